"""A well-heard wall whose ridge runs on past its ends is not seen through there.

A desk's face, y = 1 m from x = -1 to 1 m, is heard head on by 61 readings from a pass
1 m below it. The map's ridge runs on a metre past each end (the tails of the arcs), and
30 readings of the same pass beyond the desk's ends range 3 m, past where the ridge
runs: they see through the ridge's run-on, not through the stretch that echoed. The
face stays, cut back to its echoes, however few readings heard it (a sparse log hears a
2 m face from 20 poses). A line that readings see through between its echoes (a chance
crossing of arcs, which the sound crossed where it would stand) still goes.
"""

from __future__ import annotations

import math

import numpy as np
from ridges import straight_ridge

from sonarproc.surfaces.echoes.refine import MAX_SEEN_THROUGH, WEAK_ECHOES, refine_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry, echo_points
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit

CELL = 0.01
HALF_BEAM = math.radians(15.0)


def _readings(n_face: int) -> EchoGeometry:
    face = np.linspace(-0.9, 0.9, n_face)
    past = np.r_[np.linspace(-2.0, -1.1, 15), np.linspace(1.1, 2.0, 15)]
    x = np.r_[face, past]
    rng = np.r_[np.full(face.size, 1.0), np.full(past.size, 3.0)]
    return EchoGeometry(np.c_[x, np.zeros(x.size)], np.full(x.size, math.pi / 2),
                        np.full(x.size, HALF_BEAM), rng)  # fmt: skip


def _ridge() -> tuple[SurfaceFit, SurfaceCells]:
    return straight_ridge((-2.0, 0.98), (2.0, 0.98), CELL)


def test_readings_past_the_ends_see_through_the_ridge_only_there() -> None:
    g = _readings(61)
    fit, _ = _ridge()
    (whole,) = echo_points([fit.polyline], [False], g, tol=0.08)
    (spanned,) = echo_points([fit.polyline], [False], g, tol=0.08, spanned_from=WEAK_ECHOES)
    assert whole.readings.size == spanned.readings.size == 61
    # 28 (those at the ridge's very ends have no foot inside it) of the 89 facing
    # readings see through the whole ridge: more than a wall may have
    assert whole.seen_through == 28
    assert whole.seen_through > MAX_SEEN_THROUGH * (61 + whole.seen_through)
    assert spanned.seen_through == 0


def test_a_well_heard_face_stays_where_it_echoed() -> None:
    fit, cells = _ridge()
    kept, _ = refine_fits([fit], [cells], _readings(61), cell=CELL)
    assert len(kept) == 1
    np.testing.assert_allclose(kept[0].polyline[:, 1], 1.0, atol=0.01)
    assert kept[0].polyline[:, 0].min() > -1.2 and kept[0].polyline[:, 0].max() < 1.2


def test_a_face_few_readings_heard_stays_where_it_echoed() -> None:
    # a sparse log: the face heard from 20 poses, fewer than WEAK_ECHOES, and the same 30
    # readings past its ends seeing through the ridge's run-on only
    n = 20
    assert n < WEAK_ECHOES
    fit, cells = _ridge()
    kept, _ = refine_fits([fit], [cells], _readings(n), cell=CELL)
    assert len(kept) == 1
    np.testing.assert_allclose(kept[0].polyline[:, 1], 1.0, atol=0.01)
    assert kept[0].polyline[:, 0].min() > -1.2 and kept[0].polyline[:, 0].max() < 1.2


def test_a_line_seen_through_between_its_echoes_still_goes() -> None:
    # 8 readings range 1 m at the line (a chance crossing of their arcs); 24 more from the
    # same pass, between them, range 3 m: the sound crossed where the line would stand
    echo_x = np.linspace(-0.9, 0.9, 8)
    through_x = np.linspace(-0.85, 0.85, 24)
    x = np.r_[echo_x, through_x]
    rng = np.r_[np.full(echo_x.size, 1.0), np.full(through_x.size, 3.0)]
    g = EchoGeometry(np.c_[x, np.zeros(x.size)], np.full(x.size, math.pi / 2),
                     np.full(x.size, HALF_BEAM), rng)  # fmt: skip
    fit, cells = _ridge()
    kept, _ = refine_fits([fit], [cells], g, cell=CELL)
    assert kept == []

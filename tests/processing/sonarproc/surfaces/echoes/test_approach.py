"""A wall heard only head on, from a pass driving straight at it, is kept square to the pass.

A robot drives along x = 0 towards the wall y = 2 m, its forward sensor (a few
centimetres either side of the pass) ranging it every 10 cm: every echo point lands at
the foot, one spot a few centimetres wide, at ranges from 2 m down to 0.8 m. A line
fitted through that spot alone has no direction; the pass gives it. Readings from a pass
too short to tell a changing range from noise still make no surface.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from ridges import straight_ridge

from sonarproc.surfaces.echoes.approach import (
    HEAD_ON_DEPTH_M,
    Pieces,
    approach_line,
    driven_at,
    heard_head_on,
    join_directed,
)
from sonarproc.surfaces.echoes.refine import MIN_SPREAD_M, refine_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.models import SurfaceFit

IntArray = npt.NDArray[np.intp]

CELL = 0.01
WALL_Y = 2.0
HALF_BEAM = math.radians(15.0)
#: range quantisation of the robot's sonar board (1 inch)
STEP_M = 0.0254


def _pass(depth_m: float, seed: int = 3) -> EchoGeometry:
    """Readings every 10 cm along x ~ 0 over ``depth_m``, heading at the wall."""
    rng = np.random.default_rng(seed)
    y = np.arange(0.0, depth_m + 1e-9, 0.1)
    x = rng.uniform(-0.02, 0.02, y.size)
    r = WALL_Y - y + rng.normal(0.0, 0.005, y.size)
    r = np.round(r / STEP_M) * STEP_M
    return EchoGeometry(np.c_[x, y], np.full(y.size, math.pi / 2), np.full(y.size, HALF_BEAM), r)


def _ridge() -> tuple[SurfaceFit, SurfaceCells]:
    """The map's ridge of the wall, as a short line where the arcs touch it."""
    return straight_ridge((-0.3, WALL_Y - 0.02), (0.3, WALL_Y - 0.02), CELL)


def test_a_pass_straight_at_a_wall_fixes_its_direction() -> None:
    g = _pass(1.2)
    assert heard_head_on(np.arange(g.size), g.range_m)
    fit, cells = _ridge()
    kept, pts = refine_fits([fit], [cells], g, cell=CELL)
    assert len(kept) == 1 and kept[0].model == "line"
    # the echo points at one spot, narrower than a direction needs ...
    assert float(np.ptp(pts[0].x)) < MIN_SPREAD_M
    # ... and the wall square to the pass, where it is
    d = np.asarray(kept[0].params["direction"])
    assert abs(d[1]) < math.sin(math.radians(3.0))
    np.testing.assert_allclose(kept[0].polyline[:, 1], WALL_Y, atol=0.015)
    assert kept[0].length_m >= 0.1


def test_a_short_pass_makes_no_wall() -> None:
    g = _pass(0.3)
    assert float(np.ptp(g.range_m)) < HEAD_ON_DEPTH_M
    assert not heard_head_on(np.arange(g.size), g.range_m)
    fit, cells = _ridge()
    kept, _ = refine_fits([fit], [cells], g, cell=CELL)
    assert kept == []


def test_the_line_is_square_to_the_mean_direction_to_the_sensors() -> None:
    # echo points at (1, 1) heard from sensors up and to the right along the diagonal
    pts = SurfaceCells(np.array([0.99, 1.01]), np.array([1.01, 0.99]), np.zeros(2),
                       np.ones(2), False)  # fmt: skip
    s = np.array([[1.5, 1.5], [2.0, 2.0], [2.5, 2.5]])
    f = approach_line(pts, s, cell=CELL)
    d = np.asarray(f.params["direction"])
    assert abs(float(d @ np.array([1.0, 1.0]))) < 1e-9
    np.testing.assert_allclose(0.5 * (f.polyline[0] + f.polyline[-1]), [1.0, 1.0], atol=1e-9)


def test_head_on_pieces_are_not_joined() -> None:
    calls: list[int] = []

    def join(f: list[SurfaceFit], p: list[SurfaceCells], i: list[IntArray]) -> Pieces:
        calls.append(len(f))
        return f, p, i

    wide = SurfaceCells(np.array([0.0, 1.0]), np.zeros(2), np.zeros(2), np.ones(2), False)
    spot = SurfaceCells(np.array([2.0, 2.02]), np.zeros(2), np.zeros(2), np.ones(2), False)
    fit, _ = _ridge()
    _, out_p, out_r = join_directed(join, [fit, fit], [spot, wide],
                                    [np.arange(2), np.arange(2, 4)],
                                    min_spread=MIN_SPREAD_M)  # fmt: skip
    assert calls == [1]
    assert out_p == [wide, spot]
    assert [r.tolist() for r in out_r] == [[2, 3], [0, 1]]


def _crest(centre_y: float, radius: float) -> tuple[SurfaceFit, SurfaceCells]:
    """The ridge of the pass's arcs, all tangent at the foot (0, WALL_Y): it bends towards
    the sensors with their own curvature and is fitted as an arc centred among them."""
    a = np.radians(np.linspace(60.0, 120.0, 121))
    xy = np.c_[radius * np.cos(a), centre_y + radius * np.sin(a)]
    cells = SurfaceCells(xy[:, 0], xy[:, 1], np.arange(len(xy)) * CELL, np.ones(len(xy)), False)
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit) and fit.model == "arc"
    return fit, cells


def test_a_pass_whose_crest_is_fitted_as_an_arc_keeps_its_wall() -> None:
    g = _pass(1.2)
    fit, cells = _crest(1.25, WALL_Y - 1.25)
    kept, _ = refine_fits([fit], [cells], g, cell=CELL)
    # no sensor's foot falls inside the arc (they lie beyond its centre): the wall is its
    # tangent where the arcs touch, refitted square to the pass
    assert len(kept) == 1 and kept[0].model == "line"
    d = np.asarray(kept[0].params["direction"])
    assert abs(d[1]) < math.sin(math.radians(3.0))
    np.testing.assert_allclose(kept[0].polyline[:, 1], WALL_Y, atol=0.015)


def test_an_arc_heard_from_sensors_drifting_sideways_stays_dropped() -> None:
    # the same ranges, from sensors that drift 0.6 m across their axis on the way (feet
    # spread along the wall, no pass along its normal): the head-on rule is not theirs
    g = _pass(1.2)
    moved = EchoGeometry(np.c_[0.5 * g.xy[:, 1] - 0.3, g.xy[:, 1]], g.heading, g.half_beam,
                         g.range_m)  # fmt: skip
    assert not driven_at(moved.xy, moved.heading, across=MIN_SPREAD_M)
    assert driven_at(g.xy, g.heading, across=MIN_SPREAD_M)
    fit, cells = _crest(1.25, WALL_Y - 1.25)
    kept, _ = refine_fits([fit], [cells], moved, cell=CELL)
    assert kept == []

"""Sparse logs: a long wall comes out as one surface, and a doorway seen through stays open.

Analytic pieces first: a wall y = 1 seen by sensors on y = 0 looking up (a Pioneer's
15 degree half beam), its echo points a few per metre with a centimetre of range noise, as
a robot passing once with a sonar firing every few centimetres leaves them; then the
simulated sparse corridor of tests/data/scenarios with half of its readings dropped, as a
driver that publishes only fresh values drops them.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sonarproc.surfaces.echoes.openings import STRAIGHT_SHARE, join_pieces
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import FreeCones

CELL = 0.01
HALF_BEAM = math.radians(15.0)
MARGIN = 0.03  # the last refinement round's range tolerance (m)
BEHIND = 3.0  # range (m) of a reading that saw through an opening


def _points(x: np.ndarray, y: np.ndarray) -> SurfaceCells:
    return SurfaceCells(x, y, x - x[0], np.ones_like(x), False)


def _pieces() -> tuple[list[SurfaceFit], list[SurfaceCells], list[np.ndarray]]:
    """A long piece (25 echo points over 3 m, 1 cm either way) and a short one (7 points
    over 1.2 m, 6 mm either way, its line tilted 1.5 degrees by its noise) of y = 1."""
    xa = np.linspace(0.0, 3.0, 25)
    ya = 1.0 + 0.01 * (-1.0) ** np.arange(25)
    xb = np.linspace(3.3, 4.5, 7)
    yb = 1.0 + math.tan(math.radians(1.5)) * (xb - 3.9) + 0.006 * (-1.0) ** np.arange(7)
    pts = [_points(xa, ya), _points(xb, yb)]
    fits = fit_surfaces(pts, cell=CELL, scatter=STRAIGHT_SHARE * MARGIN)
    assert all(isinstance(f, SurfaceFit) and f.model == "line" for f in fits)
    return [f for f in fits if isinstance(f, SurfaceFit)], pts, [np.arange(25), 25 + np.arange(7)]


def _cones(gap_seen_through: bool) -> FreeCones:
    """Sensors every 10 cm on y = 0 looking up; under the gap they range the room behind
    it when it was seen through, else nothing at all fired there (a sparse log)."""
    x = np.arange(0.05, 4.5, 0.10)
    in_gap = (x > 3.0) & (x < 3.3)
    if not gap_seen_through:
        x = x[~in_gap]
        in_gap = in_gap[~in_gap]
    r = np.where(in_gap, BEHIND, 1.0)
    n = x.size
    return FreeCones.of(np.c_[x, np.zeros(n)], np.full(n, math.pi / 2), np.full(n, HALF_BEAM), r)


def test_a_sparse_straight_wall_is_fitted_as_a_line_not_a_curve_threading_its_noise() -> None:
    """25 echo points alternating 1 cm about a 3 m wall: the spline or arc that threads
    them explains nothing the range noise does not, so the wall is a line."""
    x = np.linspace(0.0, 3.0, 25)
    pts = _points(x, 1.0 + 0.01 * (-1.0) ** np.arange(25))
    (fit,) = fit_surfaces([pts], cell=CELL, scatter=STRAIGHT_SHARE * MARGIN)
    assert isinstance(fit, SurfaceFit) and fit.model == "line"
    assert fit.rms_m == pytest.approx(0.01, abs=1e-3)


def test_a_short_tilted_piece_joins_the_long_rest_of_its_wall() -> None:
    """The short piece's own line misses the long piece's far end by 10 cm, but the long
    piece's line passes both of its ends within their combined uncertainty, and nothing
    saw through the 30 cm gap: one surface from 0 to 4.5 m."""
    fits, pts, idx = _pieces()
    joined, _, readings = join_pieces(fits, pts, idx, _cones(False), margin=MARGIN, cell=CELL)
    assert len(joined) == 1
    xs = joined[0].polyline[:, 0]
    assert (float(xs.min()), float(xs.max())) == (pytest.approx(0.0, abs=0.02),
                                                  pytest.approx(4.5, abs=0.02))  # fmt: skip
    assert sorted(readings[0].tolist()) == list(range(32))


def test_the_same_pieces_stay_two_where_readings_saw_through_the_gap() -> None:
    fits, pts, idx = _pieces()
    joined, _, _ = join_pieces(fits, pts, idx, _cones(True), margin=MARGIN, cell=CELL)
    assert len(joined) == 2


SCENE = Path(__file__).resolve().parents[4] / "data" / "scenarios" / "sparse10-door-corridor.yaml"


def _covering(polylines: list[np.ndarray], a: np.ndarray, b: np.ndarray) -> list[np.ndarray]:
    """The polylines at least half of whose points lie within 10 cm of segment a-b."""
    u = (b - a) / np.hypot(*(b - a))
    out = []
    for p in polylines:
        along, across = (p - a) @ u, (p - a) @ np.array([-u[1], u[0]])
        near = (np.abs(across) <= 0.10) & (along >= -0.10) & (along <= np.hypot(*(b - a)) + 0.10)
        if near.mean() >= 0.5:
            out.append(p)
    return out


@pytest.fixture(scope="module")
def sparse_corridor(tmp_path_factory: pytest.TempPathFactory) -> list[np.ndarray]:
    """The surfaces of the sparse corridor, half of its readings dropped (seeded)."""
    import dataclasses

    from sonarproc.params import RunParams
    from sonarproc.pipeline import load_log, process
    from sonarproc.simulate import write_result
    from sonarsim import scenario_from_dict, simulate

    data = yaml.safe_load(SCENE.read_text(encoding="utf-8"))
    res = simulate(scenario_from_dict(data, base_dir=SCENE.parent, source=str(SCENE)))
    keep = np.random.default_rng(1001).random(res.readings.size) >= 0.5
    path = tmp_path_factory.mktemp("sparse") / "log.h5"
    write_result(dataclasses.replace(res, readings=res.readings[keep]), path, robot="test")
    out = process(load_log(path), RunParams(fit="auto"))
    assert out.surfaces is not None
    return [p for p in out.surfaces.polylines() if len(p) > 1]


def test_each_long_wall_of_a_sparse_corridor_is_one_surface(
    sparse_corridor: list[np.ndarray],
) -> None:
    """The north wall west of its recess (x 0 .. 5 on y = 2; its readings span about
    x 0.6 .. 4.9) and east of it (x 5.9 .. 10): one surface each, over most of it."""
    for a, b, least in (((0.0, 2.0), (5.0, 2.0), 3.5), ((5.9, 2.0), (10.0, 2.0), 3.0)):
        cover = _covering(sparse_corridor, np.array(a), np.array(b))
        assert len(cover) == 1, [np.round(p[[0, -1]], 2).tolist() for p in cover]
        assert np.ptp(cover[0][:, 0]) >= least


def test_the_sparse_corridors_open_doorway_stays_open(sparse_corridor: list[np.ndarray]) -> None:
    """The south doorway (x 6.5 .. 7.4 on y = 0), which the right-hand sonars looked
    through into the room behind: no surface within 5 cm of its middle (a jamb's
    diffracted echo may carry a wall's end up to sqrt(2 d tol) = 0.24 m into it at d = 1 m,
    tol = 3 cm)."""
    reach = math.sqrt(2 * 1.0 * 0.03)
    pts = np.concatenate(sparse_corridor)
    inside = (np.abs(pts[:, 1]) <= 0.05) & (pts[:, 0] > 6.5 + reach) & (pts[:, 0] < 7.4 - reach)
    assert not inside.any()

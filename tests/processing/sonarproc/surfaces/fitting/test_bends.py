"""Two straight walls meeting at an obtuse corner are two lines, not a spline round it.

Analytic: the wall y = 1 (x 0 .. 2 m) turning up by 45 degrees at (2, 1) for 1.5 m (a
135-degree corner, which the ridge's 45-degree corner test does not split), seen by
sensors 1 m in front of each wall facing it, a reading every 5 cm with 5 mm of range
noise (seeded); and a curved wall no arc fits, which stays a curve.
"""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces.echoes.openings import STRAIGHT_SHARE
from sonarproc.surfaces.echoes.refine import refine_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface, fit_surfaces
from sonarproc.surfaces.fitting.bends import best_break, straight_pieces
from sonarproc.surfaces.fitting.models import SurfaceFit

CELL = 0.01
HALF_BEAM = math.radians(15.0)
SCATTER = STRAIGHT_SHARE * 0.03  # the last refinement round's noise bound (m)
CORNER = np.array([2.0, 1.0])
TURN = math.radians(45.0)
SECOND = np.array([math.cos(TURN), math.sin(TURN)])  # direction of the second wall


def _cells(x: np.ndarray, y: np.ndarray) -> SurfaceCells:
    s = np.r_[0.0, np.cumsum(np.hypot(np.diff(x), np.diff(y)))]
    return SurfaceCells(x, y, s, np.ones_like(x), False)


def _distance_to_walls(p: np.ndarray) -> np.ndarray:
    """Distance (m) of points to the nearer of the two true walls."""
    first = np.abs(p[:, 1] - 1.0)
    first = np.where(p[:, 0] <= CORNER[0], first, np.hypot(p[:, 0] - CORNER[0], first))
    u = np.clip((p - CORNER) @ SECOND, 0.0, 1.5)
    second = np.hypot(*(p - CORNER - u[:, None] * SECOND).T)
    return np.minimum(first, second)


def _readings() -> EchoGeometry:
    """Sensors 1 m in front of each wall facing it, every 5 cm, 5 mm range noise."""
    rng = np.random.default_rng(7)
    along1 = np.arange(0.1, 1.9 + 1e-9, 0.05)
    xy1 = np.c_[along1, np.zeros(along1.size)]
    normal2 = np.array([SECOND[1], -SECOND[0]])  # towards the sensors' side
    along2 = np.arange(0.15, 1.4 + 1e-9, 0.05)
    xy2 = CORNER + along2[:, None] * SECOND + normal2
    xy = np.vstack((xy1, xy2))
    heading = np.r_[np.full(along1.size, math.pi / 2),
                    np.full(along2.size, math.atan2(-normal2[1], -normal2[0]))]  # fmt: skip
    r = 1.0 + rng.normal(0.0, 0.005, heading.size)
    return EchoGeometry(xy, heading, np.full(heading.size, HALF_BEAM), r)


def test_the_break_of_two_straight_pieces_is_their_corner() -> None:
    a = np.arange(0.0, 2.0, 0.02)
    b = np.arange(0.02, 1.5, 0.02)
    x = np.r_[a, CORNER[0] + b * SECOND[0]]
    y = np.r_[1.0 + 0 * a, CORNER[1] + b * SECOND[1]]
    assert best_break(x, y) == a.size
    assert best_break(x[:15], y[:15]) is None


def test_two_noisy_walls_at_135_degrees_are_two_lines() -> None:
    rng = np.random.default_rng(3)
    a = np.arange(0.0, 2.0, 0.04)
    b = np.arange(0.04, 1.5, 0.04)
    x = np.r_[a, CORNER[0] + b * SECOND[0]]
    y = np.r_[1.0 + 0 * a, CORNER[1] + b * SECOND[1]] + rng.normal(0.0, 0.005, x.size)
    pts = _cells(x, y)
    (whole,) = fit_surfaces([pts], cell=CELL, scatter=SCATTER)
    assert isinstance(whole, SurfaceFit) and whole.model == "spline"
    pieces = straight_pieces(pts, cell=CELL, scatter=SCATTER)
    assert pieces is not None
    assert [f.model for f, _ in pieces] == ["line", "line"]
    assert [i.size for _, i in pieces] == [a.size, b.size]
    angles = [math.degrees(math.atan2(*np.asarray(f.params["direction"])[::-1])) for f, _ in pieces]
    assert abs(angles[0]) < 1.0 and abs(angles[1] - 45.0) < 1.0


def test_a_curved_wall_no_arc_fits_is_not_split_into_lines() -> None:
    """A parabola of 1 m radius at its apex over 3 m: half of it is no line."""
    rng = np.random.default_rng(1)
    x = np.arange(-1.5, 1.5, 0.03)
    y = 0.5 * x * x + rng.normal(0.0, 0.005, x.size)
    pts = _cells(x, y)
    (whole,) = fit_surfaces([pts], cell=CELL, scatter=SCATTER)
    assert isinstance(whole, SurfaceFit) and whole.model == "spline"
    assert straight_pieces(pts, cell=CELL, scatter=SCATTER) is None


def test_a_cut_corner_refitted_through_its_readings_is_two_lines_on_the_walls() -> None:
    """The ridge follows both walls as one group (a spline); the refit through the
    readings' echo points reports the two walls as lines, each on its wall."""
    a = np.arange(0.0, 2.0, CELL)
    b = np.arange(CELL, 1.5 + 1e-9, CELL)
    cells = _cells(
        np.r_[a, CORNER[0] + b * SECOND[0]], np.r_[1.0 + 0 * a, CORNER[1] + b * SECOND[1]]
    )
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit) and fit.model == "spline"
    out, _ = refine_fits([fit], [cells], _readings(), cell=CELL)
    assert sorted(f.model for f in out) == ["line", "line"]
    for f in out:
        d = _distance_to_walls(f.polyline)
        # on its wall; an end may overshoot the corner by a few centimetres (stretched
        # over the ridge cells within the range tolerance of its line)
        assert float(d.mean()) < 0.005 and float(d.max()) < 0.03
    lengths = sorted(round(f.length_m, 1) for f in out)
    assert lengths[0] >= 1.2 and lengths[1] >= 1.7

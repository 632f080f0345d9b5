"""The point reflector search's batched steps give the candidate-by-candidate answers exactly.

:func:`~sonarproc.surfaces.reflectors.rcd.find_point_features` gathers every candidate's
readings and runs the cheap tests for all of them at once, and fits points with
:func:`scipy.optimize.leastsq`; here each is held to the one-candidate path
(:func:`_gather`, :func:`_enough`, :func:`_test_point` without a first gather) and to
``scipy.optimize.least_squares(method="lm")``, bit for bit, on a seeded scene of two
point reflectors and a wall seen by a ring of sonars driving past.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

from sonarproc.grid import Grid
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors import rcd

POINTS = np.array([[0.0, 0.0], [1.5, 0.6]])
WALL_Y = 2.0
HALF_BEAM = math.radians(12.5)


def _scene(seed: int) -> EchoGeometry:
    """A 16-sonar ring driving along y = 1 past two points below and a wall above."""
    rng = np.random.default_rng(seed)
    x = np.repeat(np.linspace(-1.5, 3.0, 60), 16)
    heading = np.tile(np.linspace(0.0, 2 * np.pi, 16, endpoint=False), 60) + 0.05 * x
    xy = np.column_stack((x + 0.2 * np.cos(heading), 1.0 + 0.2 * np.sin(heading)))
    # first echo: the nearest reflector inside the beam (points: their distance; the
    # wall: its perpendicular distance when the normal lies inside the beam)
    rel = POINTS[None, :, :] - xy[:, None, :]
    dist = np.hypot(rel[..., 0], rel[..., 1])
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(rel[..., 1], rel[..., 0]) - heading[:, None]))))
    r = np.where(off <= HALF_BEAM, dist, np.inf).min(axis=1)
    up = np.abs(np.angle(np.exp(1j * (heading - np.pi / 2)))) <= HALF_BEAM
    r = np.minimum(r, np.where(up, WALL_Y - xy[:, 1], np.inf))
    # a fifth of the readings are stray echoes (chance crossings of arcs: weak candidates)
    stray = rng.random(r.size) < 0.2
    r = np.where(stray, rng.uniform(0.3, 2.5, r.size), r)
    heard = np.isfinite(r)
    r = r + rng.normal(0.0, 0.005, r.size)
    return EchoGeometry(xy[heard], heading[heard], np.full(int(heard.sum()), HALF_BEAM), r[heard])


def _counts(echoes: EchoGeometry, grid: Grid) -> np.ndarray:
    """Arc votes per cell: readings whose arc (within the range tolerance, in the beam) holds it."""
    iy, ix = np.mgrid[0 : grid.ny, 0 : grid.nx]
    cx, cy = grid.to_world(iy.ravel(), ix.ravel())
    counts = np.zeros(iy.size, dtype=np.int64)
    for s, h, b, r in zip(echoes.xy, echoes.heading, echoes.half_beam, echoes.range_m, strict=True):
        d = np.hypot(cx - s[0], cy - s[1])
        off = np.abs(np.angle(np.exp(1j * (np.arctan2(cy - s[1], cx - s[0]) - h))))
        counts += (np.abs(d - r) <= rcd.RANGE_TOL_M) & (off <= b)
    return counts.reshape(grid.shape)


def _one_by_one(
    echoes: EchoGeometry, counts: np.ndarray, grid: Grid, free: np.ndarray
) -> list[rcd.PointFeature]:
    """The search candidate by candidate (every gather and cheap test on its own)."""
    free = free.copy()
    found: list[rcd.PointFeature] = []
    starts = rcd.candidates(counts, grid)
    index = rcd._ArcIndex(echoes, free)
    for c in starts:
        if found and min(math.dist(c, f.xy) for f in found) < rcd.CANDIDATE_SPACING_M:
            continue
        feature = rcd._test_point(echoes, free, c, index)
        if feature is not None:
            free[feature.readings] = False
            found.append(feature)
    return found


@pytest.fixture(scope="module")
def scene() -> tuple[EchoGeometry, np.ndarray, Grid]:
    echoes = _scene(3)
    grid = Grid(x0=-1.0, y0=-0.5, cell=0.02, nx=210, ny=140)
    return echoes, _counts(echoes, grid), grid


def test_the_scene_has_both_points(scene: tuple[EchoGeometry, np.ndarray, Grid]) -> None:
    echoes, counts, grid = scene
    found = rcd.find_point_features(echoes, counts, grid)
    for p in POINTS:
        assert min(math.dist(p, f.xy) for f in found) < 0.02


@pytest.mark.parametrize("seed", [0, 1])
def test_batched_gathers_and_cheap_tests_are_the_one_by_one_ones(
    scene: tuple[EchoGeometry, np.ndarray, Grid], seed: int
) -> None:
    echoes, counts, grid = scene
    rng = np.random.default_rng(seed)
    free = rng.random(echoes.size) < 0.9
    starts = rcd.candidates(counts, grid)
    index = rcd._ArcIndex(echoes, free)
    gathers = rcd._gather_all(echoes, free, starts, index)
    verdicts = rcd._enough_all(echoes, gathers)
    later = free & (rng.random(echoes.size) < 0.8)  # readings claimed meanwhile
    assert len(gathers) == starts.shape[0] >= 10
    assert (verdicts == 1).any() and (verdicts == 0).any()
    for c, g, v in zip(starts, gathers, verdicts.tolist(), strict=True):
        np.testing.assert_array_equal(g, rcd._gather(echoes, free, c, index))
        np.testing.assert_array_equal(g[later[g]], rcd._gather(echoes, later, c, index))
        assert v == -1 or bool(v) == rcd._enough(echoes, g)


@pytest.mark.parametrize("claimed", [0.0, 0.3])
def test_the_search_finds_what_the_one_by_one_search_finds(
    scene: tuple[EchoGeometry, np.ndarray, Grid], claimed: float
) -> None:
    echoes, counts, grid = scene
    free = np.random.default_rng(7).random(echoes.size) >= claimed
    got = rcd.find_point_features(echoes, counts, grid, free=free)
    want = _one_by_one(echoes, counts, grid, free)
    assert len(got) == len(want) >= 1
    for a, b in zip(got, want, strict=True):
        np.testing.assert_array_equal(a.xy, b.xy)
        np.testing.assert_array_equal(a.readings, b.readings)
        assert (a.poses, a.rms_m, a.plane_rms_m, a.span_rad) == (
            b.poses,
            b.rms_m,
            b.plane_rms_m,
            b.span_rad,
        )


@pytest.mark.parametrize("seed", range(5))
def test_leastsq_solves_as_least_squares_lm_to_the_last_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-2.0, 2.0, (12, 2))
    p = rng.uniform(-1.0, 1.0, 2) + np.array([0.0, 3.0])
    r = np.hypot(*(xy - p).T) + 0.05 + rng.normal(0.0, 0.01, 12)

    def res(q: np.ndarray) -> np.ndarray:
        return np.asarray(np.hypot(xy[:, 0] - q[0], xy[:, 1] - q[1]) - q[2] - r)

    def jac(q: np.ndarray) -> np.ndarray:
        d = q[:2] - xy
        return np.column_stack((d / np.hypot(d[:, 0], d[:, 1])[:, None], -np.ones(12)))

    x0 = np.r_[p + rng.normal(0.0, 0.03, 2), 0.0]
    want = least_squares(res, x0, jac=jac, method="lm").x
    np.testing.assert_array_equal(rcd._levenberg_marquardt(res, jac, x0), want)

"""The extraction of all surfaces at once: grouped numpy helpers, neighbour searches,
and the whole of :func:`extract_surfaces` against the one-group-at-a-time oracle."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from extract_reference import extract_surfaces_reference
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.grid import Grid
from sonarproc.surfaces import SurfaceParams, extract_surfaces
from sonarproc.surfaces.extraction.coarse import coarse_counts
from sonarproc.surfaces.planar.runs import (
    ragged_arange,
    run_cumsum,
    run_interp,
    run_median,
    run_searchsorted,
)

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def _runs(rng: np.random.Generator, n_runs: int) -> tuple[np.ndarray, np.ndarray]:
    """Sorted knots in runs (some empty, some with repeated values) and the run bounds."""
    sizes = rng.integers(0, 12, n_runs)
    parts = [np.sort(rng.integers(0, 20, k) * 0.25 + rng.choice([0.0, 1e-3])) for k in sizes]
    return np.concatenate([*parts, np.zeros(0)]), np.concatenate(([0], np.cumsum(sizes)))


@settings(max_examples=60, deadline=None)
@given(SEEDS, st.integers(1, 8))
def test_run_helpers_equal_numpy_on_each_run(seed: int, n_runs: int) -> None:
    rng = np.random.default_rng(seed)
    knots, bounds = _runs(rng, n_runs)
    fp = rng.normal(size=knots.size)
    q = rng.integers(-2, 22, 40) * 0.25 + rng.choice([0.0, 0.1, 1e-3], 40)
    run = rng.integers(0, n_runs, q.size)
    runs = [slice(int(a), int(b)) for a, b in itertools.pairwise(bounds)]
    for side in ("left", "right"):
        want = [np.searchsorted(knots[runs[r]], t, side=side) for r, t in zip(run, q, strict=True)]
        assert run_searchsorted(knots, bounds, q, run, side=side).tolist() == want
    cums = run_cumsum(fp, bounds)
    for sl in runs:
        assert np.array_equal(cums[sl], np.cumsum(fp[sl]))
    med = run_median(fp, bounds)
    for g, sl in enumerate(runs):
        if sl.stop > sl.start:
            assert med[g] == np.median(fp[sl])
        else:
            assert math.isnan(med[g])
    filled = np.flatnonzero(np.diff(bounds) > 0)
    if filled.size:
        qr = filled[rng.integers(0, filled.size, q.size)]
        got = run_interp(q, qr, knots, fp, bounds)
        want_i = [np.interp(t, knots[runs[r]], fp[runs[r]]) for r, t in zip(qr, q, strict=True)]
        assert np.array_equal(got, np.asarray(want_i))
        both = run_interp(q, qr, knots, np.stack((fp, -2 * fp), 1), bounds)
        assert np.array_equal(both[:, 0], got) and np.array_equal(both[:, 1], run_interp(
            q, qr, knots, -2 * fp, bounds))  # fmt: skip


def test_ragged_arange_counts_within_each_run() -> None:
    run, k = ragged_arange([3, 0, 1, 2])
    assert run.tolist() == [0, 0, 0, 2, 3, 3]
    assert k.tolist() == [0, 1, 2, 0, 0, 1]


def _lattice_points(rng: np.random.Generator, n: int) -> np.ndarray:
    """Points on a lattice (many equal distances) with a few off it, over a few metres."""
    pts = rng.integers(0, 120, (n, 2)) * 0.025
    off = rng.random(n) < 0.3
    pts[off] += rng.normal(0.0, 0.01, (int(off.sum()), 2))
    return np.unique(pts, axis=0)


def _cells(points: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    q = np.unique(np.round(points / cell).astype(np.int64), axis=0) * cell
    return q[:, 0], q[:, 1]


def _segment(a: np.ndarray, b: np.ndarray, step: float) -> np.ndarray:
    t = np.linspace(0.0, 1.0, max(2, int(np.hypot(*(b - a)) / step) + 1))[:, None]
    return a + (b - a) * t


def _scene(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Walls, a T junction, a ring, a thick band and clutter, as cell centres with weights."""
    rng = np.random.default_rng(seed)
    cell = float(rng.choice([0.01, 0.02]))
    parts = []
    for _ in range(int(rng.integers(1, 4))):
        a = rng.uniform(0.0, 4.0, 2)
        b = a + rng.uniform(0.3, 2.0) * np.array(
            [math.cos(th := rng.uniform(0, 2 * math.pi)), math.sin(th)]
        )
        parts.append(_segment(a, b, cell / 3))
    if rng.random() < 0.5:  # a T: a stem off the middle of the first wall
        mid = parts[0][len(parts[0]) // 2]
        parts.append(_segment(mid, mid + rng.uniform(-0.6, 0.6, 2), cell / 3))
    if rng.random() < 0.5:  # a pillar seen all round
        t = np.linspace(0, 2 * math.pi, 400)
        radius = rng.uniform(0.2, 0.5)
        parts.append(rng.uniform(5.0, 6.0, 2) + radius * np.column_stack((np.cos(t), np.sin(t))))
    if rng.random() < 0.5:  # a band a few cells thick
        band = _segment(np.array([0.0, 5.0]), np.array([1.5, 5.3]), cell / 3)
        parts.append(band + rng.normal(0.0, 1.5 * cell, band.shape))
    parts.append(rng.uniform(0.0, 6.0, (int(rng.integers(0, 60)), 2)))  # clutter
    x, y = _cells(np.concatenate(parts), cell)
    return x, y, rng.integers(1, 9, x.size).astype(np.float64), cell


@settings(max_examples=25, deadline=None)
@given(SEEDS)
def test_extraction_equals_the_one_group_at_a_time_oracle(seed: int) -> None:
    x, y, w, cell = _scene(seed)
    params = SurfaceParams()
    got = extract_surfaces(x, y, cell=cell, weight=w, params=params)
    want = extract_surfaces_reference(x, y, cell=cell, weight=w, params=params)
    assert len(got) == len(want)
    for g, r in zip(got, want, strict=True):
        assert g.closed == r.closed
        assert np.array_equal(g.x, r.x) and np.array_equal(g.y, r.y)
        assert np.array_equal(g.s, r.s) and np.array_equal(g.weight, r.weight)


@settings(max_examples=30, deadline=None)
@given(
    SEEDS,
    st.floats(0.4, 1.5),
    st.floats(0.4, 1.5),
    st.floats(0.0, 2 * math.pi),
    st.floats(75.0, 150.0),
    st.sampled_from([-1.0, 1.0]),
    st.sampled_from([0.01, 0.02]),
)
def test_an_l_splits_into_its_two_legs_at_the_corner(
    seed: int, l1: float, l2: float, heading: float, turn_deg: float, sense: float, cell: float
) -> None:
    rng = np.random.default_rng(seed)
    corner = rng.uniform(-3.0, 3.0, 2)
    turn = sense * math.radians(turn_deg)
    d1 = np.array([math.cos(heading), math.sin(heading)])
    d2 = np.array([math.cos(heading + turn), math.sin(heading + turn)])
    x, y = _cells(np.concatenate((_segment(corner - l1 * d1, corner, cell / 4),
                                  _segment(corner, corner + l2 * d2, cell / 4))), cell)  # fmt: skip
    p = SurfaceParams()
    found = extract_surfaces(x, y, cell=cell, params=p)
    assert len(found) == 2
    for f in found:
        assert not f.closed
        assert np.all(np.diff(f.s) >= 0.0) and f.s[0] == 0.0
        # one leg each: all its cells near one line, but for the corner's own window
        xy = np.column_stack((f.x, f.y)) - corner
        far = np.hypot(*xy.T) > p.corner_window_m
        off1 = np.abs(xy[far] @ np.array([-d1[1], d1[0]]))
        off2 = np.abs(xy[far] @ np.array([-d2[1], d2[0]]))
        assert (off1 <= cell).all() or (off2 <= cell).all()
    # the cut: an end of each piece within the corner window of the corner
    for f in found:
        ends = np.array([[f.x[0], f.y[0]], [f.x[-1], f.y[-1]]]) - corner
        assert np.hypot(*ends.T).min() <= p.corner_window_m
    lengths = sorted(f.extent_m for f in found)
    assert lengths == pytest.approx(sorted((l1, l2)), abs=2 * p.corner_window_m)


@settings(max_examples=20, deadline=None)
@given(SEEDS, st.floats(0.25, 1.0), st.sampled_from([0.01, 0.02]))
def test_a_ring_is_one_closed_surface_ordered_round_it(
    seed: int, radius: float, cell: float
) -> None:
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2 * math.pi, int(2 * math.pi * radius / (cell / 4)))
    centre = rng.uniform(-2.0, 2.0, 2)
    x, y = _cells(centre + radius * np.column_stack((np.cos(t), np.sin(t))), cell)
    (ring,) = extract_surfaces(x, y, cell=cell)
    assert ring.closed and ring.size == x.size
    assert ring.extent_m == pytest.approx(2 * math.pi * radius, rel=0.1)
    # ordered round it: the angle about the centre moves one way, in small steps (the
    # cells pooled into one node of side h share an arc length: back by less than 2 h)
    ang = np.unwrap(np.arctan2(ring.y - centre[1], ring.x - centre[0]))
    step = np.diff(ang) * np.sign(ang[-1] - ang[0])
    h = max(cell, SurfaceParams().bridge_m / 4)
    assert (step > -2 * h / radius).all()
    assert abs(ang[-1] - ang[0]) == pytest.approx(2 * math.pi, abs=0.2)


@settings(max_examples=40, deadline=None)
@given(SEEDS, st.integers(1, 40), st.integers(1, 40), st.sampled_from([0.01, 0.02, 0.03, 0.05]))
def test_coarse_counts_sum_blocks_as_a_zero_padded_map(
    seed: int, ny: int, nx: int, to: float
) -> None:
    rng = np.random.default_rng(seed)
    counts = rng.integers(0, 9, (ny, nx)).astype(np.uint32)
    grid = Grid(0.3, -0.2, 0.01, nx, ny)
    got, coarse = coarse_counts(counts, grid, to)
    k = round(to / 0.01)
    padded = np.zeros((-(-ny // k) * k, -(-nx // k) * k), dtype=np.int64)
    padded[:ny, :nx] = counts
    want = padded.reshape(padded.shape[0] // k, k, padded.shape[1] // k, k).sum(axis=(1, 3))
    assert got.dtype == np.int64 and np.array_equal(got, want)
    assert (coarse.nx, coarse.ny, coarse.cell) == (want.shape[1], want.shape[0], k * 0.01)
    assert coarse.x0 == pytest.approx(0.3 + 0.5 * (k - 1) * 0.01)

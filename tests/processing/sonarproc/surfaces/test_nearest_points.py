"""Nearest points, radius pairs and feet without a k-d tree, against brute force."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.pipeline.surfacefit import column_spans
from sonarproc.surfaces.planar import nearest, neighbours
from sonarproc.surfaces.planar.feet import feet_on_polyline, feet_on_polylines
from sonarproc.surfaces.planar.nearest import BRANCH, nearest_points
from sonarproc.surfaces.planar.neighbours import pairs_within
from sonarproc.surfaces.planar.polylines import distance_to_polylines

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def _targets(rng: np.random.Generator, kind: int, k: int) -> np.ndarray:
    """Points on a lattice (ties), a smooth curve, a straight line, or scattered."""
    if kind == 0:
        return rng.integers(0, 12, (k, 2)) * 0.25
    if kind == 1:
        s = np.linspace(0.0, rng.uniform(0.5, 6.0), k)
        return np.column_stack((np.cos(s), np.sin(s))) * 3.0 + rng.normal(0, 1e-3, (k, 2))
    if kind == 2:
        return np.column_stack((np.linspace(-2.0, 2.0, k), np.full(k, 0.5)))
    return rng.normal(0.0, 2.0, (k, 2))


def _brute(q: np.ndarray, t: np.ndarray) -> np.ndarray:
    dx = q[:, None, 0] - t[None, :, 0]
    dy = q[:, None, 1] - t[None, :, 1]
    return np.asarray(dx * dx + dy * dy)


@settings(max_examples=80, deadline=None)
@given(SEEDS, st.integers(0, 3), st.integers(1, 5 * BRANCH**2), st.integers(0, 4), st.booleans())
def test_nearest_points_are_the_brute_force_ones(
    seed: int, kind: int, k: int, pieces: int, reorder: bool
) -> None:
    rng = np.random.default_rng(seed)
    t = _targets(rng, kind, k)
    # queries on the lattice too (exact ties), near and far (metres away)
    q = np.concatenate((rng.integers(-4, 16, (40, 2)) * 0.25, rng.normal(0, 6.0, (40, 2))))
    d2 = _brute(q, t)
    cuts = np.sort(rng.integers(0, k + 1, pieces))
    bounds = np.concatenate(([0], cuts, [k]))
    # all pieces: the nearest of all targets, ties to the lower index
    dist, near = nearest_points(t, q, bounds=bounds, reorder=reorder)
    want = np.argmin(d2, axis=1)
    assert np.array_equal(near, want)
    assert np.array_equal(dist, np.sqrt(d2[np.arange(q.shape[0]), want]))
    # one piece per query (some of them empty: no target)
    run = rng.integers(0, bounds.size - 1, q.shape[0])
    dist, near = nearest_points(t, q, bounds=bounds, run=run, reorder=reorder)
    lo, hi = bounds[run], bounds[run + 1]
    cols = np.arange(k)
    inside = (cols >= lo[:, None]) & (cols < hi[:, None])
    masked = np.where(inside, d2, np.inf)
    best = masked.min(axis=1)
    want = np.where(hi > lo, np.argmin(masked, axis=1), -1)
    assert np.array_equal(near, want)
    assert np.array_equal(dist, np.where(hi > lo, np.sqrt(best), np.inf))


def test_nearest_points_of_nothing() -> None:
    d, k = nearest_points(np.zeros((0, 2)), np.ones((3, 2)))
    assert d.tolist() == [np.inf] * 3 and k.tolist() == [-1] * 3
    d, k = nearest_points(np.ones((3, 2)), np.zeros((0, 2)))
    assert d.shape == k.shape == (0,)


@settings(max_examples=60, deadline=None)
@given(SEEDS, st.integers(0, 3), st.integers(0, 300), st.integers(0, 30))
def test_pairs_within_are_all_pairs_within_each_radius(
    seed: int, kind: int, m: int, n: int
) -> None:
    rng = np.random.default_rng(seed)
    b = _targets(rng, kind, m) if m else np.zeros((0, 2))
    a = np.concatenate((rng.integers(-2, 14, (n, 2)) * 0.25, rng.normal(0, 3.0, (n, 2))))
    r = rng.choice([0.0, 0.25, 0.5, 1.0, 7.0], a.shape[0]) * rng.choice([1.0, 1.0 + 1e-12])
    i, j, d2 = pairs_within(a, b, r)
    full = _brute(a, b) if m else np.zeros((a.shape[0], 0))
    wi, wj = np.nonzero(full <= (r * r)[:, None])
    got = sorted(zip(i.tolist(), j.tolist(), strict=True))
    assert got == list(zip(wi.tolist(), wj.tolist(), strict=True))
    assert np.array_equal(np.sort(i), i)  # by centre
    assert np.array_equal(d2, full[i, j])


def _wiggle(rng: np.random.Generator, k: int, closed: bool) -> np.ndarray:
    s = np.linspace(0.0, 2 * np.pi if closed else rng.uniform(1.0, 4.0), k)
    r = 2.0 + 0.3 * np.sin(3 * s)
    p = np.column_stack((r * np.cos(s), r * np.sin(s))) + rng.uniform(-5, 5, 2)
    if closed:
        p[-1] = p[0]
    return p


@settings(max_examples=30, deadline=None)
@given(SEEDS, st.integers(1, 6))
def test_feet_on_many_polylines_are_those_of_each_polyline(seed: int, n_polys: int) -> None:
    rng = np.random.default_rng(seed)
    closed = [bool(c) for c in rng.random(n_polys) < 0.3]
    polys = [_wiggle(rng, int(rng.integers(2, 300)), c) for c in closed]
    q = rng.normal(0.0, 6.0, (200, 2))
    surf = rng.integers(0, n_polys, q.shape[0])
    got = feet_on_polylines(q, polys, surf, closed)
    for i in range(n_polys):
        sel = surf == i
        if sel.any():
            want = feet_on_polyline(q[sel], polys[i], closed[i])
            for g, w in zip(got, want, strict=True):
                assert np.array_equal(g[sel], w)


def test_feet_on_a_polyline_are_the_nearest_points_of_its_segments() -> None:
    rng = np.random.default_rng(11)
    poly = _wiggle(rng, 400, False)
    q = rng.normal(0.0, 8.0, (300, 2))
    d, foot, _, _ = feet_on_polyline(q, poly, False)
    # dense resampling of every segment: no point of the polyline is nearer than the foot
    t = np.linspace(0.0, 1.0, 41)[:, None, None]
    dense = (poly[:-1] + t * (poly[1:] - poly[:-1])).reshape(-1, 2)
    assert np.all(d <= np.sqrt(_brute(q, dense).min(axis=1)) + 1e-12)
    assert np.allclose(np.hypot(*(q - foot).T), d, rtol=0, atol=1e-12)


def test_distance_to_polylines_is_the_distance_to_the_nearest_segment() -> None:
    rng = np.random.default_rng(2)
    polys = [_wiggle(rng, int(rng.integers(2, 200)), False) for _ in range(5)]
    q = rng.normal(0.0, 5.0, (400, 2))
    got = distance_to_polylines(q, polys, chunk=97)
    t = np.linspace(0.0, 1.0, 201)[:, None, None]
    dense = np.concatenate([(p[:-1] + t * (p[1:] - p[:-1])).reshape(-1, 2) for p in polys])
    want = np.sqrt(_brute(q, dense).min(axis=1))
    assert np.all(got <= want + 1e-12)
    assert np.all(got >= want - 1e-3)  # the dense sampling is 1/200 of a step


@settings(max_examples=60, deadline=None)
@given(SEEDS, st.integers(1, 40), st.integers(1, 40), st.sampled_from([0.0, 0.05, 0.5]))
def test_column_spans_are_lowest_to_highest_kept_cell(
    seed: int, ny: int, nx: int, density: float
) -> None:
    m = np.random.default_rng(seed).random((ny, nx)) < density
    rows = np.arange(ny)[:, None]
    occupied = m.any(axis=0)
    top = np.where(m, rows, -1).max(axis=0)[occupied]
    bottom = np.where(m, rows, ny).min(axis=0)[occupied]
    assert np.array_equal(column_spans(m, 0.25), (top - bottom + 1) * 0.25)


def test_searches_in_small_slices_give_the_same_answers(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(4)
    t = _targets(rng, 1, 500)
    q = np.concatenate((t[::7] + rng.normal(0, 0.01, (72, 2)), rng.normal(0, 5.0, (60, 2))))
    r = rng.uniform(0.0, 2.0, q.shape[0])
    want_pairs = pairs_within(q, t, r)
    want_near = nearest_points(t, q, bounds=[0, 200, 500])
    monkeypatch.setattr(neighbours, "PAIR_CHUNK", 7)
    monkeypatch.setattr(nearest, "QUERY_CHUNK", 5)
    got_pairs = pairs_within(q, t, r)
    for g, w in zip(got_pairs, want_pairs, strict=True):
        assert np.array_equal(g, w)
    got_near = nearest_points(t, q, bounds=[0, 200, 500])
    for g, w in zip(got_near, want_near, strict=True):
        assert np.array_equal(g, w)
    # the tree alone (no bucket search first) finds the same
    monkeypatch.setattr(nearest, "NEAR_STEPS", 0.0)
    for g, w in zip(nearest_points(t, q, bounds=[0, 200, 500]), want_near, strict=True):
        assert np.array_equal(g, w)

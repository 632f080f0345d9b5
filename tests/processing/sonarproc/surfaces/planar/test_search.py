"""The k-d tree searches against brute force: pairs, nearest points, by group and by piece.

Equally near targets may come back in any order, so a nearest target is checked by its
distance (the brute-force least) and an index that has that distance.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces.planar.search import (
    close_pairs,
    nearest_in_run,
    nearest_points,
    nearest_within,
    pairs_within,
)

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


def _check_nearest(d2: np.ndarray, dist: np.ndarray, near: np.ndarray) -> None:
    """``near`` is a least of each row of ``d2`` (-1 and inf for an all-inf row)."""
    best = d2.min(axis=1) if d2.shape[1] else np.full(d2.shape[0], np.inf)
    found = np.isfinite(best)
    assert np.array_equal(near >= 0, found)
    rows = np.flatnonzero(found)
    assert np.array_equal(d2[rows, near[rows]], best[rows])
    np.testing.assert_allclose(dist[rows], np.sqrt(best[rows]), rtol=1e-15, atol=0)
    assert np.all(np.isinf(dist[~found]))


@settings(max_examples=80, deadline=None)
@given(SEEDS, st.integers(0, 3), st.integers(1, 300), st.integers(0, 4))
def test_nearest_points_are_the_brute_force_ones(seed: int, kind: int, k: int, pieces: int) -> None:
    rng = np.random.default_rng(seed)
    t = _targets(rng, kind, k)
    # queries on the lattice too (exact ties), near and far (metres away)
    q = np.concatenate((rng.integers(-4, 16, (40, 2)) * 0.25, rng.normal(0, 6.0, (40, 2))))
    d2 = _brute(q, t)
    _check_nearest(d2, *nearest_points(t, q))
    # one piece per query (some of them empty: no target)
    cuts = np.sort(rng.integers(0, k + 1, pieces))
    bounds = np.concatenate(([0], cuts, [k]))
    run = rng.integers(0, bounds.size - 1, q.shape[0])
    cols = np.arange(k)
    inside = (cols >= bounds[run][:, None]) & (cols < bounds[run + 1][:, None])
    _check_nearest(np.where(inside, d2, np.inf), *nearest_points(t, q, bounds=bounds, run=run))


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


def _lattice_points(rng: np.random.Generator, n: int) -> np.ndarray:
    """Points on a 5 cm lattice (many exactly equal distances), some moved off it."""
    pts = rng.integers(0, 20, (n, 2)) * 0.05
    off = rng.random(n) < 0.3
    pts[off] += rng.normal(0.0, 0.01, (int(off.sum()), 2))
    return np.unique(pts, axis=0)


@settings(max_examples=40, deadline=None)
@given(SEEDS, st.sampled_from([0.05, 0.1 + 1e-9, 0.25]))
def test_close_pairs_are_all_pairs_within_r(seed: int, r: float) -> None:
    pos = _lattice_points(np.random.default_rng(seed), 400)
    i, j, d2 = close_pairs(pos, r)
    full = _brute(pos, pos)
    wi, wj = np.nonzero(np.triu(full <= r * r, k=1))
    assert sorted(zip(i.tolist(), j.tolist(), strict=True)) == list(
        zip(wi.tolist(), wj.tolist(), strict=True)
    )
    assert np.array_equal(d2, full[i, j])


@settings(max_examples=40, deadline=None)
@given(SEEDS)
def test_nearest_searches_by_group_and_by_run(seed: int) -> None:
    rng = np.random.default_rng(seed)
    pos = _lattice_points(rng, 300)
    group = rng.integers(0, 3, pos.shape[0])
    is_target = rng.random(pos.shape[0]) < 0.4
    targets, queries = np.flatnonzero(is_target), np.flatnonzero(~is_target)
    d2 = _brute(pos[queries], pos[targets])
    d2 = np.where(group[queries, None] == group[None, targets], d2, np.inf)
    r = 0.2
    dist, k = nearest_within(pos, queries, targets, group, r)
    local = np.searchsorted(targets, k)
    _check_nearest(np.where(d2 <= r * r, d2, np.inf), dist, np.where(k >= 0, local, -1))
    # by run: the targets grouped, every query's group holding one
    order = targets[np.argsort(group[targets], kind="stable")]
    ids = np.unique(group[order])
    ok = np.isin(group[queries], ids)
    bounds = np.searchsorted(group[order], np.append(ids, ids.max() + 1))
    run = np.searchsorted(ids, group[queries[ok]])
    dist2, k2 = nearest_in_run(pos, queries[ok], order, bounds, run)
    _check_nearest(d2[ok], dist2, np.searchsorted(targets, k2))

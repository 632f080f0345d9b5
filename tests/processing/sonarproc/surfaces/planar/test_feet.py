"""Feet of points on polylines and distances to them, against brute force."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.pipeline.surfacefit import column_spans
from sonarproc.surfaces.planar.feet import feet_on_polyline, feet_on_polylines
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

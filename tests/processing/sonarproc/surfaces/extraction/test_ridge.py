"""The ridge across each wall against the same ridge written out with scipy.ndimage."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from sonarproc.surfaces.extraction.ridge import HESSIAN_ORDERS, ridge_directions, ridge_nms

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def _ridge_nms_scipy(mask: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The ridge as it was computed with scipy.ndimage (the oracle)."""
    cc = counts.astype(np.float32)
    smooth = ndimage.gaussian_filter(cc, 1.0)
    hxx, hyy, hxy = (ndimage.gaussian_filter(cc, 2.0, order=o) for o in HESSIAN_ORDERS)
    flat = np.flatnonzero(mask)
    a, b, d = (h.ravel()[flat].astype(np.float64) for h in (hxx, hxy, hyy))
    root = np.sqrt(0.25 * (a - d) ** 2 + b * b)
    lam_min, lam_max = 0.5 * (a + d) - root, 0.5 * (a + d) + root
    ridge = np.flatnonzero((lam_min < 0) & (-lam_min > np.abs(lam_max)))
    flat, a, b, d = flat[ridge], a[ridge], b[ridge], d[ridge]
    iy, ix = np.divmod(flat, mask.shape[1])
    theta = 0.5 * np.arctan2(2.0 * b, a - d) + 0.5 * np.pi
    nx, ny = np.cos(theta), np.sin(theta)
    here = smooth.ravel()[flat]
    ahead = ndimage.map_coordinates(smooth, [iy + ny, ix + nx], order=1, mode="nearest")
    behind = ndimage.map_coordinates(smooth, [iy - ny, ix - nx], order=1, mode="nearest")
    out = np.zeros(mask.size, dtype=bool)
    out[flat[(here >= ahead) & (here > behind)]] = True
    return out.reshape(mask.shape)


@settings(max_examples=15, deadline=None)
@given(SEEDS)
def test_ridge_nms_keeps_the_cells_the_scipy_ridge_kept(seed: int) -> None:
    # arcs of counts crossing a room: walls on the border and a pillar, plus noise; the
    # map is the whole grid (walls at the border), so the crop does not change it
    rng = np.random.default_rng(seed)
    ny, nx = 90, 150
    yy, xx = np.mgrid[0:ny, 0:nx]
    counts = rng.poisson(0.3, (ny, nx))
    for _ in range(60):
        cy, cx, r = rng.uniform(0, ny), rng.uniform(0, nx), rng.uniform(5, 60)
        ring = np.abs(np.hypot(yy - cy, xx - cx) - r) < 0.7
        counts += ring * rng.integers(1, 4)
    counts[:2] += 30
    counts[:, -2:] += 20
    counts[(yy - 40) ** 2 + (xx - 70) ** 2 < 36] += 10
    mask = counts > 0
    assert mask[0].any() and mask[-1].any() and mask[:, 0].any() and mask[:, -1].any()
    kept = ridge_nms(mask, counts)
    assert kept.sum() > 100
    assert np.array_equal(kept, _ridge_nms_scipy(mask, counts))


def test_ridge_directions_use_the_same_filters() -> None:
    rng = np.random.default_rng(5)
    c = rng.integers(0, 9, (40, 30)).astype(np.float32)
    nx, ny = ridge_directions(c)
    hxx, hyy, hxy = (ndimage.gaussian_filter(c, 2.0, order=o) for o in HESSIAN_ORDERS)
    theta = 0.5 * np.arctan2(2.0 * hxy, hxx - hyy) + 0.5 * np.pi
    assert np.array_equal(nx, np.cos(theta).astype(np.float64))
    assert np.array_equal(ny, np.sin(theta).astype(np.float64))


def test_bad_shapes_are_refused() -> None:
    with pytest.raises(ValueError, match="2-D"):
        ridge_nms(np.zeros(5, bool), np.zeros(5))
    with pytest.raises(ValueError, match="one shape"):
        ridge_nms(np.zeros((4, 4), bool), np.zeros((3, 4)))

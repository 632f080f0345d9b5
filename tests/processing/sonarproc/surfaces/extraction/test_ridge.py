"""The ridge through scipy.ndimage; our bilinear sampling against map_coordinates (to the bit)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import ndimage

from sonarproc.surfaces.extraction import bilinear
from sonarproc.surfaces.extraction.bilinear import bilinear_nearest
from sonarproc.surfaces.extraction.ridge import HESSIAN_ORDERS, ridge_directions, ridge_nms

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)
DTYPES = st.sampled_from([np.float32, np.float64, np.int64])


def _counts(rng: np.random.Generator, ny: int, nx: int, dtype: type) -> np.ndarray:
    """A sparse count map (zeros with a few hundred-count cells), or dense noise."""
    if rng.random() < 0.5:
        c = rng.integers(0, 300, (ny, nx)) * (rng.random((ny, nx)) < 0.3)
    else:
        c = rng.random((ny, nx)) * 50
    return np.asarray(c).astype(dtype)


@settings(max_examples=60, deadline=None)
@given(SEEDS, st.integers(1, 30), st.integers(1, 30), DTYPES)
def test_bilinear_nearest_is_map_coordinates_to_the_bit(
    seed: int, ny: int, nx: int, dtype: type
) -> None:
    rng = np.random.default_rng(seed)
    a = _counts(rng, ny, nx, dtype)
    y = rng.uniform(-3.0, ny + 2.0, 200)
    x = rng.uniform(-3.0, nx + 2.0, 200)
    y[:20] = np.round(y[:20])  # on cell centres and exactly on the last row
    x[20:40] = nx - 1
    got = bilinear_nearest(a, y, x)
    want = ndimage.map_coordinates(a.astype(got.dtype), [y, x], order=1, mode="nearest")
    assert got.dtype == want.dtype
    assert np.array_equal(got, want)


def test_bilinear_nearest_in_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    a = rng.random((20, 30)).astype(np.float32)
    y, x = rng.uniform(0, 19, (2, 3, 50))
    monkeypatch.setattr(bilinear, "CHUNK", 7)
    got = bilinear_nearest(a, y, x)
    assert got.shape == (3, 50)
    assert np.array_equal(got, ndimage.map_coordinates(a, [y, x], order=1, mode="nearest"))


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
        bilinear_nearest(np.zeros(5), [1.0], [1.0])
    with pytest.raises(ValueError, match="2-D"):
        ridge_nms(np.zeros(5, bool), np.zeros(5))
    with pytest.raises(ValueError, match="one shape"):
        bilinear_nearest(np.zeros((4, 4)), [1.0, 2.0], [1.0])

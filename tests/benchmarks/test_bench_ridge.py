"""Benchmark: the ridge's own bilinear sampling against scipy.ndimage (the floor).

The ridge (:func:`sonarproc.surfaces.ridge_nms`) filters with ``scipy.ndimage`` and samples
the smoothed map between cells with our :func:`bilinear_nearest`, kept while it is at least
2x faster than ``map_coordinates(order=1, mode="nearest")`` (ratio at most 0.5). Inputs of
the room benchmark's sizes: a 1000 x 1000 count map whose sonar arcs (3000 sensors, four
walls each) pile up along the walls; the ridge checked against the ridge computed with
scipy alone, and timed against it; 150 000 samples (about the ridge's comparisons on that
map). Each figure is the best of five, in the same run.
"""

from __future__ import annotations

import numpy as np
import pytest
from benchtiming import best_of
from scipy import ndimage

from sonarproc.surfaces import ridge_nms
from sonarproc.surfaces.extraction.bilinear import bilinear_nearest
from sonarproc.surfaces.extraction.ridge import HESSIAN_ORDERS


def _room_counts(rng: np.random.Generator, n: int = 1000) -> np.ndarray:
    """Arc counts of a square room: each sensor's arcs (+-0.22 rad) tangent to the walls."""
    sensors = rng.uniform(0.05 * n, 0.95 * n, (3000, 2))
    # the four walls: range to each, and the direction of its foot
    ranges = np.concatenate((sensors, n - 1 - sensors), axis=1)  # x0, y0, x1, y1 walls
    heading = np.array([np.pi, -np.pi / 2, 0.0, np.pi / 2])
    r = ranges.ravel()
    centre = np.repeat(sensors, 4, axis=0)
    h = np.tile(heading, sensors.shape[0])
    count = np.ceil(0.44 * r).astype(np.intp) + 1  # a point per cell along the arc
    arc = np.repeat(np.arange(r.size), count)
    k = np.arange(arc.size) - np.repeat(np.cumsum(count) - count, count)
    theta = h[arc] - 0.22 + 0.44 * k / np.maximum(count[arc] - 1, 1)
    x = np.clip(np.rint(centre[arc, 0] + r[arc] * np.cos(theta)), 0, n - 1).astype(np.intp)
    y = np.clip(np.rint(centre[arc, 1] + r[arc] * np.sin(theta)), 0, n - 1).astype(np.intp)
    return np.bincount(y * n + x, minlength=n * n).reshape(n, n)


def _ridge_scipy(mask: np.ndarray, counts: np.ndarray) -> np.ndarray:
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


def _line(label: str, ours: float, theirs: float) -> None:
    print(f"  {label}: ours {ours * 1e3:.1f} ms, scipy {theirs * 1e3:.1f} ms, "
          f"ratio {ours / theirs:.2f}")  # fmt: skip


@pytest.mark.benchmark
def test_bench_ridge_against_scipy() -> None:
    rng = np.random.default_rng(0)
    counts = _room_counts(rng)
    mask = counts > 0
    print(f"\nridge: {mask.mean():.0%} of a 1000 x 1000 map kept")
    assert np.array_equal(ridge_nms(mask, counts), _ridge_scipy(mask, counts))
    _line("ridge_nms", best_of(lambda: ridge_nms(mask, counts)),
          best_of(lambda: _ridge_scipy(mask, counts)))  # fmt: skip
    cc = counts.astype(np.float32)
    y, x = rng.uniform(0, 999, (2, 150_000))
    _line(
        "bilinear sampling, 150 000 points",
        best_of(lambda: bilinear_nearest(cc, y, x)),
        best_of(lambda: ndimage.map_coordinates(cc, [y, x], order=1, mode="nearest")),
    )

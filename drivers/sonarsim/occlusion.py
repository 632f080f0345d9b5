"""Line-of-sight tests: does any segment cut the straight path between two points?"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sonarsim.geometry import FloatArray
from sonarsim.segments import Segments

_BLOCK = 64
"""Segments per bounding box in the coarse pass."""

CHUNK_ELEMENTS = 2_000_000
"""Upper bound on ray x segment elements held at once."""


def _boxes(segs: Segments) -> tuple[FloatArray, FloatArray, NDArray[np.intp]]:
    """Bounding boxes of runs of ``_BLOCK`` consecutive segments."""
    n = len(segs)
    starts = np.arange(0, n, _BLOCK, dtype=np.intp)
    lo = np.minimum(segs.a, segs.b)
    hi = np.maximum(segs.a, segs.b)
    return np.minimum.reduceat(lo, starts, axis=0), np.maximum.reduceat(hi, starts, axis=0), starts


def blocked(
    segs: Segments, q0: FloatArray, q1: FloatArray, *, tol: float = 1e-5
) -> NDArray[np.bool_]:
    """Whether each straight path ``q0[k] -> q1[k]`` is cut by a segment.

    Crossings within ``tol`` metres of either end are ignored, so a path that starts or
    ends on a surface (a reflection point) is not blocked by that surface itself.

    Parameters
    ----------
    segs : Segments
        The obstacles.
    q0, q1 : ndarray, shape (K, 2)
        Path ends.
    tol : float
        End tolerance (m).

    Returns
    -------
    ndarray of bool, shape (K,)

    Examples
    --------
    >>> from sonarsim.surfaces import wall
    >>> s = wall((0.0, -1.0), (0.0, 1.0)).segments()
    >>> blocked(s, np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]])).tolist()
    [True]
    """
    k = q0.shape[0]
    out = np.zeros(k, dtype=bool)
    if k == 0 or len(segs) == 0:
        return out
    box_lo, box_hi, starts = _boxes(segs)
    ray_lo = np.minimum(q0, q1)
    ray_hi = np.maximum(q0, q1)
    # Coarse pass: which (ray, block) bounding boxes overlap.
    rows_per = max(1, CHUNK_ELEMENTS // max(1, len(starts)))
    ray_idx_parts = []
    blk_idx_parts = []
    for c0 in range(0, k, rows_per):
        sl = slice(c0, c0 + rows_per)
        ov = (
            (ray_lo[sl, None, 0] <= box_hi[None, :, 0])
            & (ray_hi[sl, None, 0] >= box_lo[None, :, 0])
            & (ray_lo[sl, None, 1] <= box_hi[None, :, 1])
            & (ray_hi[sl, None, 1] >= box_lo[None, :, 1])
        )
        r, b = np.nonzero(ov)
        ray_idx_parts.append(r + c0)
        blk_idx_parts.append(b)
    ray_idx = np.concatenate(ray_idx_parts)
    blk_idx = np.concatenate(blk_idx_parts)
    if ray_idx.size == 0:
        return out
    # Fine pass: every segment of each overlapping block.
    n_seg = len(segs)
    per = _BLOCK
    step = max(1, CHUNK_ELEMENTS // per)
    offs = np.arange(per, dtype=np.intp)
    for c0 in range(0, ray_idx.size, step):
        ri = ray_idx[c0 : c0 + step]
        si = starts[blk_idx[c0 : c0 + step], None] + offs[None, :]
        valid = si < n_seg
        si = np.minimum(si, n_seg - 1)
        p0 = q0[ri][:, None, :]
        d = (q1[ri] - q0[ri])[:, None, :]
        a = segs.a[si]
        e = segs.b[si] - a
        w = a - p0
        den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
        safe = np.where(den != 0.0, den, 1.0)
        u = (w[..., 0] * e[..., 1] - w[..., 1] * e[..., 0]) / safe
        v = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / safe
        length = np.hypot(d[..., 0], d[..., 1])
        ut = tol / np.where(length > 0.0, length, 1.0)
        hit = valid & (den != 0.0) & (u > ut) & (u < 1.0 - ut) & (v >= 0.0) & (v <= 1.0)
        np.logical_or.at(out, ri, hit.any(axis=1))
    return out

"""Line-of-sight tests: does any segment cut the straight path between two points?"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sonarsim.geometry import FloatArray
from sonarsim.segments import Segments

_BLOCK = 64
"""Segments per bounding box: a ray is tested against a block's segments only where its
box overlaps the block's."""

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
    d_all = q1 - q0
    length = np.hypot(d_all[:, 0], d_all[:, 1])
    ut_all = tol / np.where(length > 0.0, length, 1.0)
    # Block by block: the rays whose boxes overlap the block's (and are not yet blocked)
    # against the block's segments, a contiguous slice broadcast over them (no gather of
    # segments per ray, which cost more than the arithmetic).
    for b, s0 in enumerate(starts):
        rays = np.flatnonzero(
            (ray_lo[:, 0] <= box_hi[b, 0])
            & (ray_hi[:, 0] >= box_lo[b, 0])
            & (ray_lo[:, 1] <= box_hi[b, 1])
            & (ray_hi[:, 1] >= box_lo[b, 1])
            & ~out
        )
        if rays.size == 0:
            continue
        a = segs.a[s0 : s0 + _BLOCK]
        e = segs.b[s0 : s0 + _BLOCK] - a
        rows_per = max(1, CHUNK_ELEMENTS // len(a))
        for c0 in range(0, rays.size, rows_per):
            ri = rays[c0 : c0 + rows_per]
            d = d_all[ri][:, None, :]
            w = a[None] - q0[ri][:, None, :]
            den = d[..., 0] * e[None, :, 1] - d[..., 1] * e[None, :, 0]
            safe = np.where(den != 0.0, den, 1.0)
            u = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / safe
            v = (w[..., 0] * d[..., 1] - w[..., 1] * d[..., 0]) / safe
            ut = ut_all[ri][:, None]
            hit = (den != 0.0) & (u > ut) & (u < 1.0 - ut) & (v >= 0.0) & (v <= 1.0)
            out[ri] |= hit.any(axis=1)
    return out

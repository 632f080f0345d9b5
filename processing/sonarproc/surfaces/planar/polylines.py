"""Polyline geometry shared by the surface fits and metrics: split, resample, distance.

A set of polylines is an ``(N, 2)`` array whose pieces are separated by rows of NaN (the
``/truth/profile`` convention of sonarlog v1.1). Everything here is vectorised; distances
go through a k-d tree of the polyline vertices (:mod:`sonarproc.surfaces.planar.search`)
and then the exact distance to the two segments meeting at the nearest vertex.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.runs import ragged_arange
from sonarproc.surfaces.planar.search import nearest_points

__all__ = [
    "distance_to_polylines", "join_polylines", "resample", "resample_segments", "split_polylines",
    "to_adjacent_segments",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]


def split_polylines(points: npt.ArrayLike) -> list[FloatArray]:
    """Split an ``(N, 2)`` array at its NaN rows into polylines of at least one point.

    Examples
    --------
    >>> parts = split_polylines([[0, 0], [1, 0], [np.nan, np.nan], [0, 1]])
    >>> [p.shape for p in parts]
    [(2, 2), (1, 2)]
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"polylines must be an (N, 2) array, got shape {p.shape}")
    gap = ~np.all(np.isfinite(p), axis=1)
    piece = np.cumsum(gap)
    keep = ~gap
    if not keep.any():
        return []
    ids, starts = np.unique(piece[keep], return_index=True)
    kept = p[keep]
    return [a for a in np.split(kept, starts[1:]) if len(a)] if ids.size else []


def join_polylines(parts: list[FloatArray]) -> FloatArray:
    """The inverse of :func:`split_polylines`: one array, a NaN row between pieces.

    Examples
    --------
    >>> join_polylines([np.zeros((2, 2)), np.ones((1, 2))]).shape
    (4, 2)
    """
    rows: list[FloatArray] = []
    for k, part in enumerate(parts):
        if k:
            rows.append(np.full((1, 2), np.nan))
        rows.append(np.asarray(part, dtype=np.float64).reshape(-1, 2))
    return np.concatenate(rows) if rows else np.zeros((0, 2))


def resample(polyline: npt.ArrayLike, step: float) -> FloatArray:
    """Points every ``step`` metres along a polyline, both ends kept (last step shorter).

    Examples
    --------
    >>> resample([[0.0, 0.0], [1.0, 0.0]], 0.25)[:, 0].tolist()
    [0.0, 0.25, 0.5, 0.75, 1.0]
    """
    p = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
    if not step > 0:
        raise ValueError(f"step must be > 0, got {step}")
    if len(p) < 2:
        return p.copy()
    seg = np.hypot(*np.diff(p, axis=0).T)
    s = np.concatenate(([0.0], np.cumsum(seg)))
    total = float(s[-1])
    if total == 0.0:
        return p[:1].copy()
    n = int(np.floor(total / step + 1e-9))
    t = np.concatenate((step * np.arange(n + 1), [total]))
    if t[-1] - t[-2] < 1e-9 * max(step, 1.0):
        t = t[:-1]
    return np.stack((np.interp(t, s, p[:, 0]), np.interp(t, s, p[:, 1])), axis=1)


def resample_segments(start: npt.ArrayLike, end: npt.ArrayLike, step: float) -> list[FloatArray]:
    """:func:`resample` of many straight segments ``start[i] -> end[i]`` at once.

    Examples
    --------
    >>> a = resample_segments([[0.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [0.0, 1.6]], 0.25)
    >>> [np.round(p[:, i], 6).tolist() for p, i in zip(a, (0, 1))]
    [[0.0, 0.25, 0.5, 0.75, 1.0], [1.0, 1.25, 1.5, 1.6]]
    """
    a = np.asarray(start, dtype=np.float64).reshape(-1, 2)
    b = np.asarray(end, dtype=np.float64).reshape(-1, 2)
    if not step > 0:
        raise ValueError(f"step must be > 0, got {step}")
    if a.shape[0] == 0:
        return []
    total = np.hypot(*(b - a).T)
    n = np.floor(total / step + 1e-9).astype(np.intp)
    # a last step shorter than rounding is dropped, as resample does
    last = total - step * n >= 1e-9 * max(step, 1.0)
    count = np.where(total > 0, n + 1 + last, 1)
    seg, k = ragged_arange(count)
    first = np.cumsum(count) - count
    t = np.minimum(step * k, total[seg])
    slope = (b - a) / np.where(total > 0, total, 1.0)[:, None]
    pts = slope[seg] * t[:, None] + a[seg]
    ends = (first + count - 1)[(total > 0) & last]
    pts[ends] = b[(total > 0) & last]
    return np.split(pts, np.cumsum(count)[:-1])


def to_adjacent_segments(
    q: npt.NDArray[np.float64],
    verts: npt.NDArray[np.float64],
    k: npt.NDArray[np.intp],
    best: npt.NDArray[np.float64],
    first: npt.NDArray[np.intp],
    last: npt.NDArray[np.intp],
) -> npt.NDArray[np.float64]:
    """``best`` lowered to the distance from each point to the segments either side of vertex ``k``.

    ``first`` and ``last`` bound each point's polyline in ``verts`` (a segment never joins
    two polylines).
    """
    best = np.array(best, dtype=np.float64)
    for side in (-1, 1):
        j = k + side
        ok = (j >= first) & (j <= last)
        a, b = verts[k[ok]], verts[j[ok]]
        ab = b - a
        denom = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
        t = np.clip(np.einsum("ij,ij->i", q[ok] - a, ab) / denom, 0.0, 1.0)
        foot = a + ab * t[:, None]
        best[ok] = np.minimum(best[ok], np.hypot(*(q[ok] - foot).T))
    return best


def distance_to_polylines(
    points: npt.ArrayLike, polylines: list[FloatArray], *, chunk: int = 200_000
) -> FloatArray:
    """Distance (m) from each point to the nearest of ``polylines`` (segments, not vertices).

    Polylines should be sampled finely (a few cell sizes): the exact distance is taken to
    the two segments at the nearest vertex, which is the nearest segment unless the
    polyline folds back on itself within one step.

    Examples
    --------
    >>> d = distance_to_polylines([[0.5, 0.2], [2.0, 0.0]], [np.array([[0.0, 0], [1.0, 0]])])
    >>> np.round(d, 6).tolist()
    [0.2, 1.0]
    """
    q = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    parts = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in polylines if len(p)]
    out = np.full(len(q), np.inf)
    if not parts or not len(q):
        return out
    verts = np.concatenate(parts)
    lengths = np.array([len(p) for p in parts])
    first = np.repeat(np.cumsum(lengths) - lengths, lengths)
    last = first + np.repeat(lengths, lengths) - 1
    best_all, k_all = nearest_points(verts, q)
    for c0 in range(0, len(q), chunk):
        qq = q[c0 : c0 + chunk]
        best, k = best_all[c0 : c0 + chunk], k_all[c0 : c0 + chunk]
        out[c0 : c0 + chunk] = to_adjacent_segments(qq, verts, k, best, first[k], last[k])
    return out

"""Feet of points on surfaces: the nearest point of a polyline to each of many points.

The foot of a reading on a surface is where the surface's normal points at the sensor.
On a straight polyline it is one closed-form projection for any number of points and
surfaces at once; on a curved one, a k-d tree of its vertices gives the nearest vertex
(:func:`sonarproc.surfaces.planar.search.nearest_points`) and the two segments beside it
are searched. A foot within half a step of an open end counts as the end (the reading
saw past the surface's end, not its face).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.runs import run_cumsum
from sonarproc.surfaces.planar.search import nearest_points

__all__ = [
    "feet_on_polyline",
    "feet_on_polylines",
    "feet_on_segments",
    "median_steps",
    "straight_polylines",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def feet_on_polyline(
    q: FloatArray, poly: FloatArray, closed: bool
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """Nearest point of a finely sampled polyline to each of ``q``.

    Parameters
    ----------
    q : ndarray, shape (N, 2)
        The points (sensor positions).
    poly : ndarray, shape (K, 2)
        The polyline, K >= 2.
    closed : bool
        Whether it closes on itself (then every foot is inside).

    Returns
    -------
    distance, foot, along, inside : ndarray
        Distance to the foot, the foot ``(N, 2)``, its arc length along the polyline,
        and whether it is inside (not at an open end).

    Examples
    --------
    >>> wall = np.column_stack((np.linspace(0, 2, 201), np.ones(201)))
    >>> d, foot, s, inside = feet_on_polyline(np.array([[0.5, 0.0], [3.0, 1.0]]), wall, False)
    >>> np.round(d, 6).tolist(), np.round(s, 6).tolist(), inside.tolist()
    ([1.0, 1.0], [0.5, 2.0], [True, False])
    """
    return feet_on_polylines(q, [poly], np.zeros(q.shape[0], dtype=np.intp), [closed])


def feet_on_polylines(
    q: FloatArray, polys: list[FloatArray], surf: IntArray, closed: list[bool]
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """:func:`feet_on_polyline` of each ``q[k]`` on ``polys[surf[k]]``, all at once.

    Parameters
    ----------
    q : ndarray, shape (N, 2)
        The points.
    polys : list of ndarray, shape (K_i, 2)
        Finely sampled polylines (those used have K_i >= 2).
    surf : ndarray of int, shape (N,)
        Which polyline each point is tested against.
    closed : list of bool
        Whether each polyline closes on itself.

    Returns
    -------
    distance, foot, along, inside : ndarray
        As :func:`feet_on_polyline` (the same values, to the last bit).
    """
    ids = np.unique(surf)
    parts = [np.asarray(polys[i], dtype=np.float64).reshape(-1, 2) for i in ids]
    sizes = np.array([p.shape[0] for p in parts], dtype=np.intp)
    bounds = np.concatenate(([0], np.cumsum(sizes))).astype(np.intp)
    verts = np.concatenate(parts) if parts else np.zeros((0, 2))
    piece = np.searchsorted(ids, surf)
    # segment lengths and arc length at each vertex, each polyline on its own
    seg_all = np.hypot(*np.diff(verts, axis=0).T)
    inner = np.ones(seg_all.size, dtype=bool)
    inner[bounds[1:-1] - 1] = False  # the gaps from one polyline to the next
    seg = seg_all[inner]
    seg_bounds = bounds - np.arange(bounds.size)
    s_vert = np.zeros(verts.shape[0])
    s_vert[np.flatnonzero(inner) + 1] = run_cumsum(seg, seg_bounds)
    first, last = bounds[:-1][piece], bounds[1:][piece] - 1
    _, k = nearest_points(verts, q, bounds=bounds, run=piece)
    best_d = np.hypot(*(q - verts[k]).T)
    best_f = verts[k].copy()
    best_s = s_vert[k].copy()
    for side in (-1, 1):
        j = k + side
        ok = (j >= first) & (j <= last)
        a, b = verts[k[ok]], verts[j[ok]]
        ab = b - a
        den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
        t = np.clip(np.einsum("ij,ij->i", q[ok] - a, ab) / den, 0.0, 1.0)
        foot = a + ab * t[:, None]
        d = np.hypot(*(q[ok] - foot).T)
        better = d < best_d[ok]
        idx = np.flatnonzero(ok)[better]
        best_d[idx] = d[better]
        best_f[idx] = foot[better]
        best_s[idx] = (s_vert[k[ok]] + t * (s_vert[j[ok]] - s_vert[k[ok]]))[better]
    step = median_steps(parts)[piece] if parts else np.zeros(0)
    is_closed = np.asarray(closed, dtype=bool)[ids][piece]
    length = s_vert[last]
    inside = is_closed | ((best_s > 0.5 * step) & (best_s < length - 0.5 * step))
    return best_d, best_f, best_s, inside


def straight_polylines(
    polys: list[FloatArray], usable: npt.NDArray[np.bool_]
) -> npt.NDArray[np.bool_]:
    """Which polylines are straight (every vertex on the chord, to rounding).

    Parameters
    ----------
    polys : list of ndarray, shape (K_i, 2)
        The polylines.
    usable : ndarray of bool
        Which to test (the others are reported as not straight).

    Returns
    -------
    ndarray of bool, shape (len(polys),)
    """
    out = np.zeros(len(polys), dtype=bool)
    for i in np.flatnonzero(usable):
        p = polys[i]
        chord = p[-1] - p[0]
        span = float(np.hypot(*chord))
        if span > 0:
            dev = np.abs((p[:, 0] - p[0, 0]) * chord[1] - (p[:, 1] - p[0, 1]) * chord[0])
            out[i] = dev.max() <= 1e-9 * span * max(span, 1.0)
    return out


def median_steps(polys: list[FloatArray]) -> FloatArray:
    """The median segment length of each polyline (all at once: one sort).

    Parameters
    ----------
    polys : list of ndarray, shape (K_i, 2)
        The polylines, each with at least two vertices.

    Returns
    -------
    ndarray, shape (len(polys),)
    """
    seg = np.hypot(*np.diff(np.concatenate(polys), axis=0).T)
    sizes = np.array([len(p) for p in polys])
    last = np.cumsum(sizes) - 1
    mask = np.ones(seg.size, dtype=bool)
    mask[last[:-1]] = False  # the gaps between one polyline and the next
    n = sizes - 1
    owner = np.repeat(np.arange(len(polys)), n)
    seg = seg[mask]
    order = np.lexsort((seg, owner))
    ranked = seg[order]
    first = np.cumsum(n) - n
    lo = ranked[first + (n - 1) // 2]
    hi = ranked[first + n // 2]
    return np.asarray(0.5 * (lo + hi), dtype=np.float64)


def feet_on_segments(
    q: FloatArray, polys: list[FloatArray], surf: IntArray
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """:func:`feet_on_polyline` of each ``q[k]`` on the straight polyline ``polys[surf[k]]``.

    Parameters
    ----------
    q : ndarray, shape (N, 2)
        The points.
    polys : list of ndarray
        Straight polylines (only their ends and steps are used).
    surf : ndarray of int, shape (N,)
        Which polyline each point is tested against.

    Returns
    -------
    distance, foot, along, inside : ndarray
        As :func:`feet_on_polyline`.
    """
    ids = np.unique(surf)
    a = np.array([polys[i][0] for i in ids])
    b = np.array([polys[i][-1] for i in ids])
    # a vertex this close to an open end counts as the end (as for curved polylines)
    step = median_steps([polys[i] for i in ids])
    k = np.searchsorted(ids, surf)
    ab = (b - a)[k]
    length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", q - a[k], ab) / length2, 0.0, 1.0)
    foot = a[k] + ab * t[:, None]
    d = np.hypot(*(q - foot).T)
    length = np.sqrt(length2)
    along = t * length
    inside = (along > 0.5 * step[k]) & (along < length - 0.5 * step[k])
    return d, foot, along, inside

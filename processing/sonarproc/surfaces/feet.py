"""Feet of points on surfaces: the nearest point of a polyline to each of many points.

The foot of a reading on a surface is where the surface's normal points at the sensor.
On a straight polyline it is one closed-form projection for any number of points and
surfaces at once; on a curved one, a k-d tree of its vertices gives the nearest vertex
and the two segments beside it are searched. A foot within half a step of an open end
counts as the end (the reading saw past the surface's end, not its face).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

__all__ = ["feet_on_polyline", "feet_on_segments", "median_steps", "straight_polylines"]

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
    seg = np.hypot(*np.diff(poly, axis=0).T)
    s_vert = np.concatenate(([0.0], np.cumsum(seg)))
    _, k = cKDTree(poly).query(q)
    k = np.asarray(k, dtype=np.intp)
    best_d = np.hypot(*(q - poly[k]).T)
    best_f = poly[k].copy()
    best_s = s_vert[k].copy()
    last = poly.shape[0] - 1
    for side in (-1, 1):
        j = k + side
        ok = (j >= 0) & (j <= last)
        a, b = poly[k[ok]], poly[j[ok]]
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
    if closed:
        inside = np.ones(q.shape[0], dtype=bool)
    else:
        step = float(np.median(seg)) if seg.size else 0.0
        inside = (best_s > 0.5 * step) & (best_s < s_vert[-1] - 0.5 * step)
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

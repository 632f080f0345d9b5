"""Geometry of sonar arcs: the ellipse of each reading and its joint-sensitivity part.

A reading with transmitter T, receiver R and path length ``p`` (= tof x c) puts the
reflector on the ellipse ``|PT| + |PR| = p`` (foci T and R, semi-major axis ``a = p / 2``,
half focal distance ``c = |TR| / 2``, semi-minor axis ``b = sqrt(a^2 - c^2)``); when T = R
it is the circle of radius ``p / 2``. In the ellipse's own frame (centre at the origin, major
axis along x, T at ``(-c, 0)``, R at ``(c, 0)``) a point is ``(a cos E, b sin E)``; E is the
eccentric anomaly, and E equals the polar angle for a circle.

The arc is the part of the ellipse inside both beams: seen from T within the transmitter's
half beamwidth of its heading, and seen from R within the receiver's. Because both foci
lie inside the ellipse, each beam cuts one interval of E; their intersection is at most
two intervals. Everything here is vectorised over readings; nothing loops per arc.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ArcGeometry", "arc_geometry", "point_at", "tangent_at"]

TWO_PI = 2.0 * np.pi

FloatArray = NDArray[np.float64]


def _wrap(angle: FloatArray) -> FloatArray:
    """Wrap angles into (-pi, pi]."""
    return np.pi - np.mod(np.pi - angle, TWO_PI)


def _anomaly_from_focus(theta: FloatArray, a: FloatArray, c: FloatArray) -> FloatArray:
    """E of the ellipse point seen from the focus ``(-c, 0)`` at local polar angle theta.

    ``tan(E / 2) = sqrt((a + c) / (a - c)) tan(theta / 2)``, written with atan2 so it has no
    division; monotone in theta, maps (-pi, pi] onto (-pi, pi].
    """
    half = 0.5 * _wrap(theta)
    return 2.0 * np.arctan2(np.sqrt(a + c) * np.sin(half), np.sqrt(a - c) * np.cos(half))


@dataclass(frozen=True)
class ArcGeometry:
    """Ellipses and their joint-region E intervals, one row per arc (valid readings only).

    Attributes
    ----------
    arc : ndarray of intp, (K,)
        Index of the reading each row comes from.
    cx, cy, a, b, alpha : ndarray, (K,)
        Centre (m), semi-axes (m) and major-axis direction (rad, world) of each ellipse.
    lo, length : ndarray, (K, 2)
        Start and length (rad, >= 0) of up to two E intervals; NaN where absent.
    turning : ndarray, (K, 2)
        Total turning of the tangent (rad) over each interval; NaN where absent.
    """

    arc: NDArray[np.intp]
    cx: FloatArray
    cy: FloatArray
    a: FloatArray
    b: FloatArray
    alpha: FloatArray
    lo: FloatArray
    length: FloatArray
    turning: FloatArray

    def __len__(self) -> int:
        return int(self.arc.shape[0])


def _as_inputs(
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    path: ArrayLike,
    tx_half_beamwidth: ArrayLike,
    rx_half_beamwidth: ArrayLike,
) -> tuple[FloatArray, ...]:
    """Check shapes and broadcast to (N,) float arrays: tx, ty, th, rx, ry, rh, p, tw, rw."""
    txy = np.asarray(tx_xy, dtype=np.float64)
    rxy = np.asarray(rx_xy, dtype=np.float64)
    if txy.ndim == 1 and txy.shape == (2,):
        txy = txy[None, :]
    if rxy.ndim == 1 and rxy.shape == (2,):
        rxy = rxy[None, :]
    if txy.ndim != 2 or txy.shape[1] != 2:
        raise ValueError(f"tx_xy must have shape (N, 2), got {txy.shape}")
    if rxy.ndim != 2 or rxy.shape[1] != 2:
        raise ValueError(f"rx_xy must have shape (N, 2), got {rxy.shape}")
    p = np.atleast_1d(np.asarray(path, dtype=np.float64))
    if p.ndim != 1:
        raise ValueError(f"path must have shape (N,), got {p.shape}")
    n = max(txy.shape[0], rxy.shape[0], p.shape[0])
    parts = {
        "tx_xy": txy,
        "rx_xy": rxy,
        "path": p,
        "tx_heading": np.atleast_1d(np.asarray(tx_heading, dtype=np.float64)),
        "rx_heading": np.atleast_1d(np.asarray(rx_heading, dtype=np.float64)),
        "tx_half_beamwidth": np.atleast_1d(np.asarray(tx_half_beamwidth, dtype=np.float64)),
        "rx_half_beamwidth": np.atleast_1d(np.asarray(rx_half_beamwidth, dtype=np.float64)),
    }
    out: dict[str, FloatArray] = {}
    for name, arr in parts.items():
        if arr.shape[0] not in (1, n) or (name not in ("tx_xy", "rx_xy") and arr.ndim != 1):
            raise ValueError(f"{name} has shape {arr.shape}; expected {n} rows (or 1)")
        out[name] = np.broadcast_to(arr, (n, *arr.shape[1:]))
    return (
        out["tx_xy"][:, 0],
        out["tx_xy"][:, 1],
        out["tx_heading"],
        out["rx_xy"][:, 0],
        out["rx_xy"][:, 1],
        out["rx_heading"],
        out["path"],
        out["tx_half_beamwidth"],
        out["rx_half_beamwidth"],
    )


def _beam_interval(
    heading: FloatArray,
    half_width: FloatArray,
    alpha: FloatArray,
    a: FloatArray,
    c: FloatArray,
    *,
    receiver: bool,
) -> tuple[FloatArray, FloatArray]:
    """E interval ``(start, length)`` of the ellipse seen inside one beam."""
    t1 = heading - half_width - alpha
    t2 = heading + half_width - alpha
    if receiver:  # mirror x -> -x maps R onto T and E onto pi - E
        e1 = np.pi - _anomaly_from_focus(np.pi - t1, a, c)
        e2 = np.pi - _anomaly_from_focus(np.pi - t2, a, c)
    else:
        e1 = _anomaly_from_focus(t1, a, c)
        e2 = _anomaly_from_focus(t2, a, c)
    length = np.mod(e2 - e1, TWO_PI)
    length = np.where(half_width <= 0.0, 0.0, length)
    length = np.where(half_width >= np.pi, TWO_PI, length)
    return e1, length


def _intersect(
    s1: FloatArray, l1: FloatArray, s2: FloatArray, l2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Intersection of two circular intervals: (K, 2) starts and lengths, NaN if absent."""
    full1 = l1 >= TWO_PI
    full2 = l2 >= TWO_PI
    d = np.mod(s2 - s1, TWO_PI)
    lo1 = np.maximum(0.0, d)
    hi1 = np.minimum(l1, d + l2)
    lo2 = np.maximum(0.0, d - TWO_PI)
    hi2 = np.minimum(l1, d - TWO_PI + l2)
    starts = np.stack([s1 + lo1, s1 + lo2], axis=1)
    lengths = np.stack([hi1 - lo1, hi2 - lo2], axis=1)
    # A full beam does not cut the ellipse: the other interval stands as it is.
    one_full = full1 | full2
    starts[one_full, 0] = np.where(full1, s2, s1)[one_full]
    lengths[one_full, 0] = np.where(full1, l2, l1)[one_full]
    lengths[one_full, 1] = -1.0
    absent = lengths < 0.0
    starts[absent] = np.nan
    lengths[absent] = np.nan
    # Two pieces that touch at 0 / l1 (tangent beams) stay two pieces; harmless.
    return starts, lengths


def _tangent_angle_offset(e: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Tangent direction (local) minus ``E + pi/2``, in (-pi/2, pi/2)."""
    phi = np.arctan2(b * np.cos(e), -a * np.sin(e))
    return _wrap(phi - e - 0.5 * np.pi)


def arc_geometry(
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    path: ArrayLike,
    *,
    tx_half_beamwidth: ArrayLike,
    rx_half_beamwidth: ArrayLike,
) -> ArcGeometry:
    """The ellipse and joint-region intervals of every reading that makes an arc.

    Readings whose path is not finite, not longer than ``|TR|``, or whose ellipse misses the
    joint sensitivity region are dropped (their index does not appear in ``arc``).

    Parameters
    ----------
    tx_xy, rx_xy : array_like, (N, 2)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading : array_like, (N,)
        Beam axes (rad, world).
    path : array_like, (N,)
        Path lengths ``|TP| + |PR|`` (m).
    tx_half_beamwidth, rx_half_beamwidth : float or array_like, (N,)
        Half beamwidths (rad).

    Returns
    -------
    ArcGeometry

    Examples
    --------
    >>> g = arc_geometry([[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [2.0],
    ...                  tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)
    >>> float(g.a[0]), float(g.b[0]), round(float(g.length[0, 0]), 6)
    (1.0, 1.0, 0.4)
    """
    tx, ty, th, rx, ry, rh, p, tw, rw = _as_inputs(
        tx_xy, tx_heading, rx_xy, rx_heading, path, tx_half_beamwidth, rx_half_beamwidth
    )
    dx = rx - tx
    dy = ry - ty
    c = 0.5 * np.hypot(dx, dy)
    a = 0.5 * p
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(p) & (a > c) & np.isfinite(c) & np.isfinite(th) & np.isfinite(rh)
        ok &= np.isfinite(tw) & np.isfinite(rw)
    idx = np.flatnonzero(ok)
    a = a[idx]
    c = c[idx]
    alpha = np.where(c > 0.0, np.arctan2(dy[idx], dx[idx]), 0.0)
    b = np.sqrt((a - c) * (a + c))
    cx = 0.5 * (tx[idx] + rx[idx])
    cy = 0.5 * (ty[idx] + ry[idx])
    s1, l1 = _beam_interval(th[idx], tw[idx], alpha, a, c, receiver=False)
    s2, l2 = _beam_interval(rh[idx], rw[idx], alpha, a, c, receiver=True)
    lo, length = _intersect(s1, l1, s2, l2)
    has = np.isfinite(length).any(axis=1)
    lo = lo[has]
    length = length[has]
    a, b, alpha, cx, cy = a[has], b[has], alpha[has], cx[has], cy[has]
    aa = a[:, None]
    bb = b[:, None]
    with np.errstate(invalid="ignore"):
        turning = (
            length + _tangent_angle_offset(lo + length, aa, bb) - _tangent_angle_offset(lo, aa, bb)
        )
    return ArcGeometry(
        arc=idx[has].astype(np.intp),
        cx=cx,
        cy=cy,
        a=a,
        b=b,
        alpha=alpha,
        lo=lo,
        length=length,
        turning=turning,
    )


def point_at(
    e: ArrayLike, cx: ArrayLike, cy: ArrayLike, a: ArrayLike, b: ArrayLike, alpha: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """World point(s) of ellipse(s) at eccentric anomaly e (all inputs broadcast).

    Examples
    --------
    >>> x, y = point_at(np.pi / 2, 1.0, 0.0, 2.0, 1.0, 0.0)
    >>> round(float(x), 12), round(float(y), 12)
    (1.0, 1.0)
    """
    ea = np.asarray(e, dtype=np.float64)
    ce = np.asarray(a) * np.cos(ea)
    se = np.asarray(b) * np.sin(ea)
    ca = np.cos(alpha)
    sa = np.sin(alpha)
    return np.asarray(cx) + ca * ce - sa * se, np.asarray(cy) + sa * ce + ca * se


def tangent_at(
    e: ArrayLike, a: ArrayLike, b: ArrayLike, alpha: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """World tangent vector(s) ``dP/dE`` of ellipse(s) at eccentric anomaly e.

    Examples
    --------
    >>> tx, ty = tangent_at(0.0, 2.0, 1.0, 0.0)
    >>> float(tx), float(ty)
    (-0.0, 1.0)
    """
    ea = np.asarray(e, dtype=np.float64)
    ux = -np.asarray(a) * np.sin(ea)
    uy = np.asarray(b) * np.cos(ea)
    ca = np.cos(alpha)
    sa = np.sin(alpha)
    return ca * ux - sa * uy, sa * ux + ca * uy

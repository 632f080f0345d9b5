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

from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["ArcGeometry", "arc_geometry", "mod_2pi", "point_at", "tangent_at", "unit_vectors"]

TWO_PI = 2.0 * np.pi

FloatArray = NDArray[np.float64]


def mod_2pi(angle: FloatArray) -> FloatArray:
    """``angle mod 2 pi`` in [0, 2 pi) (floor-based: np.mod is ten times slower)."""
    r = angle - TWO_PI * np.floor(angle * (1.0 / TWO_PI))
    return np.where(r >= TWO_PI, r - TWO_PI, r)


def unit_vectors(e: FloatArray) -> tuple[FloatArray, FloatArray]:
    """cos e, sin e: float32 trigonometry renormalised to an exact float64 unit vector.

    Used for arc ends only, where an angle error of 1e-7 rad does not matter; the point
    stays exactly on its ellipse. (float64 sin/cos cost ten times more.)
    """
    e32 = e.astype(np.float32)
    c = np.cos(e32).astype(np.float64)
    s = np.sin(e32).astype(np.float64)
    r = np.sqrt(c * c + s * s)
    return c / r, s / r


def _wrap(angle: FloatArray) -> FloatArray:
    """Wrap angles into (-pi, pi]."""
    return np.pi - mod_2pi(np.pi - angle)


def _anomaly_from_focus(theta: FloatArray, a: FloatArray, c: FloatArray) -> FloatArray:
    """E of the ellipse point seen from the focus ``(-c, 0)`` at local polar angle theta.

    ``tan(E / 2) = sqrt((a + c) / (a - c)) tan(theta / 2)``, written with atan2 so it has no
    division; monotone in theta, maps (-pi, pi] onto (-pi, pi].
    """
    # float32 sines are ten times cheaper and ample here: E only says where an arc ends.
    half = (0.5 * _wrap(theta)).astype(np.float32)
    sh = np.sin(half).astype(np.float64)
    ch = np.cos(half).astype(np.float64)
    return 2.0 * np.arctan2(np.sqrt(a + c) * sh, np.sqrt(a - c) * ch)


@dataclass(frozen=True)
class ArcGeometry:
    """Ellipses and their joint-region E intervals, one row per arc (valid readings only).

    Attributes
    ----------
    arc : ndarray of intp, (K,)
        Index of the reading each row comes from.
    cx, cy, a, b : ndarray, (K,)
        Centre (m) and semi-axes (m) of each ellipse.
    ca, sa : ndarray, (K,)
        Cosine and sine of the major-axis direction (world); 1 and 0 for circles.
    lo, length : ndarray, (K, 2)
        Start and length (rad, >= 0) of up to two E intervals; NaN where absent.
    turning : ndarray, (K, 2)
        An upper bound of the total turning of the tangent (rad) over each interval
        (``length * a / b``; exact for circles); NaN where absent.
    """

    arc: NDArray[np.intp]
    cx: FloatArray
    cy: FloatArray
    a: FloatArray
    b: FloatArray
    ca: FloatArray
    sa: FloatArray
    lo: FloatArray
    length: FloatArray
    turning: FloatArray

    def __len__(self) -> int:
        return int(self.arc.shape[0])

    def __getitem__(self, rows: slice) -> ArcGeometry:
        """The rows ``rows`` (views)."""
        return ArcGeometry(**{f.name: getattr(self, f.name)[rows] for f in fields(self)})

    def bounds(self) -> tuple[float, float, float, float]:
        """Bounding box ``(xmin, xmax, ymin, ymax)`` (m) of every arc's joint-region part.

        The arc ends, and each ellipse's axis extremes (``cx +- hx``, ``cy +- hy``) where
        one of its E intervals holds them.

        Raises
        ------
        ValueError
            If there is no arc (no reading made one).

        Examples
        --------
        >>> arcs = arc_geometry([[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [2.0],
        ...                     tx_half_beamwidth=np.pi / 2, rx_half_beamwidth=np.pi / 2)
        >>> [round(v, 6) + 0.0 for v in arcs.bounds()]
        [0.0, 1.0, -1.0, 1.0]
        """
        if len(self) == 0:
            raise ValueError("no reading makes an arc (paths too short or outside the beams)")
        lo, length = self.lo, self.length
        c, s = unit_vectors(np.concatenate([lo, lo + length], axis=1))
        ca, sa = self.ca[:, None], self.sa[:, None]
        aa, bb = self.a[:, None], self.b[:, None]
        x = self.cx[:, None] + aa * c * ca - bb * s * sa
        y = self.cy[:, None] + aa * c * sa + bb * s * ca
        box = [float(np.nanmin(x)), float(np.nanmax(x)), float(np.nanmin(y)), float(np.nanmax(y))]
        a, b, cas, sas = self.a, self.b, self.ca, self.sa
        half_x = np.sqrt((a * cas) ** 2 + (b * sas) ** 2)
        half_y = np.sqrt((a * sas) ** 2 + (b * cas) ** 2)
        e_xmax = np.arctan2(-b * sas, a * cas)
        e_ymax = np.arctan2(b * cas, a * sas)
        for e, centre, half, axis in ((e_xmax, self.cx, half_x, 0), (e_ymax, self.cy, half_y, 2)):
            for flip, sign in ((0.0, 1.0), (np.pi, -1.0)):  # the max, then the min
                with np.errstate(invalid="ignore"):
                    held = (mod_2pi(e + flip - lo[:, 0]) <= length[:, 0]) | (
                        mod_2pi(e + flip - lo[:, 1]) <= length[:, 1]
                    )
                if held.any():
                    v = centre[held] + sign * half[held]
                    box[axis] = min(box[axis], float(v.min()))
                    box[axis + 1] = max(box[axis + 1], float(v.max()))
        return box[0], box[1], box[2], box[3]


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
    """E interval ``(start, length)`` of the ellipse seen inside one beam.

    For a circle (c = 0, alpha = 0) E is the polar angle and needs no trigonometry.
    """
    e1 = heading - half_width - alpha
    length = 2.0 * half_width
    ell = np.flatnonzero(c > 0.0)
    if ell.size:
        t1 = e1[ell]
        t2 = t1 + length[ell]
        ae, ce = a[ell], c[ell]
        if receiver:  # mirror x -> -x maps R onto T and E onto pi - E
            f1 = np.pi - _anomaly_from_focus(np.pi - t1, ae, ce)
            f2 = np.pi - _anomaly_from_focus(np.pi - t2, ae, ce)
        else:
            f1 = _anomaly_from_focus(t1, ae, ce)
            f2 = _anomaly_from_focus(t2, ae, ce)
        e1[ell] = f1
        length[ell] = mod_2pi(f2 - f1)
    length = np.where(half_width <= 0.0, 0.0, np.minimum(length, TWO_PI))
    length = np.where(half_width >= np.pi, TWO_PI, length)
    return e1, length


def _intersect(
    s1: FloatArray, l1: FloatArray, s2: FloatArray, l2: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Intersection of two circular intervals: (K, 2) starts and lengths, NaN if absent."""
    full1 = l1 >= TWO_PI
    full2 = l2 >= TWO_PI
    d = mod_2pi(s2 - s1)
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
    dx = dx[idx]
    dy = dy[idx]
    bis = c > 0.0
    alpha = np.zeros(idx.shape[0])
    alpha[bis] = np.arctan2(dy[bis], dx[bis])
    inv = np.divide(0.5, c, out=np.zeros_like(c), where=bis)
    ca = np.where(bis, dx * inv, 1.0)
    sa = dy * inv
    b = np.sqrt((a - c) * (a + c))
    s1, l1 = _beam_interval(th[idx], tw[idx], alpha, a, c, receiver=False)
    s2, l2 = _beam_interval(rh[idx], rw[idx], alpha, a, c, receiver=True)
    lo, length = _intersect(s1, l1, s2, l2)
    has = np.isfinite(length[:, 0]) | np.isfinite(length[:, 1])
    if not has.all():
        idx = idx[has]
        a, b, ca, sa, lo, length = (v[has] for v in (a, b, ca, sa, lo, length))
        bis = bis[has]
    cx = 0.5 * (tx[idx] + rx[idx])
    cy = 0.5 * (ty[idx] + ry[idx])
    turning = length * np.where(bis, a / b, 1.0)[:, None]
    return ArcGeometry(
        arc=idx.astype(np.intp),
        cx=cx,
        cy=cy,
        a=a,
        b=b,
        ca=ca,
        sa=sa,
        lo=lo,
        length=length,
        turning=turning,
    )


def point_at(
    e: ArrayLike,
    cx: ArrayLike,
    cy: ArrayLike,
    a: ArrayLike,
    b: ArrayLike,
    ca: ArrayLike,
    sa: ArrayLike,
) -> tuple[FloatArray, FloatArray]:
    """World point(s) of ellipse(s) at eccentric anomaly e (all inputs broadcast).

    ``ca, sa`` are the cosine and sine of the major-axis direction.

    Examples
    --------
    >>> x, y = point_at(np.pi / 2, 1.0, 0.0, 2.0, 1.0, 1.0, 0.0)
    >>> round(float(x), 12), round(float(y), 12)
    (1.0, 1.0)
    """
    ea = np.asarray(e, dtype=np.float64)
    ce = np.asarray(a) * np.cos(ea)
    se = np.asarray(b) * np.sin(ea)
    cosa = np.asarray(ca)
    sina = np.asarray(sa)
    return np.asarray(cx) + cosa * ce - sina * se, np.asarray(cy) + sina * ce + cosa * se


def tangent_at(
    e: ArrayLike, a: ArrayLike, b: ArrayLike, ca: ArrayLike, sa: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """World tangent vector(s) ``dP/dE`` of ellipse(s) at eccentric anomaly e.

    Examples
    --------
    >>> tx, ty = tangent_at(0.0, 2.0, 1.0, 1.0, 0.0)
    >>> float(tx), float(ty)
    (-0.0, 1.0)
    """
    ea = np.asarray(e, dtype=np.float64)
    ux = -np.asarray(a) * np.sin(ea)
    uy = np.asarray(b) * np.cos(ea)
    cosa = np.asarray(ca)
    sina = np.asarray(sa)
    return cosa * ux - sina * uy, sina * ux + cosa * uy

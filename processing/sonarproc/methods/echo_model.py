"""The first-echo model: which path length a reading would measure off a known curve.

A transmitter T (heading, half beamwidth) and a receiver R hear a surface at its specular
points: where the path ``|TP| + |PR|`` is stationary along the surface (the normal
bisects P->T and P->R), inside both beams; the first echo is the shortest of them (for
T = R, the nearest foot of a perpendicular in the beam: twice its distance). This is the
simulator's first-order specular model, applied to a sampled curve (a stationary point
is a sample whose path is no longer, or no shorter, than both its neighbours': the foot
of a perpendicular in a trough, or a crest). A reading of echo rank ``k`` (0: first)
is predicted by the ``k``-th shortest. It predicts
readings from a fitted profile (:mod:`sonarproc.auto`) and makes the analytic logs of
the tests (:mod:`sonarproc.methods.testing`).

:func:`curve_echo_points` is the one implementation of echo points on a sampled curve:
each reading's first-echo point P on the curve (exact for a bistatic pair: the shortest
stationary ``|TP| + |PR|``, not the midpoint's perpendicular), moved along the curve's
normal until its path equals the measured one. ``--auto``'s echo refit and its noise
estimates use it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

__all__ = ["MIN_PATH_GAIN", "beam_x_bounds", "curve_echo_points", "first_echo", "first_echo_path"]

FloatArray = npt.NDArray[np.float64]

#: A reading whose path changes by less than this per metre along the surface's normal
#: (grazing geometry, far off the bisector) says too little about the surface's distance:
#: a range error e moves its echo point by e / gain, so below 0.5 it is magnified more
#: than twice.
MIN_PATH_GAIN = 0.5

#: Work per chunk: readings x curve points.
_CHUNK = 1 << 22


class _Beam(NamedTuple):
    """One end of each reading's path: apexes (N, 2), headings and half beamwidths (rad)."""

    xy: FloatArray
    heading: FloatArray
    half: FloatArray

    def take(self, rows: npt.NDArray[np.intp]) -> _Beam:
        return _Beam(self.xy[rows], self.heading[rows], self.half[rows])


def _in_beam(
    dx: FloatArray, dy: FloatArray, heading: FloatArray, half: FloatArray
) -> npt.NDArray[np.bool_]:
    c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
    along = dx * c + dy * s
    across = np.abs(dy * c - dx * s)
    # angle from the axis <= half, without arctan2: across <= along * tan(half)
    return (along > 0) & (across <= along * np.tan(half)[:, None])


def beam_x_bounds(
    xy: FloatArray, heading: FloatArray, half: FloatArray, ymin: float, ymax: float
) -> tuple[FloatArray, FloatArray]:
    """The x range of each beam's wedge within the band ``ymin <= y <= ymax``.

    The wedge is the apex ``xy`` and the directions within ``half`` of ``heading``; its
    intersection with the band is a convex polygon whose x extremes lie at the apex (if
    inside the band) or where an edge ray meets a band line; it is unbounded towards
    +x (-x) when the wedge holds the direction 0 (pi). An empty intersection gives
    ``lo > hi``.

    Examples
    --------
    A beam looking up from the origin, 30 degrees each side, into the band y = 1..2:

    >>> lo, hi = beam_x_bounds(np.zeros((1, 2)), np.array([np.pi / 2]),
    ...                        np.array([np.pi / 6]), 1.0, 2.0)
    >>> round(float(lo[0]), 4), round(float(hi[0]), 4)
    (-1.1547, 1.1547)
    """
    x, y = xy[:, 0], xy[:, 1]
    lo = np.full(x.shape, np.inf)
    hi = np.full(x.shape, -np.inf)
    inside = (y >= ymin) & (y <= ymax)
    lo = np.where(inside, x, lo)
    hi = np.where(inside, x, hi)
    for edge in (heading - half, heading + half):
        dx, dy = np.cos(edge), np.sin(edge)
        for c in (ymin, ymax):
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (c - y) / dy
            reach = np.isfinite(t) & (t >= 0)
            xe = np.where(reach, x + t * dx, np.nan)
            lo = np.where(reach, np.minimum(lo, xe), lo)
            hi = np.where(reach, np.maximum(hi, xe), hi)
    # a wedge holding a horizontal direction reaches the band arbitrarily far along x
    wide = half >= np.pi / 2
    to_right = wide | (np.cos(heading) >= np.cos(half))  # angle 0 within half of heading
    to_left = wide | (-np.cos(heading) >= np.cos(half))  # angle pi within half of heading
    return np.where(to_left, -np.inf, lo), np.where(to_right, np.inf, hi)


def _windows(
    tx: _Beam, rx: _Beam, pts: FloatArray
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Per reading, the curve indices ``[i0, i1)`` that can lie inside both beams.

    Only for a curve whose x increases along it (a profile y(x)); every index otherwise.
    """
    m = pts.shape[0]
    n = tx.xy.shape[0]
    xs = pts[:, 0]
    if not np.all(np.diff(xs) > 0):
        return np.zeros(n, np.intp), np.full(n, m, np.intp)
    ymin, ymax = float(pts[:, 1].min()), float(pts[:, 1].max())
    lo_t, hi_t = beam_x_bounds(*tx, ymin, ymax)
    lo_r, hi_r = beam_x_bounds(*rx, ymin, ymax)
    lo, hi = np.maximum(lo_t, lo_r), np.minimum(hi_t, hi_r)
    # a margin of a sample each side: rounding at the wedge's edges
    i0 = np.searchsorted(xs, lo, side="left") - 1
    i1 = np.searchsorted(xs, hi, side="right") + 1
    i0 = np.clip(i0, 0, m)
    i1 = np.clip(np.maximum(i1, i0), 0, m)
    return i0.astype(np.intp), i1.astype(np.intp)


#: Below this much work (readings x curve points) the windows cost more than they save
#: (measured: even at 20 readings of a 1000-point curve, 0.1 ms lost at 100 readings of a
#: 100-point one; 7x faster at 1000 readings of a 270-point one).
_WINDOW_MIN_WORK = 1 << 14


def first_echo(
    tx_xy: npt.ArrayLike,
    tx_heading: npt.ArrayLike,
    tx_half: npt.ArrayLike,
    rx_xy: npt.ArrayLike,
    rx_heading: npt.ArrayLike,
    rx_half: npt.ArrayLike,
    curve: npt.ArrayLike,
    rank: npt.ArrayLike | None = None,
) -> tuple[FloatArray, npt.NDArray[np.intp]]:
    """Shortest path T -> P -> R over the curve's specular points P inside both beams.

    On a profile y(x) (x increasing along the curve) and enough work, each reading looks
    only at the samples within its beams' x range (:func:`beam_x_bounds`): the same
    result for a fraction of the work.

    Parameters
    ----------
    tx_xy, rx_xy : array_like, (N, 2)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading, tx_half, rx_half : array_like, (N,)
        Beam axes and half beamwidths (rad).
    curve : array_like, (M, 2)
        Points of the surface in order along it, spaced well below the range resolution
        wanted (the two end points are never specular).
    rank : array_like of int, (N,), optional
        Echo rank of each reading (0, the default: the first echo).

    Returns
    -------
    path : ndarray, (N,)
        Path lengths (m); NaN where no point of the curve is inside both beams.
    index : ndarray of int, (N,)
        The curve point P of each path (where the echo came from); -1 where none.

    Examples
    --------
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> path, at = first_echo([[0, 0]], [np.pi / 2], [0.2], [[0, 0]], [np.pi / 2], [0.2], wall)
    >>> path.tolist(), wall[at].tolist()
    ([2.0], [[0.0, 1.0]])
    """
    tx, rx = _beam(tx_xy, tx_heading, tx_half), _beam(rx_xy, rx_heading, rx_half)
    pts = np.asarray(curve, dtype=np.float64).reshape(-1, 2)
    n = tx.xy.shape[0]
    out = np.full(n, np.nan)
    at = np.full(n, -1, dtype=np.intp)
    k = np.zeros(n, np.intp) if rank is None else np.asarray(rank, np.intp).reshape(-1)
    if pts.shape[0] < 3 or n == 0:
        return out, at
    m = pts.shape[0]
    if n * m >= _WINDOW_MIN_WORK:
        i0, i1 = _windows(tx, rx, pts)
    else:
        i0, i1 = np.zeros(n, np.intp), np.full(n, m, np.intp)
    if (i1 - i0).max() < m:  # windows: each reading over its own samples only
        return _windowed_echoes(tx, rx, pts, k, i0, i1)
    order = np.argsort(i0, kind="stable")
    rows = max(1, _CHUNK // m)
    for start in range(0, order.size, rows):
        sel = order[start : start + rows]
        a, b = int(i0[sel].min()), int(i1[sel].max())
        if b - a < 3:
            continue  # no sample of the curve in these readings' beams
        path, pick = _chunk_echoes(tx.take(sel), rx.take(sel), pts[a:b], k[sel])
        found = np.isfinite(path)
        out[sel] = np.where(found, path, np.nan)
        at[sel] = np.where(found, pick + a, -1)
    return out, at


def _windowed_echoes(
    tx: _Beam,
    rx: _Beam,
    pts: FloatArray,
    k: npt.NDArray[np.intp],
    i0: npt.NDArray[np.intp],
    i1: npt.NDArray[np.intp],
) -> tuple[FloatArray, npt.NDArray[np.intp]]:
    """:func:`first_echo` with each reading looking at its own window ``[i0, i1)`` of the
    curve only: every (reading, sample) pair of the windows in one flat array, in groups
    of at most :data:`_CHUNK` pairs. A window's end samples are never specular (margins
    beyond the beams, or the curve's own ends), as :func:`_chunk_echoes` has it."""
    n = i0.size
    out = np.full(n, np.nan)
    at = np.full(n, -1, dtype=np.intp)
    width = np.where(i1 - i0 >= 3, i1 - i0, 0)  # fewer than 3 samples: none specular
    ends = np.cumsum(width)
    first = 0
    while first < n:
        last = max(first + 1, int(np.searchsorted(ends, ends[first] - width[first] + _CHUNK)))
        rows = np.arange(first, min(last, n))
        first = int(rows[-1]) + 1
        rows = rows[width[rows] > 0]
        if rows.size == 0:
            continue
        best, pick = _flat_echoes(tx.take(rows), rx.take(rows), pts, k[rows], i0[rows],
                                  width[rows])  # fmt: skip
        found = np.isfinite(best)
        out[rows] = np.where(found, best, np.nan)
        at[rows] = np.where(found, pick, -1)
    return out, at


def _flat_echoes(
    tx: _Beam,
    rx: _Beam,
    pts: FloatArray,
    k: npt.NDArray[np.intp],
    i0: npt.NDArray[np.intp],
    width: npt.NDArray[np.intp],
) -> tuple[FloatArray, npt.NDArray[np.intp]]:
    """The ``k``-th shortest specular path of each reading over samples ``i0 .. i0 +
    width - 1`` (each width >= 3), and its sample."""
    total = int(width.sum())
    start = np.cumsum(width) - width
    owner = np.repeat(np.arange(i0.size), width)
    sample = np.arange(total) - start[owner] + i0[owner]
    px, py = pts[sample, 0], pts[sample, 1]

    def seen(beam: _Beam) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
        # the arithmetic of _in_beam, one pair at a time
        dx, dy = px - beam.xy[owner, 0], py - beam.xy[owner, 1]
        c, s = np.cos(beam.heading)[owner], np.sin(beam.heading)[owner]
        along = dx * c + dy * s
        across = np.abs(dy * c - dx * s)
        inside = (along > 0) & (across <= along * np.tan(beam.half)[owner])
        return np.hypot(dx, dy), inside

    t_len, ok = seen(tx)
    r_len, r_in = seen(rx)
    ok &= r_in
    path = t_len + r_len  # for T = R, exactly twice the distance
    mid = path[1:-1]
    low = (mid <= path[:-2]) & (mid <= path[2:])
    high = (mid >= path[:-2]) & (mid >= path[2:])
    ok[1:-1] &= low | high
    ok[start] = False
    ok[start + width - 1] = False
    path[~ok] = np.inf
    best = np.minimum.reduceat(path, start)
    # the first sample at the shortest path (np.argmin's choice)
    flat = np.arange(total)
    pick = np.minimum.reduceat(np.where(path == best[owner], flat, total), start)
    later = np.flatnonzero(k > 0)
    if later.size:
        mine = np.isin(owner, later)
        order = flat[mine][np.lexsort((path[mine], owner[mine]))]  # by reading, then path
        first = np.cumsum(width[later]) - width[later]
        beyond = k[later] >= width[later]
        chosen = order[first + np.minimum(k[later], width[later] - 1)]
        best[later] = np.where(beyond, np.inf, path[chosen])
        pick[later] = chosen
    return best, sample[np.minimum(pick, total - 1)]


def _chunk_echoes(
    tx: _Beam, rx: _Beam, pts: FloatArray, k: npt.NDArray[np.intp]
) -> tuple[FloatArray, npt.NDArray[np.intp]]:
    """:func:`first_echo` for some readings over a stretch of the curve. Its end samples
    are never specular: the curve's own ends, or a window's margin beyond every beam."""
    px, py = pts[None, :, 0], pts[None, :, 1]
    tdx, tdy = px - tx.xy[:, 0:1], py - tx.xy[:, 1:2]
    ok = _in_beam(tdx, tdy, tx.heading, tx.half)
    if np.array_equal(tx.xy, rx.xy) and np.array_equal(tx.heading, rx.heading):
        # monostatic: one beam, the path is twice the distance
        if not np.array_equal(tx.half, rx.half):
            ok &= _in_beam(tdx, tdy, rx.heading, rx.half)
        path = 2.0 * np.hypot(tdx, tdy)
    else:
        rdx, rdy = px - rx.xy[:, 0:1], py - rx.xy[:, 1:2]
        ok &= _in_beam(rdx, rdy, rx.heading, rx.half)
        path = np.hypot(tdx, tdy) + np.hypot(rdx, rdy)
    mid = path[:, 1:-1]
    low = (mid <= path[:, :-2]) & (mid <= path[:, 2:])
    high = (mid >= path[:, :-2]) & (mid >= path[:, 2:])
    ok[:, 1:-1] &= low | high
    ok[:, [0, -1]] = False
    path[~ok] = np.inf
    pick = path.argmin(axis=1)
    later = np.flatnonzero(k > 0)  # later echoes: only their rows are ranked further
    top = min(int(k.max()) + 1, path.shape[1])
    if later.size and top > 1:
        sub = path[later]
        part = np.argpartition(sub, top - 1, axis=1)[:, :top]
        ranked = np.take_along_axis(
            part, np.argsort(np.take_along_axis(sub, part, axis=1), axis=1), axis=1
        )
        rank = np.minimum(k[later], top - 1)[:, None]
        pick[later] = np.take_along_axis(ranked, rank, axis=1)[:, 0]
    best = path[np.arange(pick.size), pick]
    # a rank beyond the window's samples has no echo in it (nor in the whole curve)
    best = np.where(k < path.shape[1], best, np.inf)
    return best, pick


def _beam(xy: npt.ArrayLike, heading: npt.ArrayLike, half: npt.ArrayLike) -> _Beam:
    h = np.asarray(heading, dtype=np.float64).reshape(-1)
    w = np.broadcast_to(np.asarray(half, dtype=np.float64), h.shape)
    return _Beam(np.asarray(xy, dtype=np.float64).reshape(-1, 2), h, w)


def first_echo_path(
    tx_xy: npt.ArrayLike,
    tx_heading: npt.ArrayLike,
    tx_half: npt.ArrayLike,
    rx_xy: npt.ArrayLike,
    rx_heading: npt.ArrayLike,
    rx_half: npt.ArrayLike,
    curve: npt.ArrayLike,
    rank: npt.ArrayLike | None = None,
) -> FloatArray:
    """The path lengths of :func:`first_echo` (m; NaN where the curve misses the beams).

    Examples
    --------
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> first_echo_path([[0, 0]], [np.pi / 2], [0.2], [[0, 0]], [np.pi / 2], [0.2], wall)
    array([2.])
    """
    return first_echo(tx_xy, tx_heading, tx_half, rx_xy, rx_heading, rx_half, curve, rank)[0]


def curve_echo_points(
    tx_xy: npt.ArrayLike,
    tx_heading: npt.ArrayLike,
    tx_half: npt.ArrayLike,
    rx_xy: npt.ArrayLike,
    rx_heading: npt.ArrayLike,
    rx_half: npt.ArrayLike,
    path: npt.ArrayLike,
    curve: npt.ArrayLike,
    *,
    tol: float,
    rank: npt.ArrayLike | None = None,
) -> tuple[npt.NDArray[np.intp], FloatArray]:
    """Each reading's echo point on the surface near a sampled ``curve``.

    The reading's first echo on the curve (:func:`first_echo`: its specular point P, the
    path ``|TP| + |PR|``) is moved along the curve's normal ``n`` at P until its path
    equals the measured one, to first order: the path grows by ``n . (u_T + u_R)`` per
    metre along ``n`` (``u_T``, ``u_R`` the unit vectors from transmitter and receiver).
    The echo point lies on the surface whatever the curve's offset; only where the curve
    is wrong in slope does it slide along the surface.

    Parameters
    ----------
    tx_xy, tx_heading, tx_half, rx_xy, rx_heading, rx_half : array_like
        As :func:`first_echo`.
    path : array_like, (N,)
        Measured path lengths (m).
    curve : array_like, (M, 2)
        Samples of a curve near the surface, in order along it.
    tol : float
        Largest range residual (m, half the path) of a reading kept, and largest distance
        of its echo point from the curve.
    rank : array_like of int, (N,), optional
        Echo rank of each reading (:func:`first_echo`).

    Returns
    -------
    rows : ndarray of int, (E,)
        The readings that echo from the curve (their path within ``2 tol`` of the
        predicted one, a path gain of at least :data:`MIN_PATH_GAIN`).
    points : ndarray, (E, 2)
        Their echo points.

    Examples
    --------
    A wall along y = 1, a sensor at (0.1, 0) looking up, range 1 m; the curve is 2 cm
    short of the wall and tilted: the echo point is on the wall.

    >>> xs = np.linspace(-1, 1, 201)
    >>> near = np.column_stack((xs, 0.98 + 0.01 * xs))
    >>> rows, pts = curve_echo_points([[0.1, 0]], [np.pi / 2], [0.2], [[0.1, 0]],
    ...                               [np.pi / 2], [0.2], [2.0], near, tol=0.05)
    >>> rows.tolist(), np.round(pts[:, 1], 3).tolist()
    ([0], [1.0])
    """
    pts = np.asarray(curve, dtype=np.float64).reshape(-1, 2)
    measured = np.asarray(path, dtype=np.float64).reshape(-1)
    txy = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
    rxy = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
    predicted, at = first_echo(txy, tx_heading, tx_half, rxy, rx_heading, rx_half, pts, rank)
    ok = (at > 0) & (at < pts.shape[0] - 1) & (np.abs(measured - predicted) <= 2.0 * tol)
    hit = np.flatnonzero(ok)
    k = at[hit]
    foot = pts[k]
    tangent = pts[k + 1] - pts[k - 1]
    normal = np.column_stack((-tangent[:, 1], tangent[:, 0]))
    normal /= np.hypot(*normal.T)[:, None]
    to_tx, to_rx = foot - txy[hit], foot - rxy[hit]
    gain = np.einsum(
        "ij,ij->i",
        normal,
        to_tx / np.hypot(*to_tx.T)[:, None] + to_rx / np.hypot(*to_rx.T)[:, None],
    )
    shift = (measured[hit] - predicted[hit]) / np.where(gain == 0.0, np.nan, gain)
    # a small gain magnifies the path's error: the echo point must lie within the
    # tolerance of the curve too, not only its path
    good = (np.abs(gain) >= MIN_PATH_GAIN) & (np.abs(shift) <= tol)
    return hit[good], foot[good] + shift[good, None] * normal[good]

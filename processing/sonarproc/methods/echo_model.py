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
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["first_echo", "first_echo_path"]

FloatArray = npt.NDArray[np.float64]

#: Work per chunk: readings x curve points.
_CHUNK = 1 << 22


def _in_beam(
    dx: FloatArray, dy: FloatArray, heading: FloatArray, half: FloatArray
) -> npt.NDArray[np.bool_]:
    c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
    along = dx * c + dy * s
    across = np.abs(dy * c - dx * s)
    # angle from the axis <= half, without arctan2: across <= along * tan(half)
    return (along > 0) & (across <= along * np.tan(half)[:, None])


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
    t = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
    ht = np.asarray(tx_heading, dtype=np.float64).reshape(-1)
    hr = np.asarray(rx_heading, dtype=np.float64).reshape(-1)
    wt = np.broadcast_to(np.asarray(tx_half, dtype=np.float64), ht.shape)
    wr = np.broadcast_to(np.asarray(rx_half, dtype=np.float64), hr.shape)
    pts = np.asarray(curve, dtype=np.float64).reshape(-1, 2)
    out = np.full(t.shape[0], np.nan)
    at = np.full(t.shape[0], -1, dtype=np.intp)
    k = np.zeros(t.shape[0], np.intp) if rank is None else np.asarray(rank, np.intp).reshape(-1)
    if pts.shape[0] < 3 or t.shape[0] == 0:
        return out, at
    step = max(1, _CHUNK // pts.shape[0])
    px, py = pts[None, :, 0], pts[None, :, 1]
    for i in range(0, t.shape[0], step):
        sl = slice(i, i + step)
        tdx, tdy = px - t[sl, 0:1], py - t[sl, 1:2]
        ok = _in_beam(tdx, tdy, ht[sl], wt[sl])
        if np.array_equal(t[sl], r[sl]) and np.array_equal(ht[sl], hr[sl]):
            # monostatic: one beam, the path is twice the distance
            ok &= _in_beam(tdx, tdy, hr[sl], wr[sl]) if not np.array_equal(wt[sl], wr[sl]) else ok
            path = 2.0 * np.hypot(tdx, tdy)
        else:
            rdx, rdy = px - r[sl, 0:1], py - r[sl, 1:2]
            ok &= _in_beam(rdx, rdy, hr[sl], wr[sl])
            path = np.hypot(tdx, tdy) + np.hypot(rdx, rdy)
        mid = path[:, 1:-1]
        low = (mid <= path[:, :-2]) & (mid <= path[:, 2:])
        high = (mid >= path[:, :-2]) & (mid >= path[:, 2:])
        ok[:, 1:-1] &= low | high
        ok[:, [0, -1]] = False
        path[~ok] = np.inf
        kk = k[sl]
        top = min(int(kk.max()) + 1, path.shape[1])
        if top == 1:
            pick = path.argmin(axis=1)
        else:
            part = np.argpartition(path, top - 1, axis=1)[:, :top]
            ranked = np.take_along_axis(
                part, np.argsort(np.take_along_axis(path, part, axis=1), axis=1), axis=1
            )
            pick = np.take_along_axis(ranked, np.minimum(kk, top - 1)[:, None], axis=1)[:, 0]
        best = path[np.arange(pick.size), pick]
        found = np.isfinite(best)
        out[sl] = np.where(found, best, np.nan)
        at[sl] = np.where(found, pick, -1)
    return out, at


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

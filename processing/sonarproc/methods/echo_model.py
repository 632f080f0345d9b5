"""The first-echo model: which path length a reading would measure off a known curve.

A transmitter T (heading, half beamwidth) and a receiver R hear a surface first at the
point P of the surface inside both beams that minimises ``|TP| + |PR|`` (for T = R, the
nearest point in the beam: twice its distance). This is the simulator's specular model
for smooth surfaces seen within the beam, applied to a sampled curve. It predicts
readings from a fitted profile (:mod:`sonarproc.auto`) and makes the analytic logs of
the tests (:mod:`sonarproc.methods.testing`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["first_echo_path"]

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


def first_echo_path(
    tx_xy: npt.ArrayLike,
    tx_heading: npt.ArrayLike,
    tx_half: npt.ArrayLike,
    rx_xy: npt.ArrayLike,
    rx_heading: npt.ArrayLike,
    rx_half: npt.ArrayLike,
    curve: npt.ArrayLike,
) -> FloatArray:
    """Shortest path T -> P -> R over the curve's points P inside both beams.

    Parameters
    ----------
    tx_xy, rx_xy : array_like, (N, 2)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading, tx_half, rx_half : array_like, (N,)
        Beam axes and half beamwidths (rad).
    curve : array_like, (M, 2)
        Points of the surface, spaced well below the range resolution wanted.

    Returns
    -------
    ndarray, (N,)
        Path lengths (m); NaN where no point of the curve is inside both beams.

    Examples
    --------
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> first_echo_path([[0, 0]], [np.pi / 2], [0.2], [[0, 0]], [np.pi / 2], [0.2], wall)
    array([2.])
    """
    t = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
    ht = np.asarray(tx_heading, dtype=np.float64).reshape(-1)
    hr = np.asarray(rx_heading, dtype=np.float64).reshape(-1)
    wt = np.broadcast_to(np.asarray(tx_half, dtype=np.float64), ht.shape)
    wr = np.broadcast_to(np.asarray(rx_half, dtype=np.float64), hr.shape)
    pts = np.asarray(curve, dtype=np.float64).reshape(-1, 2)
    out = np.full(t.shape[0], np.nan)
    if pts.shape[0] == 0 or t.shape[0] == 0:
        return out
    step = max(1, _CHUNK // pts.shape[0])
    px, py = pts[None, :, 0], pts[None, :, 1]
    for i in range(0, t.shape[0], step):
        sl = slice(i, i + step)
        tdx, tdy = px - t[sl, 0:1], py - t[sl, 1:2]
        rdx, rdy = px - r[sl, 0:1], py - r[sl, 1:2]
        ok = _in_beam(tdx, tdy, ht[sl], wt[sl]) & _in_beam(rdx, rdy, hr[sl], wr[sl])
        path = np.hypot(tdx, tdy) + np.hypot(rdx, rdy)
        path[~ok] = np.inf
        best = path.min(axis=1)
        out[sl] = np.where(np.isfinite(best), best, np.nan)
    return out

"""Proven bounds for the rasteriser: the most arcs on one cell, the float32 error of a piece."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sonarproc.grid import Grid

__all__ = ["f32_error_bound", "overlap_bound"]

#: Side (cells) of the tiles on which :func:`overlap_bound` counts arcs.
_TILE = 64
#: Unit roundoff of float32.
_U32 = 2.0**-24

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
BoolArray = NDArray[np.bool_]


def overlap_bound(
    x_lo: FloatArray, x_hi: FloatArray, y_lo: FloatArray, y_hi: FloatArray, grid: Grid
) -> int:
    """An upper bound of any cell's count: the most piece boxes over one tile of cells.

    A piece's cells lie in its box (grid coordinates, widened by a cell); the boxes are
    added onto tiles of ``_TILE`` cells with a summed 2-D difference array.
    """
    if x_lo.shape[0] == 0:
        return 0
    nty = -(-grid.ny // _TILE)
    ntx = -(-grid.nx // _TILE)

    def tiles(lo: FloatArray, hi: FloatArray, nt: int) -> tuple[IntArray, IntArray]:
        with np.errstate(invalid="ignore"):
            a = np.clip(np.floor((lo - 1.0) / _TILE), 0, nt - 1)
            b = np.clip(np.floor((hi + 1.0) / _TILE), 0, nt - 1)
        return np.nan_to_num(a).astype(np.intp), np.nan_to_num(b, nan=nt - 1).astype(np.intp)

    tx0, tx1 = tiles(x_lo, x_hi, ntx)
    ty0, ty1 = tiles(y_lo, y_hi, nty)
    d = np.zeros((nty + 1) * (ntx + 1), dtype=np.int64)
    w = ntx + 1
    np.add.at(d, ty0 * w + tx0, 1)
    np.add.at(d, ty0 * w + tx1 + 1, -1)
    np.add.at(d, (ty1 + 1) * w + tx0, -1)
    np.add.at(d, (ty1 + 1) * w + tx1 + 1, 1)
    counts = np.cumsum(np.cumsum(d.reshape(nty + 1, w), axis=0), axis=1)
    return int(counts.max())


def f32_error_bound(
    u_first: FloatArray, u_last: FloatArray, beta: FloatArray, gamma: FloatArray, alpha: FloatArray
) -> FloatArray:
    """Bound (cells) of the error of ``v = f + alpha u +- sqrt(beta u^2 + gamma)`` in float32.

    ``f`` is in [0, 1) and ``u`` runs from ``u_first`` to ``u_last`` by steps of 1; the
    inputs are float64 values rounded to float32 and every operation rounds once (unit
    roundoff ``e``). With ``U = max |u|`` the rounded ``u`` is off by at most ``2 e U``,
    the radicand ``Q`` by ``dQ <= 7 e |beta| U^2 + 2 e gamma``; ``Q`` is concave in ``u``
    (``beta < 0``), so its least value on the piece is at an end, and the square root is
    off by at most ``dQ / (1.8 sqrt(Q_min)) + e sqrt(gamma)``. ``alpha u`` adds
    ``4 e |alpha| U``; the rounding of ``f`` and of ``f + eps`` (the shift of
    :func:`fill_block32`) ``2 e``; the two sums ``2 e (1 + |alpha| U + sqrt(gamma))``.
    The total, times 1.1 for the second-order terms, is returned; ``inf`` where ``Q_min``
    is not well clear of ``dQ``. ``test_float32_error_bound_holds`` checks it.
    """
    e = _U32
    big_u = np.maximum(np.abs(u_first), np.abs(u_last))
    with np.errstate(invalid="ignore", divide="ignore"):
        q_min = np.minimum(beta * u_first * u_first, beta * u_last * u_last) + gamma
        d_q = e * (7.0 * np.abs(beta) * big_u * big_u + 2.0 * np.abs(gamma))
        root = np.sqrt(np.abs(gamma))
        au = np.abs(alpha) * big_u
        # |sqrt(Q + d) - sqrt(Q)| = |d| / (sqrt(Q + d) + sqrt(Q)) <= |d| / (1.8 sqrt(Q))
        # when |d| < Q / 4.
        d_root = d_q / (1.8 * np.sqrt(np.maximum(q_min, 0.0))) + e * root
        bound = 1.1 * (d_root + 4.0 * e * au + 2.0 * e + 2.0 * e * (1.0 + au + root))
        bad = ~(q_min > 4.0 * d_q)
    bound[bad] = np.inf
    return np.asarray(bound, dtype=np.float64)

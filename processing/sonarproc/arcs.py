"""Rasterise sonar arcs onto a grid: the arc map (a count of arcs per cell).

Each reading's arc (see :mod:`sonarproc.arcs_geometry`) is drawn as a minimal
8-connected chain of cells, the way a midpoint circle algorithm draws one, but
vectorised over all arcs at once:

1. Each arc is cut into pieces at the points where its tangent is at 45 degrees. On a
   "flat" piece (``|dy/dx| <= 1``) the chain takes one cell per grid column, on a "steep"
   piece one cell per row; the other coordinate comes from the closed-form conic
   ``v = alpha u +- sqrt(beta u^2 + gamma)``. The exact end points of every piece (beam
   limits and the 45 degree points) are cells of the chain too, which closes the joints.
2. All pieces' samples are laid out in one flat array in order along each arc
   (``np.repeat`` of per-piece parameters; no Python loop per arc or per sample), in
   chunks that bound memory.
3. A cell can repeat only near joints and ends; repeats are found by comparing each cell
   with the few before it along the same arc (a bounded lag that holds for any arc whose
   tangent turns by at most 45 degrees; other arcs get an exact sort-based check) and are
   sent to a trash bin.
4. One ``np.bincount`` over flat cell indices of a grid padded by one cell makes the count
   map; cells outside the grid fall into the padding ring and are cut off.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sonarproc.arcs_geometry import (
    TWO_PI,
    ArcGeometry,
    arc_geometry,
    point_at,
    tangent_at,
)
from sonarproc.grid import Grid

__all__ = ["arc_bounds", "arc_cells", "arc_geometry", "rasterize_arcs"]

log = logging.getLogger(__name__)

#: Arcs whose tangent turns more than this (rad) get the exact duplicate check.
_SIMPLE_TURNING = np.pi / 4
#: How far back along an arc a repeated cell can be for a simple arc (samples).
_LAG = 6
#: Samples per chunk: bounds the working memory (about 20 arrays of this many float64).
_CHUNK = 1 << 18
#: Flat keys buffered before one bincount.
_BUFFER = 1 << 23

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class _Pieces:
    """Arc pieces along which one grid axis drives the chain, in order along each arc."""

    arc: IntArray  # reading index
    row: IntArray  # geometry row
    first_of_interval: NDArray[np.bool_]
    last_of_arc: NDArray[np.bool_]
    x_driven: NDArray[np.bool_]
    e_start: FloatArray
    e_end: FloatArray
    complex_arc: NDArray[np.bool_]


def _pieces(geom: ArcGeometry) -> _Pieces:
    """Split each interval at the 45-degree tangent points (vectorised)."""
    k = len(geom)
    lo = geom.lo.reshape(-1)
    length = geom.length.reshape(-1)
    row = np.repeat(np.arange(k, dtype=np.intp), 2)
    keep = np.isfinite(length)
    lo, length, row = lo[keep], length[keep], row[keep]
    a, b, alpha = geom.a[row], geom.b[row], geom.alpha[row]
    targets = np.array([0.25, 0.75, 1.25, 1.75]) * np.pi
    gamma = targets[None, :] - alpha[:, None]
    bp = np.arctan2(-b[:, None] * np.cos(gamma), a[:, None] * np.sin(gamma))
    rel = np.mod(bp - lo[:, None], TWO_PI)
    rel = np.where((rel > 0.0) & (rel < length[:, None]), rel, length[:, None])
    bounds = np.sort(
        np.concatenate([np.zeros((rel.shape[0], 1)), rel, length[:, None]], axis=1), axis=1
    )
    starts = bounds[:, :-1]
    ends = bounds[:, 1:]
    npc = starts.shape[1]
    keep2 = (ends > starts) | (np.arange(npc) == 0)[None, :]
    prow = np.repeat(row, npc).reshape(-1, npc)[keep2]
    e_start = (lo[:, None] + starts)[keep2]
    e_end = (lo[:, None] + ends)[keep2]
    first = np.broadcast_to(np.arange(npc) == 0, keep2.shape)[keep2]
    last = np.ones(prow.shape[0], dtype=bool)
    last[:-1] = prow[1:] != prow[:-1]
    mid = 0.5 * (e_start + e_end)
    tx, ty = tangent_at(mid, geom.a[prow], geom.b[prow], geom.alpha[prow])
    turning = np.where(np.isfinite(geom.turning), geom.turning, 0.0)
    two = np.isfinite(geom.length).all(axis=1)
    complex_row = (turning.max(axis=1) > _SIMPLE_TURNING) | two
    return _Pieces(
        arc=geom.arc[prow],
        row=prow,
        first_of_interval=first,
        last_of_arc=last,
        x_driven=np.abs(tx) >= np.abs(ty),
        e_start=e_start,
        e_end=e_end,
        complex_arc=complex_row[prow],
    )


@dataclass(frozen=True)
class _Plan:
    """Per-piece sample layout and conic parameters, in grid units."""

    pieces: _Pieces
    slots: IntArray  # samples per piece (start? + interior + end + sentinels?)
    pre: IntArray  # 1 when the piece starts with its interval's start point
    n_interior: IntArray
    first: FloatArray  # driver index of the first interior sample
    step: FloatArray  # +1 or -1
    d_centre: FloatArray  # driver-axis coordinate of the ellipse centre
    c_centre: FloatArray  # computed-axis coordinate of the centre
    c_alpha: FloatArray
    c_beta: FloatArray
    c_gamma: FloatArray
    sign: FloatArray
    c_max: FloatArray  # padded size of the computed axis - 1
    d_mult: IntArray  # flat-key multiplier of the (padded) driver index
    c_mult: IntArray
    start_key: IntArray  # padded flat key of the start point (if pre)
    end_key: IntArray


def _padded_key(gx: FloatArray, gy: FloatArray, grid: Grid) -> IntArray:
    """Flat key in the padded grid of continuous grid coordinates (clipped to the ring)."""
    w = grid.nx + 2
    ix = np.clip(np.floor(gx + 1.5), 0, grid.nx + 1).astype(np.intp)
    iy = np.clip(np.floor(gy + 1.5), 0, grid.ny + 1).astype(np.intp)
    return iy * w + ix


def _plan(geom: ArcGeometry, grid: Grid) -> _Plan:
    pcs = _pieces(geom)
    r = pcs.row
    cell = grid.cell
    a = geom.a[r] / cell
    b = geom.b[r] / cell
    alpha = geom.alpha[r]
    gcx = (geom.cx[r] - grid.x0) / cell
    gcy = (geom.cy[r] - grid.y0) / cell
    ca, sa = np.cos(alpha), np.sin(alpha)
    ia2 = 1.0 / (a * a)
    ib2 = 1.0 / (b * b)
    qa = ca * ca * ia2 + sa * sa * ib2
    qc = sa * sa * ia2 + ca * ca * ib2
    qb = 2.0 * ca * sa * (ia2 - ib2)
    inv_ab2 = ia2 * ib2
    xd = pcs.x_driven
    q_d = np.where(xd, qc, qa)  # coefficient of the computed coordinate squared
    c_alpha = -qb / (2.0 * q_d)
    c_beta = -inv_ab2 / (q_d * q_d)
    c_gamma = 1.0 / q_d
    d_centre = np.where(xd, gcx, gcy)
    c_centre = np.where(xd, gcy, gcx)
    # End points in grid coordinates.
    sx, sy = point_at(pcs.e_start, geom.cx[r], geom.cy[r], geom.a[r], geom.b[r], alpha)
    ex, ey = point_at(pcs.e_end, geom.cx[r], geom.cy[r], geom.a[r], geom.b[r], alpha)
    sx, sy = (sx - grid.x0) / cell, (sy - grid.y0) / cell
    ex, ey = (ex - grid.x0) / cell, (ey - grid.y0) / cell
    mx, my = point_at(
        0.5 * (pcs.e_start + pcs.e_end), geom.cx[r], geom.cy[r], geom.a[r], geom.b[r], alpha
    )
    mx, my = (mx - grid.x0) / cell, (my - grid.y0) / cell
    du = np.where(xd, mx - gcx, my - gcy)
    dv = np.where(xd, my - gcy, mx - gcx)
    sign = np.where(dv - c_alpha * du >= 0.0, 1.0, -1.0)
    ds = np.where(xd, sx, sy)
    de = np.where(xd, ex, ey)
    n_d = np.where(xd, grid.nx, grid.ny).astype(np.float64)
    up = de >= ds
    step = np.where(up, 1.0, -1.0)
    first = np.where(up, np.ceil(ds), np.floor(ds))
    last = np.where(up, np.floor(de), np.ceil(de))
    first = np.where(up, np.maximum(first, 0.0), np.minimum(first, n_d - 1.0))
    last = np.where(up, np.minimum(last, n_d - 1.0), np.maximum(last, 0.0))
    n_interior = np.maximum((last - first) * step + 1.0, 0.0).astype(np.intp)
    pre = pcs.first_of_interval.astype(np.intp)
    slots = pre + n_interior + 1 + np.where(pcs.last_of_arc, _LAG, 0)
    w = grid.nx + 2
    return _Plan(
        pieces=pcs,
        slots=slots,
        pre=pre,
        n_interior=n_interior,
        first=first,
        step=step,
        d_centre=d_centre,
        c_centre=c_centre,
        c_alpha=c_alpha,
        c_beta=c_beta,
        c_gamma=c_gamma,
        sign=sign,
        c_max=np.where(xd, grid.ny + 1, grid.nx + 1).astype(np.float64),
        d_mult=np.where(xd, 1, w).astype(np.intp),
        c_mult=np.where(xd, w, 1).astype(np.intp),
        start_key=_padded_key(sx, sy, grid),
        end_key=_padded_key(ex, ey, grid),
    )


def _chunks(plan: _Plan) -> Iterator[tuple[int, int]]:
    """Piece ranges ``[p0, p1)`` holding whole arcs and about ``_CHUNK`` samples."""
    arc_end = np.flatnonzero(plan.pieces.last_of_arc) + 1  # piece index after each arc
    if arc_end.shape[0] == 0:
        return
    cum_at_end = np.cumsum(plan.slots)[arc_end - 1]
    i = 0
    while i < arc_end.shape[0]:
        base = int(cum_at_end[i - 1]) if i > 0 else 0
        k = max(int(np.searchsorted(cum_at_end, base + _CHUNK, side="right")), i + 1)
        yield (int(arc_end[i - 1]) if i > 0 else 0), int(arc_end[k - 1])
        i = k


def _chunk_keys(plan: _Plan, p0: int, p1: int, trash: int) -> tuple[IntArray, IntArray]:
    """Padded flat keys of all samples of pieces ``[p0, p1)``, repeats sent to ``trash``.

    Returns the keys and the per-piece slot offsets (length ``p1 - p0 + 1``).
    """
    sl = slice(p0, p1)
    slots = plan.slots[sl]
    offs = np.zeros(slots.shape[0] + 1, dtype=np.intp)
    np.cumsum(slots, out=offs[1:])
    total = int(offs[-1])
    pre = plan.pre[sl]
    step = plan.step[sl]
    # Driver index of slot j: first + step * (j - offs - pre).
    k0 = plan.first[sl] - step * (offs[:-1] + pre)
    j = np.arange(total, dtype=np.float64)

    def rep(v: NDArray[Any]) -> NDArray[Any]:
        return np.repeat(v, slots)

    d = rep(step) * j
    d += rep(k0)
    u = d - rep(plan.d_centre[sl])
    q = u * u
    q *= rep(plan.c_beta[sl])
    q += rep(plan.c_gamma[sl])
    np.maximum(q, 0.0, out=q)
    np.sqrt(q, out=q)
    q *= rep(plan.sign[sl])
    u *= rep(plan.c_alpha[sl])
    q += u
    q += rep(plan.c_centre[sl] + 1.5)
    np.clip(q, 0.0, rep(plan.c_max[sl]), out=q)
    ci = q.astype(np.intp)
    di = d.astype(np.intp)
    di += 1
    keys = di * rep(plan.d_mult[sl])
    ci *= rep(plan.c_mult[sl])
    keys += ci
    # End points and sentinels.
    has_pre = pre.astype(bool)
    keys[offs[:-1][has_pre]] = plan.start_key[sl][has_pre]
    end_pos = offs[:-1] + pre + plan.n_interior[sl]
    keys[end_pos] = plan.end_key[sl]
    last = plan.pieces.last_of_arc[sl]
    sent0 = end_pos[last] + 1
    for i in range(_LAG):
        keys[sent0 + i] = trash + i
    # Repeats within a short lag along an arc (the sentinels keep arcs apart).
    dup = np.zeros(total, dtype=bool)
    for lag in range(1, _LAG + 1):
        dup[lag:] |= keys[lag:] == keys[:-lag]
    # Exact check for complex arcs.
    cx = plan.pieces.complex_arc[sl]
    if cx.any():
        idx = _ranges(offs[:-1][cx], slots[cx])
        owner = np.repeat(plan.pieces.arc[sl][cx], slots[cx])
        comb = owner.astype(np.int64) * np.int64(trash + _LAG + 1) + keys[idx]
        _, first_idx = np.unique(comb, return_index=True)
        rep_mask = np.ones(idx.shape[0], dtype=bool)
        rep_mask[first_idx] = False
        dup[idx[rep_mask]] = True
    keys[dup] = trash
    return keys, offs


def _ranges(starts: IntArray, lengths: IntArray) -> IntArray:
    """Concatenation of ``arange(s, s + n)`` for each pair (vectorised)."""
    before = np.cumsum(lengths) - lengths
    total = int(lengths.sum())
    return np.arange(total, dtype=np.intp) + np.repeat(starts - before, lengths)


def arc_bounds(
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    path: ArrayLike,
    *,
    tx_half_beamwidth: ArrayLike,
    rx_half_beamwidth: ArrayLike,
) -> tuple[float, float, float, float]:
    """Bounding box ``(xmin, xmax, ymin, ymax)`` (m) of all arcs (joint-region parts).

    Parameters
    ----------
    tx_xy, rx_xy : array_like, (N, 2)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading : array_like, (N,)
        Beam axes (rad, world frame).
    path : array_like, (N,)
        Path lengths ``|TP| + |PR|`` (m), i.e. tof x speed of sound.
    tx_half_beamwidth, rx_half_beamwidth : float or array_like, (N,)
        Half beamwidths (rad).

    Returns
    -------
    tuple of float

    Raises
    ------
    ValueError
        If no reading makes an arc (or on malformed input shapes).

    Examples
    --------
    >>> b = arc_bounds([[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [2.0],
    ...                tx_half_beamwidth=np.pi / 2, rx_half_beamwidth=np.pi / 2)
    >>> [round(v, 9) for v in b]
    [0.0, 1.0, -1.0, 1.0]
    """
    geom = arc_geometry(
        tx_xy,
        tx_heading,
        rx_xy,
        rx_heading,
        path,
        tx_half_beamwidth=tx_half_beamwidth,
        rx_half_beamwidth=rx_half_beamwidth,
    )
    if len(geom) == 0:
        raise ValueError("no reading makes an arc (paths too short or outside the beams)")
    lo = geom.lo
    length = geom.length
    # Candidate E: interval ends and the four axis extremes of each ellipse inside them.
    ca = np.cos(geom.alpha)[:, None]
    sa = np.sin(geom.alpha)[:, None]
    aa = geom.a[:, None]
    bb = geom.b[:, None]
    ex = np.arctan2(-bb * sa, aa * ca)  # dx/dE = 0
    ey = np.arctan2(bb * ca, aa * sa)  # dy/dE = 0
    extremes = np.concatenate([ex, ex + np.pi, ey, ey + np.pi], axis=1)  # (K, 4)
    cands = [lo, lo + length]
    for i in range(extremes.shape[1]):
        rel = np.mod(extremes[:, i : i + 1] - lo, TWO_PI)
        cands.append(np.where(rel <= length, lo + rel, lo))
    e = np.concatenate(cands, axis=1)
    x, y = point_at(e, geom.cx[:, None], geom.cy[:, None], aa, bb, geom.alpha[:, None])
    return (
        float(np.nanmin(x)),
        float(np.nanmax(x)),
        float(np.nanmin(y)),
        float(np.nanmax(y)),
    )


def _plan_for(
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    path: ArrayLike,
    tx_half_beamwidth: ArrayLike,
    rx_half_beamwidth: ArrayLike,
    grid: Grid,
) -> _Plan:
    geom = arc_geometry(
        tx_xy,
        tx_heading,
        rx_xy,
        rx_heading,
        path,
        tx_half_beamwidth=tx_half_beamwidth,
        rx_half_beamwidth=rx_half_beamwidth,
    )
    return _plan(geom, grid)


def rasterize_arcs(
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    path: ArrayLike,
    *,
    tx_half_beamwidth: ArrayLike,
    rx_half_beamwidth: ArrayLike,
    grid: Grid,
) -> NDArray[np.uint32]:
    """Count map: for each grid cell, how many distinct arcs cross it.

    Each reading makes one arc (circular when the transmitter and receiver positions are
    equal, elliptical otherwise), limited to the joint sensitivity region of the two
    beams. Each arc is an 8-connected chain of cells without repeats; cells outside the
    grid are clipped. Readings whose path is too short (``<= |TR|``), not finite, or whose
    arc misses the joint region make no cells.

    Parameters
    ----------
    tx_xy, rx_xy : array_like, (N, 2)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading : array_like, (N,)
        Beam axes (rad, world frame).
    path : array_like, (N,)
        Path lengths ``|TP| + |PR|`` (m).
    tx_half_beamwidth, rx_half_beamwidth : float or array_like, (N,)
        Half beamwidths (rad).
    grid : Grid
        The map grid.

    Returns
    -------
    ndarray of uint32, shape ``grid.shape``
        The binary arc map is ``counts >= 1``.

    Examples
    --------
    >>> g = Grid.covering(-1.0, 1.0, -1.0, 1.0, cell=0.01)
    >>> c = rasterize_arcs([[0, 0], [0, 0]], [0.0, np.pi / 2], [[0, 0], [0, 0]],
    ...                    [0.0, np.pi / 2], [1.0, 1.0], tx_half_beamwidth=np.pi / 2,
    ...                    rx_half_beamwidth=np.pi / 2, grid=g)
    >>> int(c.max()), int((c == 2).sum()) > 0, c.dtype.name
    (2, True, 'uint32')
    """
    plan = _plan_for(
        tx_xy, tx_heading, rx_xy, rx_heading, path, tx_half_beamwidth, rx_half_beamwidth, grid
    )
    npad = (grid.ny + 2) * (grid.nx + 2)
    trash = npad
    counts = np.zeros(npad + _LAG + 1, dtype=np.uint32)
    buffer: list[IntArray] = []
    buffered = 0
    for p0, p1 in _chunks(plan):
        keys, _ = _chunk_keys(plan, p0, p1, trash)
        buffer.append(keys)
        buffered += keys.shape[0]
        if buffered >= _BUFFER:
            counts += np.bincount(np.concatenate(buffer), minlength=counts.shape[0]).astype(
                np.uint32
            )
            buffer.clear()
            buffered = 0
    if buffer:
        counts += np.bincount(np.concatenate(buffer), minlength=counts.shape[0]).astype(np.uint32)
    return counts[:npad].reshape(grid.ny + 2, grid.nx + 2)[1:-1, 1:-1].copy()


def arc_cells(
    tx_xy: ArrayLike,
    tx_heading: ArrayLike,
    rx_xy: ArrayLike,
    rx_heading: ArrayLike,
    path: ArrayLike,
    *,
    tx_half_beamwidth: ArrayLike,
    rx_half_beamwidth: ArrayLike,
    grid: Grid,
) -> tuple[IntArray, IntArray, IntArray]:
    """The cells of every arc inside the grid, in order along each arc.

    Same inputs and rules as :func:`rasterize_arcs`; ``np.add.at(m, (iy, ix), 1)`` on a
    zero map of ``grid.shape`` gives its count map.

    Returns
    -------
    arc_id, iy, ix : ndarray of intp
        For each arc cell, the index of its reading and the cell's row and column.

    Examples
    --------
    >>> g = Grid.covering(-0.1, 0.1, -0.1, 0.1, cell=0.01)
    >>> arc, iy, ix = arc_cells([[0, 0]], [0.0], [[0, 0]], [0.0], [0.2],
    ...                         tx_half_beamwidth=np.pi, rx_half_beamwidth=np.pi, grid=g)
    >>> len(arc), sorted(set(arc.tolist()))
    (56, [0])
    """
    plan = _plan_for(
        tx_xy, tx_heading, rx_xy, rx_heading, path, tx_half_beamwidth, rx_half_beamwidth, grid
    )
    w = grid.nx + 2
    npad = (grid.ny + 2) * w
    out_arc: list[IntArray] = []
    out_key: list[IntArray] = []
    for p0, p1 in _chunks(plan):
        keys, offs = _chunk_keys(plan, p0, p1, npad)
        owner = np.repeat(plan.pieces.arc[p0:p1], np.diff(offs))
        iy, ix = np.divmod(keys, w)
        ok = (keys < npad) & (iy >= 1) & (iy <= grid.ny) & (ix >= 1) & (ix <= grid.nx)
        out_arc.append(owner[ok])
        out_key.append(keys[ok])
    if not out_key:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty.copy(), empty.copy()
    keys = np.concatenate(out_key)
    iy, ix = np.divmod(keys, w)
    return np.concatenate(out_arc).astype(np.intp), iy - 1, ix - 1

"""Rasterise sonar arcs onto a grid: the arc map (a count of arcs per cell).

Each reading makes one arc (:mod:`sonarproc.arcs_geometry`): a circle arc when the
transmitter and receiver are at one place, an ellipse arc otherwise, cut to the joint
sensitivity region of both beams. Each arc becomes a minimal 8-connected chain of cells
with no cell twice; the count map holds, for each cell, how many distinct arcs cross it
(the binary arc map is ``counts >= 1``). The vectorised engine is in
:mod:`sonarproc.arcs_raster`.
"""

from __future__ import annotations

import logging

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sonarproc.arcs_geometry import (
    arc_geometry,
    mod_2pi,
)
from sonarproc.arcs_raster import (
    IntArray,
    _accumulate,
    _batch_keys,
    _batches,
    _Plan,
    _plan,
    _ranges,
    _unit,
)
from sonarproc.grid import Grid

__all__ = ["arc_bounds", "arc_cells", "arc_geometry", "rasterize_arcs"]

log = logging.getLogger(__name__)


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
    >>> [round(v, 6) + 0.0 for v in b]
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
    # The arc ends, and each ellipse's axis extremes (cx +- hx, cy +- hy) where an
    # interval holds them.
    ends = np.concatenate([lo, lo + length], axis=1)
    c, s = _unit(ends)
    ca = geom.ca[:, None]
    sa = geom.sa[:, None]
    aa = geom.a[:, None]
    bb = geom.b[:, None]
    x = geom.cx[:, None] + aa * c * ca - bb * s * sa
    y = geom.cy[:, None] + aa * c * sa + bb * s * ca
    xmin, xmax = np.nanmin(x), np.nanmax(x)
    ymin, ymax = np.nanmin(y), np.nanmax(y)
    a, b = geom.a, geom.b
    cas, sas = geom.ca, geom.sa
    hx = np.sqrt((a * cas) ** 2 + (b * sas) ** 2)
    hy = np.sqrt((a * sas) ** 2 + (b * cas) ** 2)
    e_xmax = np.arctan2(-b * sas, a * cas)
    e_ymax = np.arctan2(b * cas, a * sas)
    for e, centre, half, is_x in (
        (e_xmax, geom.cx, hx, True),
        (e_ymax, geom.cy, hy, False),
    ):
        for flip in (0.0, np.pi):  # the max, then the min
            held = np.zeros(len(geom), dtype=bool)
            for k in range(2):
                with np.errstate(invalid="ignore"):
                    held |= mod_2pi(e + flip - lo[:, k]) <= length[:, k]
            if held.any():
                v = centre[held] + (half[held] if flip == 0.0 else -half[held])
                if is_x:
                    xmin, xmax = min(xmin, v.min()), max(xmax, v.max())
                else:
                    ymin, ymax = min(ymin, v.min()), max(ymax, v.max())
    return float(xmin), float(xmax), float(ymin), float(ymax)


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
    size = grid.ny * grid.nx
    # The map, then the trash bin. uint16 scatters faster (half the memory) where no cell
    # can reach 2**16 arcs; the trash bin may wrap, harmlessly.
    if plan.overlap < 1 << 16:
        c16 = np.zeros(size + 1, dtype=np.uint16)
        _accumulate(plan, c16, size)
        return c16[:size].reshape(grid.shape).astype(np.uint32)
    c32 = np.zeros(size + 1, dtype=np.uint32)
    _accumulate(plan, c32, size)
    return c32[:size].reshape(grid.shape)


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
    size = grid.ny * grid.nx
    out_arc: list[IntArray] = []
    out_key: list[IntArray] = []
    for p0, p1 in _batches(plan):
        bk = _batch_keys(plan, p0, p1, size)
        n = plan.n[p0:p1]
        pre = plan.pre[p0:p1]
        # Buffer positions in order along each arc: start point, interior, end point.
        cnt = pre + n + 1
        off = np.cumsum(cnt) - cnt
        src = np.empty(int(cnt.sum()), dtype=np.intp)
        has_pre = pre.astype(bool)
        src[off[has_pre]] = bk.start_pos[has_pre]
        src[_ranges(off + pre, n)] = _ranges(bk.row_base, n)
        src[off + pre + n] = bk.end_pos
        keys = bk.keys[src]
        owner = np.repeat(plan.arc[p0:p1], cnt)
        ok = keys < size
        out_arc.append(owner[ok])
        out_key.append(keys[ok])
    if not out_key:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty.copy(), empty.copy()
    keys = np.concatenate(out_key)
    iy, ix = np.divmod(keys, grid.nx)
    return np.concatenate(out_arc).astype(np.intp), iy, ix

"""Arcs to cells: the count map (distinct arcs per cell) and each arc's cell chain.

Each arc (:class:`~sonarproc.arcs.ArcGeometry`) becomes a minimal 8-connected chain of
cells with no cell twice (:mod:`sonarproc.arcs._raster`), or, in the paper-style mode, a
set of samples at a fixed angular step (:mod:`sonarproc.arcs._sampled`). The count map
holds, for each cell, how many distinct arcs cross it; the binary arc map is
``counts >= 1``.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs._geometry import ArcGeometry
from sonarproc.arcs._plan import IntArray, plan_pieces
from sonarproc.arcs._raster import accumulate, batch_keys, batches, ranges
from sonarproc.arcs._sampled import arc_samples
from sonarproc.grid import Grid

__all__ = ["RASTER_METHODS", "arc_cell_keys", "arc_cells", "rasterize"]

#: How arcs become cells: a gap-free chain (default) or samples at a fixed angular step.
RASTER_METHODS = ("connected", "sampled")

RasterMethod = Literal["connected", "sampled"]


def rasterize(
    arcs: ArcGeometry,
    grid: Grid,
    *,
    method: RasterMethod = "connected",
    step: float | None = None,
) -> NDArray[np.uint32]:
    """Count map: for each grid cell, how many distinct arcs cross it.

    Parameters
    ----------
    arcs : ArcGeometry
        The arcs (:func:`sonarproc.arcs.arc_geometry`), computed once per run.
    grid : Grid
        The map grid; cells outside it are clipped.
    method : {"connected", "sampled"}
        ``connected`` draws each arc as an 8-connected chain of cells without repeats;
        ``sampled`` sets the cell under a sample every ``step`` rad of the arc's angle, as
        a C loop over angles would (gaps where the step spans more than a cell).
    step : float, optional
        The angular step (rad) of ``sampled``; required there, refused otherwise.

    Returns
    -------
    ndarray of uint32, shape ``grid.shape``
        The binary arc map is ``counts >= 1``.

    Raises
    ------
    ValueError
        An unknown method, or a step missing for ``sampled`` (or given for ``connected``).

    Examples
    --------
    >>> from sonarproc.arcs import arc_geometry
    >>> g = Grid.covering(-1.0, 1.0, -1.0, 1.0, cell=0.01)
    >>> arcs = arc_geometry([[0, 0], [0, 0]], [0.0, np.pi / 2], [[0, 0], [0, 0]],
    ...                     [0.0, np.pi / 2], [1.0, 1.0], tx_half_beamwidth=np.pi / 2,
    ...                     rx_half_beamwidth=np.pi / 2)
    >>> c = rasterize(arcs, g)
    >>> int(c.max()), int((c == 2).sum()) > 0, c.dtype.name
    (2, True, 'uint32')
    """
    if method == "sampled":
        if step is None:
            raise ValueError("step is required for method 'sampled'")
        _, iy, ix = arc_samples(arcs, grid, step=step)
        counts = np.bincount(iy * grid.nx + ix, minlength=grid.ny * grid.nx)
        return counts.astype(np.uint32).reshape(grid.shape)
    if method != "connected":
        raise ValueError(f"method must be one of {', '.join(RASTER_METHODS)}, got {method!r}")
    if step is not None:
        raise ValueError("step applies to method 'sampled' only")
    plan = plan_pieces(arcs, grid)
    size = grid.ny * grid.nx
    # The map, then the trash bin. uint16 scatters faster (half the memory) where no cell
    # can reach 2**16 arcs; the trash bin may wrap, harmlessly.
    if plan.overlap < 1 << 16:
        c16 = np.zeros(size + 1, dtype=np.uint16)
        accumulate(plan, c16, size)
        return c16[:size].reshape(grid.shape).astype(np.uint32)
    c32 = np.zeros(size + 1, dtype=np.uint32)
    accumulate(plan, c32, size)
    return c32[:size].reshape(grid.shape)


def arc_cells(arcs: ArcGeometry, grid: Grid) -> tuple[IntArray, IntArray, IntArray]:
    """The cells of every arc inside the grid, in order along each arc.

    Same rules as :func:`rasterize` (``connected``); ``np.add.at(m, (iy, ix), 1)`` on a
    zero map of ``grid.shape`` gives its count map.

    Returns
    -------
    arc_id, iy, ix : ndarray of intp
        For each arc cell, the index of its reading and the cell's row and column.

    Examples
    --------
    >>> from sonarproc.arcs import arc_geometry
    >>> g = Grid.covering(-0.1, 0.1, -0.1, 0.1, cell=0.01)
    >>> arcs = arc_geometry([[0, 0]], [0.0], [[0, 0]], [0.0], [0.2],
    ...                     tx_half_beamwidth=np.pi, rx_half_beamwidth=np.pi)
    >>> arc, iy, ix = arc_cells(arcs, g)
    >>> len(arc), sorted(set(arc.tolist()))
    (56, [0])
    >>> bool(np.array_equal(arc_cell_keys(arcs, g)[1], iy * g.nx + ix))
    True
    """
    arc, keys = arc_cell_keys(arcs, grid)
    iy, ix = np.divmod(keys, grid.nx)
    return arc, iy, ix


def arc_cell_keys(arcs: ArcGeometry, grid: Grid) -> tuple[IntArray, IntArray]:
    """:func:`arc_cells` with each cell as its flat index ``iy * grid.nx + ix`` (what a
    walk along the arcs over a flat count map wants; the example is :func:`arc_cells`')."""
    plan = plan_pieces(arcs, grid)
    size = grid.ny * grid.nx
    out_arc: list[IntArray] = []
    out_key: list[IntArray] = []
    for p0, p1 in batches(plan):
        bk = batch_keys(plan, p0, p1, size)
        n = plan.n[p0:p1]
        pre = plan.pre[p0:p1]
        # Buffer positions in order along each arc: start point, interior, end point.
        cnt = pre + n + 1
        off = np.cumsum(cnt) - cnt
        src = np.empty(int(cnt.sum()), dtype=np.intp)
        has_pre = pre.astype(bool)
        src[off[has_pre]] = bk.start_pos[has_pre]
        src[ranges(off + pre, n)] = ranges(bk.row_base, n)
        src[off + pre + n] = bk.end_pos
        keys = bk.keys[src]
        owner = np.repeat(plan.arc[p0:p1], cnt)
        ok = keys < size
        out_arc.append(owner[ok])
        out_key.append(keys[ok])
    if not out_key:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    return np.concatenate(out_arc).astype(np.intp), np.concatenate(out_key).astype(np.intp)

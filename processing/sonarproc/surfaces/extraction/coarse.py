"""A coarser count map: the arc counts summed over square blocks of cells.

The surfaces are extracted on a map of about 2 cm cells (see
:mod:`sonarproc.pipeline.surfacefit`); this sums a finer count map into it without
copying it into a padded array or any array of the fine map's size: the ``k x k``
strided views of the blocks' cells are added in turn (the last block may be narrower, as
if padded with zeros).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid

__all__ = ["coarse_counts"]


def coarse_counts(
    counts: npt.ArrayLike, grid: Grid, cell_m: float
) -> tuple[npt.NDArray[np.int64], Grid]:
    """Counts summed over blocks of ``k x k`` cells (``k = round(cell_m / grid.cell)``).

    The coarse grid's cell centres are the blocks' centres; a block cut by the map's
    edge sums the cells it has.

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=0.01, nx=5, ny=4)
    >>> c, cg = coarse_counts(np.ones((4, 5), int), g, 0.02)
    >>> c.tolist(), (cg.x0, cg.cell, cg.nx, cg.ny)
    ([[4, 4, 2], [4, 4, 2]], (0.005, 0.02, 3, 2))
    """
    c = np.asarray(counts)
    k = max(1, round(cell_m / grid.cell))
    if k == 1:
        return c.astype(np.int64), grid
    ny, nx = -(-grid.ny // k), -(-grid.nx // k)
    summed = np.zeros((ny, nx), dtype=np.int64)
    for i in range(k):
        for j in range(k):
            part = c[i::k, j::k]
            summed[: part.shape[0], : part.shape[1]] += part
    half = 0.5 * (k - 1) * grid.cell
    return summed, Grid(grid.x0 + half, grid.y0 + half, k * grid.cell, nx, ny)

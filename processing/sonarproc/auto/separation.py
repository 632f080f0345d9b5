"""One profile y(x), not a surface and stray clusters bridged: the columns a profile fits.

A y(x) candidate fits every kept cell of its map. Echoes off other surfaces and
second-order echoes off a room's corners leave clusters of cells far from the surface
(metres behind a cardboard in a lab), and a spline through every column runs through
them. The map's occupied columns are cut into runs at gaps of at least
:data:`SPLIT_GAP_M`; a run continues an earlier one when their facing ends differ in y
by at most :data:`STEP_M` or by no more than the gap is wide (a slope of at most 45°
across it: a wave's crest and trough, with the flanks between them unseen, still
continue each other). Each run joins the latest chain it continues (so a cluster that
interrupts a surface does not cut it), or starts its own, and the profile is fitted to
the chain holding the most cells; the others are left out of it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid
from sonarproc.methods.base import MethodMap

__all__ = [
    "LEFT_OUT", "SEPARATION_RULE", "SPLIT_GAP_M", "STEP_M", "profile_columns", "profile_map",
]  # fmt: skip

#: Gaps between occupied columns at least this wide (m) may separate two surfaces.
SPLIT_GAP_M = 0.3
#: Runs whose facing ends differ in y by at most this much (m) continue each other.
STEP_M = 0.5
#: The run's count (report.json ``counts``) of map cells left out of a profile.
LEFT_OUT = "profile_cells_left_out"
#: What report.json's ``auto.profile_columns`` says the rule is.
SEPARATION_RULE = (
    f"the profile is fitted to the chain of column runs (cut at gaps of {SPLIT_GAP_M:g} m or "
    f"more; a run continues another when their facing ends differ in y by at most "
    f"{STEP_M:g} m or by no more than the gap's width) holding the most cells; the map's "
    "other cells (stray echo clusters) are left out"
)


def profile_columns(processed: npt.NDArray[np.bool_], grid: Grid) -> npt.NDArray[np.bool_]:
    """The columns of the map a profile y(x) is fitted to (all of them unless it splits;
    then the main chain's occupied columns).

    Examples
    --------
    A wall at y = 1.5 m (x = 0.2 to 1.9 m) interrupted by a cluster 2.2 m behind it:

    >>> g = Grid.covering(0.0, 3.0, 0.0, 4.0, cell=0.1)
    >>> m = np.zeros(g.shape, dtype=bool)
    >>> m[15, 2:8] = m[15, 13:20] = True
    >>> m[37, 10] = True
    >>> keep = profile_columns(m, g)
    >>> int(keep[m.any(axis=0)].sum()), bool(keep[5] and keep[15]), bool(keep[10])
    (13, True, False)
    """
    keep = np.ones(grid.nx, dtype=bool)
    ix, iy = np.nonzero(processed.T)
    if ix.size == 0:
        return keep
    cells = np.bincount(ix, minlength=grid.nx)
    cols = np.flatnonzero(cells)
    sum_y = np.bincount(ix, weights=grid.to_world(iy, ix)[1], minlength=grid.nx)
    mean_y = sum_y[cols] / cells[cols]
    cut = np.flatnonzero(np.diff(cols) * grid.cell >= SPLIT_GAP_M)
    if cut.size == 0:
        return keep
    # runs of columns: [first, last] indices into cols
    first = np.r_[0, cut + 1]
    last = np.r_[cut, cols.size - 1]
    # a handful of runs: the chaining is a short loop over them, not over cells
    chain_end: list[int] = []  # each chain's last run
    chain_of = np.empty(first.size, dtype=np.intp)
    for r in range(int(first.size)):
        joined = -1
        for c in range(len(chain_end) - 1, -1, -1):
            prev = chain_end[c]
            gap = (cols[first[r]] - cols[last[prev]]) * grid.cell
            step = abs(mean_y[first[r]] - mean_y[last[prev]])
            if step <= max(STEP_M, gap):
                joined = c
                break
        if joined < 0:
            chain_end.append(r)
            joined = len(chain_end) - 1
        chain_end[joined] = r
        chain_of[r] = joined
    if len(chain_end) == 1:
        return keep
    run_cells = np.add.reduceat(cells[cols], first)
    main = int(np.argmax(np.bincount(chain_of, weights=run_cells)))
    run_of_col = np.repeat(np.arange(first.size), last - first + 1)
    keep[:] = False
    keep[cols[chain_of[run_of_col] == main]] = True
    return keep


def profile_map(mmap: MethodMap, grid: Grid) -> tuple[MethodMap, int]:
    """``mmap`` with only the cells of :func:`profile_columns`, and how many it left out."""
    kept = mmap.processed & profile_columns(mmap.processed, grid)[None, :]
    left_out = int(np.count_nonzero(mmap.processed)) - int(np.count_nonzero(kept))
    return (replace(mmap, processed=kept) if left_out else mmap), left_out

"""Methods that keep one cell per arc: directional maximum and the arc-transversal median.

Both start from the arc count map of :func:`sonarproc.arcs.rasterize` (distinct arcs per
cell) and walk every arc's cells in order along the arc (:func:`sonarproc.arcs.arc_cell_keys`);
each arc then votes for one cell, and the processed map is the set of voted cells (the
evidence: how many arcs voted for a cell). Everything is numpy group operations over the
concatenated cells of all arcs, with no loop per arc.

* ``directional-max``: Barshan (IJRR 2007, "Directional processing of ultrasonic arc maps
  and its comparison with existing techniques"): along each arc, in its direction of
  propagation, the cell of maximum count is where the arc's echo most likely came from;
  a run of tied maxima votes for its middle cell.
* ``arc-median``: the arc-transversal median of Choset, Nagatani & Lazar (IEEE T-RA 2003,
  "The arc-transversal median algorithm: a geometric approach to increasing ultrasonic
  sensor azimuth accuracy"): each arc's echo lies at the median of the arc's intersections
  with the other arcs crossing it; on the grid, an arc cell crossed by ``c`` arcs holds
  ``c - 1`` intersections, and the arc votes for the cell at the weighted median position.
  Arcs no other arc crosses vote for nothing.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from sonarproc.arcs import arc_cell_keys
from sonarproc.errors import ParameterError
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MapMethod, MethodMap, OptionValue
from sonarproc.params import RunParams

__all__ = ["ArcMedian", "DirectionalMaximum", "ordered_arc_cells", "vote_map"]

IntArray = npt.NDArray[np.intp]


class _LastWalk(threading.local):
    """One entry per thread: both methods of a comparison (or of an --auto fold) share one
    walk of the arcs. Keyed on the Beams object itself (kept alive here, so its id cannot
    be reused); per thread, as --auto builds its folds' maps on several."""

    entry: tuple[Any, ...] = ()


_LAST = _LastWalk()


def ordered_arc_cells(beams: Beams, grid: Grid) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """Every arc's cells in order along the arc, grouped by arc, and the count per cell.

    Returns
    -------
    arc, flat : ndarray of intp
        Arc (reading index) and flat cell index ``iy * nx + ix`` of each arc cell; the
        cells of one arc are contiguous and in order along it.
    count : ndarray of intp
        The count map's value at each arc cell (distinct arcs crossing it).
    start : ndarray of intp
        Index into ``arc`` where each arc's run starts (one entry per arc with a cell).
    """
    last = _LAST.entry
    if last and last[0] is beams and last[1] == grid:
        return last[2]
    arc, flat = arc_cell_keys(beams.arcs, grid)
    # keep each arc's own order (stable), only group arcs together
    order = np.argsort(arc, kind="stable")
    arc, flat = arc[order], flat[order]
    counts = np.bincount(flat, minlength=grid.ny * grid.nx)
    start = np.flatnonzero(np.r_[True, arc[1:] != arc[:-1]]) if arc.size else arc
    out = (arc, flat, counts[flat], start)
    _LAST.entry = (beams, grid, out)
    return out


def vote_map(flat: IntArray, grid: Grid) -> MethodMap:
    """The map of voted cells ``flat`` (evidence: votes per cell)."""
    votes = np.bincount(flat, minlength=grid.ny * grid.nx).reshape(grid.shape)
    return MethodMap(votes >= 1, votes.astype(np.uint32))


def _group_ids(start: IntArray, size: int) -> IntArray:
    g = np.zeros(size, dtype=np.intp)
    if start.size > 1:
        g[start[1:]] = 1
    return np.cumsum(g)


class DirectionalMaximum(MapMethod):
    """Directional maximum (Barshan 2007): each arc votes for its cell of maximum count.

    Option ``min_count``: an arc whose maximum count is below it votes for nothing (an
    arc no other arc confirms is most likely a spurious echo).

    Examples
    --------
    A flat wall at y = 1 m seen by sensors along y = 0: the votes lie on the wall.

    >>> from sonarproc.methods.testing import flat_wall_beams
    >>> beams, grid = flat_wall_beams()
    >>> m = DirectionalMaximum().build(beams, grid, RunParams())
    >>> iy, ix = np.nonzero(m.processed)
    >>> bool(np.all(np.abs(grid.to_world(iy, ix)[1] - 1.0) <= 0.015))
    True
    """

    name: ClassVar[str] = "directional-max"
    summary: ClassVar[str] = "each arc votes for its cell of maximum count (Barshan 2007)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {"min_count": 2}

    def validate(self) -> None:
        if int(self.options["min_count"]) < 1:
            raise ParameterError(self.name, "option min_count must be >= 1")

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        arc, flat, count, start = ordered_arc_cells(beams, grid)
        if arc.size == 0:
            return vote_map(flat, grid)
        group = _group_ids(start, arc.size)
        best = np.maximum.reduceat(count, start)
        is_max = count == best[group]
        # the middle of the arc's maximal cells, in order along the arc
        n_max = np.bincount(group, weights=is_max, minlength=start.size).astype(np.intp)
        rank = np.cumsum(is_max) - 1  # rank among all maximal cells so far
        first = np.r_[0, np.cumsum(n_max)[:-1]]
        pick = is_max & (rank - first[group] == n_max[group] // 2)
        pick &= best[group] >= int(self.options["min_count"])
        return vote_map(flat[pick], grid)


class ArcMedian(MapMethod):
    """Arc-transversal median (Choset et al. 2003): the median of an arc's crossings.

    Option ``min_crossings``: an arc crossed by fewer other arcs votes for nothing.

    Examples
    --------
    >>> from sonarproc.methods.testing import flat_wall_beams
    >>> beams, grid = flat_wall_beams()
    >>> m = ArcMedian().build(beams, grid, RunParams())
    >>> iy, ix = np.nonzero(m.processed)
    >>> bool(np.all(np.abs(grid.to_world(iy, ix)[1] - 1.0) <= 0.03))
    True
    """

    name: ClassVar[str] = "arc-median"
    summary: ClassVar[str] = "each arc votes for the median of its crossings (Choset et al. 2003)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {"min_crossings": 2}

    def validate(self) -> None:
        if int(self.options["min_crossings"]) < 1:
            raise ParameterError(self.name, "option min_crossings must be >= 1")

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        arc, flat, count, start = ordered_arc_cells(beams, grid)
        if arc.size == 0:
            return vote_map(flat, grid)
        group = _group_ids(start, arc.size)
        w = count - 1  # the other arcs crossing this cell
        cum = np.cumsum(w)
        before = np.r_[0, cum][start]  # crossings of earlier arcs
        total = np.add.reduceat(w, start)
        within = cum - before[group]
        # first cell of each arc whose cumulative crossings reach half the arc's total
        # (within grows along the arc, so this is one run at each arc's end)
        reach = 2 * within >= total[group]
        earlier = np.r_[False, reach[:-1] & (group[1:] == group[:-1])]
        pick = reach & ~earlier & (total[group] >= int(self.options["min_crossings"]))
        return vote_map(flat[pick], grid)

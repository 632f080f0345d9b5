"""Live processing: an arc-map accumulator fed readings as a log grows.

:class:`LiveAccumulator` keeps the count map between updates and rasterises only the new
readings' arcs onto it (the expensive step); morphology, fit and metrics are redone on
each :meth:`LiveAccumulator.snapshot`, which returns the same
:class:`~sonarproc.pipeline.RunResult` as :func:`sonarproc.pipeline.process` on all the
readings added so far (same grid, identical count map, same counts, fit and metrics).

The count map lives on a *working grid* a margin larger than the arcs need, aligned to
multiples of the cell size like every :class:`~sonarproc.grid.Grid`; when new arcs leave
it, it is re-grown (the old counts are copied across by whole-cell offsets) with a fresh
margin. A snapshot crops it to the grid a batch run would use,
``Grid.covering(arc bounds of all readings)`` (or the ``bbox``), so the snapshot's map is
the batch map cell for cell. Arc bounds are a min/max over arcs, so the union of the
batches' bounds is the batch bounds exactly.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.arcs import arcs_of
from sonarproc.errors import NothingToMapError
from sonarproc.grid import Grid
from sonarproc.morphology import apply_chain, parse_chain
from sonarproc.params import RunParams
from sonarproc.pipeline.arcmap import count_map
from sonarproc.pipeline.mapping import MethodMap, evaluate_map
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import make_grid, select_beams, select_readings

__all__ = ["LiveAccumulator"]

log = logging.getLogger(__name__)

#: Extra room (fraction of the arcs' span per side, at least :data:`MIN_MARGIN_CELLS`) the
#: working grid keeps so that a growing log seldom forces a re-grow.
MARGIN_FRACTION = 0.25
MIN_MARGIN_CELLS = 16

Bounds = tuple[float, float, float, float]


def _union(a: Bounds | None, b: Bounds) -> Bounds:
    if a is None:
        return b
    return (min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3]))


def _inside(inner: Bounds, grid: Grid) -> bool:
    """Whether every point of the box maps into the grid."""
    iy, ix = grid.to_index([inner[0], inner[1]], [inner[2], inner[3]])
    return bool(np.all(grid.contains_index(iy, ix)))


class LiveAccumulator:
    """The arc count map of a growing log, updated incrementally.

    Parameters
    ----------
    template : sonarlog.SonarLog
        The log as first read: its sensors, attributes (speed of sound), truth profile and
        path are used; its readings are *not* added (call :meth:`add`).
    params : RunParams
        What a run does; the same record ``sonarproc run`` takes.

    Examples
    --------
    >>> acc = LiveAccumulator(first_read, RunParams(ops="thinning:3"))  # doctest: +SKIP
    >>> acc.add(first_read.readings)  # doctest: +SKIP
    >>> result = acc.snapshot()  # doctest: +SKIP
    """

    def __init__(self, template: SonarLog, params: RunParams) -> None:
        self.params = params
        self._ops = parse_chain(params.ops)  # a bad --ops fails now, not at the first reading
        self._template = replace(template, readings=template.readings[:0], dropped_rows=0)
        self._readings: list[np.ndarray] = []
        self._n = 0
        self._bounds: Bounds | None = None
        self._work: Grid | None = None
        self._counts: npt.NDArray[np.uint32] | None = None
        self._cpu = 0.0
        self._raster_s = 0.0
        self.regrows = 0

    # ---- feeding ------------------------------------------------------------------------

    @property
    def n_readings(self) -> int:
        """Readings added so far (kept or not)."""
        return self._n

    def _kept(self, readings: np.ndarray) -> np.ndarray:
        """The rows a run would map (the pipeline's own selection), possibly none."""
        view = replace(self._template, readings=readings)
        try:
            kept, _ = select_readings(view, drop_crosstalk=self.params.drop_crosstalk)
        except NothingToMapError:
            # Fine mid-log (a batch of flagged readings); a row with a bad tof still fails
            # (InputError) as it does in a batch run.
            return readings[:0]
        return kept

    def add(self, readings: np.ndarray) -> int:
        """Add readings (``READING_DTYPE`` rows, any length) and rasterise their arcs.

        Parameters
        ----------
        readings : numpy.ndarray
            New rows, in log order, not added before.

        Returns
        -------
        int
            How many of them make arcs on the map (kept and inside the beams).

        Raises
        ------
        ValueError
            A kept reading with tof <= 0 or NaN, or one naming an unknown transducer id.
        """
        cpu0 = time.process_time()
        wall0 = time.perf_counter()
        readings = np.asarray(readings)
        if len(readings) == 0:
            return 0
        kept = self._kept(readings)
        self._readings.append(readings)
        self._n += len(readings)
        made = 0
        if len(kept):
            arcs = arcs_of(self._template.transducer_poses(kept), self._template.path_lengths(kept))
            if len(arcs):  # else no reading of this batch makes an arc
                self._bounds = _union(self._bounds, arcs.bounds())
                self._ensure_grid(self._bounds)
                assert self._work is not None and self._counts is not None
                self._counts += count_map(arcs, self._work, self.params)
                made = len(kept)
        self._cpu += time.process_time() - cpu0
        self._raster_s += time.perf_counter() - wall0
        return made

    def _ensure_grid(self, bounds: Bounds) -> None:
        """Make the working grid cover ``bounds`` (or the bbox), re-growing it if needed."""
        p = self.params
        if p.bbox is not None:
            if self._work is None:
                xmin, xmax, ymin, ymax = p.bbox
                self._work = Grid.covering(xmin, xmax, ymin, ymax, cell=p.cell)
                self._counts = np.zeros(self._work.shape, dtype=np.uint32)
            return
        if self._work is not None and _inside(bounds, self._work):
            return
        xmin, xmax, ymin, ymax = bounds
        mx = max(MARGIN_FRACTION * (xmax - xmin), MIN_MARGIN_CELLS * p.cell)
        my = max(MARGIN_FRACTION * (ymax - ymin), MIN_MARGIN_CELLS * p.cell)
        new = Grid.covering(xmin - mx, xmax + mx, ymin - my, ymax + my, cell=p.cell)
        counts = np.zeros(new.shape, dtype=np.uint32)
        if self._work is not None and self._counts is not None:
            oy, ox = self._offset(self._work, new)
            counts[oy : oy + self._work.ny, ox : ox + self._work.nx] = self._counts
            self.regrows += 1
            log.debug("working grid re-grown to %d x %d cells", new.nx, new.ny)
        self._work, self._counts = new, counts

    @staticmethod
    def _offset(inner: Grid, outer: Grid) -> tuple[int, int]:
        """Whole-cell offset ``(rows, columns)`` of ``inner``'s cell (0, 0) in ``outer``."""
        return (
            round((inner.y0 - outer.y0) / outer.cell),
            round((inner.x0 - outer.x0) / outer.cell),
        )

    # ---- results ------------------------------------------------------------------------

    @property
    def readings(self) -> np.ndarray:
        """Every reading added so far, in order."""
        if not self._readings:
            return self._template.readings
        if len(self._readings) > 1:
            self._readings = [np.concatenate(self._readings)]
        return self._readings[0]

    def count_map(self) -> tuple[Grid, npt.NDArray[np.uint32]] | None:
        """The grid a batch run would use and the count map on it (a copy), or None.

        Raises
        ------
        ValueError
            As a batch run: no arc touches the ``bbox``, or the map would be too large.
        """
        if self._bounds is None or self._work is None or self._counts is None:
            return None
        grid = make_grid(self.params, self._bounds, str(self._template.path))
        oy, ox = self._offset(grid, self._work)
        crop = self._counts[oy : oy + grid.ny, ox : ox + grid.nx]
        return grid, np.ascontiguousarray(crop)

    def snapshot(self) -> RunResult | None:
        """Morphology, fit and metrics on the current count map.

        Returns
        -------
        RunResult or None
            What :func:`sonarproc.pipeline.process` returns for all readings added so far
            (``t_cpu_s``: the CPU time of every :meth:`add` plus this snapshot); None while
            no reading has made an arc.

        Raises
        ------
        ValueError
            As a batch run: every reading flagged, no arc touches the bbox, ...
        """
        cpu0 = time.process_time()
        wall0 = time.perf_counter()
        cm = self.count_map()
        if cm is None:
            return None
        grid, counts_map = cm
        p = self.params
        lg = replace(self._template, readings=self.readings)
        # the readings themselves too: surfaces are refitted through their echo points
        beams, counts = select_beams(lg, p)
        t_morph = time.perf_counter()
        processed = apply_chain(counts_map, self._ops)
        t_fit = time.perf_counter()
        result = evaluate_map(
            lg,
            p,
            grid,
            MethodMap(processed, counts_map),
            robot_xy=beams.robot_xy,
            counts=counts,
            cpu_start=cpu0,
            beams=beams,
        )
        result.t_cpu_s += self._cpu
        result.timings_s = {
            "rasterise": self._raster_s,
            "select": t_morph - wall0,
            "morphology": t_fit - t_morph,
            "fit": time.perf_counter() - t_fit,
        }
        return result

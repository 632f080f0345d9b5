"""What the runs of a sweep share, computed once per worker instead of once per run.

A sweep's grid points on one input differ mostly in the operations and the fit, which
come after the arc count map. Two caches remove the repeated work:

- :func:`shared_log`: a log read, or a scenario simulated, once per worker for each
  (input, sigma, seed): the few most recent are kept, and a worker handed several chunks
  of the same data reads or simulates it once;
- :class:`SharedMaps`: on one log, the readings selected, the grid laid and the arcs
  rasterised once for each set of the parameters they depend on (``drop_crosstalk``,
  ``cell``, ``bbox``, ``arc_step``); every grid point then runs only its ``ops`` chain,
  its fit and its metrics, through the same :func:`~sonarproc.pipeline.mapping.evaluate_map`
  as ``sonarproc run``. The rows are those of separate runs: the test suite checks them
  against ``sonarproc run``. The part of the truth-free quality that comes before the
  ``ops`` chain (the held-out fold, the subsamples, the training readings and their
  count map: :func:`sonarproc.quality.held_out`) is kept with each count map too.

A shared run's ``t_cpu_s`` counts its own stages only (not the shared read, selection and
rasterisation), so it is smaller than the same run's alone.
"""

from __future__ import annotations

import json
import time
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams

if TYPE_CHECKING:
    from sonarproc.quality import HeldOut

__all__ = ["CACHED_LOGS", "CACHED_MAPS", "SharedMaps", "clear_shared", "shared_log"]

#: Count maps kept per log: a chunk runs its grid points sorted by map parameters
#: (:func:`SharedMaps.map_key`), so it needs one map at a time; a second one keeps the
#: last map of the previous chunk on the same log.
CACHED_MAPS = 2
#: Logs (read or simulated) a worker keeps. A chunk holds the runs of one log, and the
#: chunks of one log are handed out one after the other, so a worker rarely needs more
#: than the log it is on and the next one; a few more cover uneven hand-outs while a
#: fig12-sized log (10 000 readings, a 1 cm map of a few megabytes) stays cheap to hold.
CACHED_LOGS = 4

#: What one count map shares: the readings, their counts, the grid, the arc count map and
#: the quality's held-out part.
_Shared = tuple[Beams, dict[str, int], Grid, npt.NDArray[np.unsignedinteger[Any]], "HeldOut"]

_LOGS: OrderedDict[str, tuple[SonarLog, SharedMaps]] = OrderedDict()


def _identity(inp: str, data: dict[str, Any]) -> str:
    """The cache key of a log: the input, its data values and, for a file, its size and
    modification time (a log rewritten between two sweeps in one process is read again)."""
    p = Path(inp)
    stamp = None
    if p.is_file():
        st = p.stat()
        stamp = [st.st_size, st.st_mtime_ns]
    return json.dumps([inp, sorted(data.items()), stamp])


def shared_log(
    inp: str, data: dict[str, Any], load: Callable[[str, dict[str, Any]], SonarLog]
) -> tuple[SonarLog, SharedMaps]:
    """The log of ``(inp, data)`` and its :class:`SharedMaps`, loaded once per process.

    Parameters
    ----------
    inp : str
        A log path or a scenario.
    data : dict
        The data keys of the combination (``sigma``, ``seed``).
    load : callable
        ``load(inp, data)`` reads or simulates the log (called on a cache miss).
    """
    key = _identity(inp, data)
    hit = _LOGS.get(key)
    if hit is not None:
        _LOGS.move_to_end(key)
        return hit
    lg = load(inp, data)
    entry = (lg, SharedMaps(lg))
    _LOGS[key] = entry
    while len(_LOGS) > CACHED_LOGS:
        _LOGS.popitem(last=False)
    return entry


def clear_shared() -> None:
    """Forget every cached log: after a sweep that ran in this process, before a
    benchmark's cold run."""
    _LOGS.clear()


class SharedMaps:
    """The count maps of one log, each built once per set of map parameters."""

    def __init__(self, log_: SonarLog) -> None:
        self.log = log_
        self._maps: OrderedDict[tuple[Any, ...], _Shared] = OrderedDict()

    @staticmethod
    def map_key(params: RunParams) -> tuple[Any, ...]:
        """The parameters the selection, the grid and the arc count map depend on."""
        return (params.drop_crosstalk, params.cell, params.bbox, params.arc_step)

    def _count_map(self, params: RunParams) -> _Shared:
        from sonarproc.pipeline.arcmap import count_map
        from sonarproc.pipeline.selection import plan_grid, select_beams
        from sonarproc.quality import held_out

        key = self.map_key(params)
        hit = self._maps.get(key)
        if hit is None:
            beams, counts = select_beams(self.log, params)
            grid = plan_grid(self.log, params, beams)
            cmap = count_map(beams.arcs, grid, params)
            cmap.flags.writeable = False  # shared by every run on it: nobody may change it
            hit = (beams, counts, grid, cmap, held_out(beams, grid, params, cmap))
            self._maps[key] = hit
            while len(self._maps) > CACHED_MAPS:
                self._maps.popitem(last=False)
        else:
            self._maps.move_to_end(key)
        return hit

    def process(self, params: RunParams) -> RunResult:
        """:func:`sonarproc.pipeline.process` of this log, sharing the count map.

        Raises
        ------
        NothingToMapError, InputError, ParameterError
            As :func:`sonarproc.pipeline.process`.
        """
        from sonarproc.morphology import apply_chain, parse_chain
        from sonarproc.pipeline.arcmap import build_arc_map
        from sonarproc.pipeline.mapping import MethodMap, evaluate_map
        from sonarproc.quality import measure_quality

        cpu0 = time.process_time()
        beams, counts, grid, cmap, held = self._count_map(params)
        mmap = MethodMap(apply_chain(cmap, parse_chain(params.ops)), cmap)
        result = evaluate_map(
            self.log, params, grid, mmap, robot_xy=beams.robot_xy, counts=counts,
            cpu_start=cpu0, beams=beams,
        )  # fmt: skip
        # the truth-free quality, as process() measures it (after the paper's CPU time)
        result.quality = measure_quality(
            self.log, params, build_arc_map, beams, grid, mmap, result, held=held
        )
        return result

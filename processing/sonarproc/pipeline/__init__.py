"""The one pipeline: select the readings, lay the grid, build a map, fit and measure.

>>> from sonarproc.pipeline import process, run_file  # the paper's method
>>> from sonarproc.pipeline import map_log, evaluate_map  # the seam every method uses

Modules: ``selection`` (readings, their arcs, the grid), ``arcmap`` (the paper's builder),
``mapping`` (the seam), ``evaluation`` (fit and metrics of a map), ``result`` (the run
record), ``run`` (reading a log and running the paper's method), ``align_ahead`` (its
align stage on the second core while the log is mapped), ``live`` (incremental build for
a growing log) and ``watch`` (following a log a writer is still writing).
"""

from sonarproc.pipeline.arcmap import build_arc_map, count_map
from sonarproc.pipeline.evaluation import Evaluation, fit_and_measure
from sonarproc.pipeline.mapping import STAGES, MapBuilder, MethodMap, evaluate_map, map_log
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.run import METHOD, load_log, process, run_file
from sonarproc.pipeline.selection import Beams, plan_grid, select_beams, select_readings

__all__ = [
    "METHOD",
    "STAGES",
    "Beams",
    "Evaluation",
    "MapBuilder",
    "MethodMap",
    "RunResult",
    "build_arc_map",
    "count_map",
    "evaluate_map",
    "fit_and_measure",
    "load_log",
    "map_log",
    "plan_grid",
    "process",
    "run_file",
    "select_beams",
    "select_readings",
]

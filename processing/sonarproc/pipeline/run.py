"""The paper's method end to end: readings -> arc map -> morphology -> fit -> metrics.

:func:`process` is pure (a log in memory in, a :class:`RunResult` out); :func:`run_file`
adds the one piece of I/O, reading the log, so that ``t_cpu_s`` covers the whole run from
raw TOF as the paper measures it (process CPU time, ``time.process_time``). Both go
through the one seam, :func:`sonarproc.pipeline.mapping.map_log`, with the paper's
builder :func:`sonarproc.pipeline.arcmap.build_arc_map`.

Memory: the maps are unsigned-integer counts (from the rasteriser) and ``bool`` masks;
the processed map's cells are listed once (``np.nonzero`` on its transpose, which yields
them sorted by column and row) and every later step works on those index arrays.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from sonarlog import SonarLog, read_log
from sonarproc.errors import InputError, ParameterError
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.align_ahead import AlignAhead, Aligned, Progress, align_stage
from sonarproc.pipeline.arcmap import build_arc_map
from sonarproc.pipeline.mapping import (
    BuiltMap,
    MappedStage,
    MethodMap,
    OnMapped,
    build_map,
    fit_map,
)
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams

if TYPE_CHECKING:
    from sonarproc.quality.ahead import HeldOutAhead

__all__ = [
    "METHOD",
    "Aligned",
    "align_stage",
    "import_stage_modules",
    "load_log",
    "process",
    "run_file",
]

METHOD = "morphological processing of sonar arc maps (Baskent & Barshan 1999)"


def import_stage_modules(params: RunParams) -> None:
    """Import the modules a run with ``params`` loads as it goes, now.

    Loading modules is the interpreter's start-up, counted in a run's wall time but not
    in its processing's CPU time, so callers import them before the clock starts. The
    surface stage's (``fit = "auto"``) are most of it: scipy's trees, graphs and solvers.
    A process forked after this call (``run``'s figure child) has them too.
    """
    if params.fit == "auto":
        import sonarproc.pipeline.surfacefit
    if params.align:
        import sonarproc.pipeline.alignment  # noqa: F401


def process(
    log_: SonarLog,
    params: RunParams,
    *,
    progress: Progress | None = None,
    cpu_start: float | None = None,
    aligned: Aligned | AlignAhead | None = None,
    quality_of_curves: bool = True,
    on_fitted: Callable[[RunResult], None] | None = None,
    on_mapped: OnMapped | None = None,
) -> RunResult:
    """Run the paper's method on a log in memory.

    With ``params.align`` (the default) the poses are first aligned where the echoes
    show odometry drift (:func:`sonarproc.pipeline.alignment.align_log`;
    ``result.alignment`` says whether and why); ``t_cpu_s`` leaves it out (it measures
    the paper's method), ``timings_s["align"]`` is its wall time.

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The readings, sensors and (optionally) truth profile.
    params : RunParams
        Cell size, extent, operations, fit.
    progress : callable, optional
        Called with each stage name of :data:`sonarproc.pipeline.STAGES` as it starts.
    cpu_start : float, optional
        ``time.process_time()`` when the run began (default: now).
    aligned : Aligned or AlignAhead, optional
        The align stage already run on ``log_`` by the caller (:func:`align_stage`), or
        started by it (:class:`~sonarproc.pipeline.align_ahead.AlignAhead`), used in place
        of running it again (``run``'s default mode may hand the log on to ``--auto``,
        which then needs the same aligned poses). While a child aligns, the log is mapped
        as read and the held-out refit of that map starts (the quality stage's, in a
        child); a log whose poses the stage corrects is then mapped again, and its
        refit started again.
    quality_of_curves : bool, optional
        Measure the quality of a map that is one curve (no surfaces). ``False`` where the
        caller replaces such a result (``run``'s default mode hands it to ``--auto``, which
        measures its own choice), so nothing is measured for nothing.
    on_fitted : callable, optional
        Called with the result as its quality starts to be measured: mapped, fitted and
        measured but for its quality and timings (``run`` draws its figures meanwhile).
        Not called where the result is handed on (``quality_of_curves`` false on a curve).
    on_mapped : callable, optional
        Called with the map as it is built, before its fit
        (:class:`~sonarproc.pipeline.mapping.MappedStage`; ``run`` draws its arc map
        figure meanwhile).

    Returns
    -------
    RunResult
        With its truth-free quality (:mod:`sonarproc.quality`) in ``.quality``.

    Raises
    ------
    NothingToMapError
        Nothing in the log to map (every reading skipped, no arc on the map).
    InputError
        Readings the method cannot use (tof <= 0 without the no-echo flag).
    ParameterError
        Parameters that cannot apply to this log (a map over ``max_cells``).
    """
    cpu0 = time.process_time() if cpu_start is None else cpu_start
    if aligned is None and params.align:
        aligned = AlignAhead.start(log_, progress)
    pending = aligned if isinstance(aligned, AlignAhead) and aligned.forked else None
    if isinstance(aligned, AlignAhead) and pending is None:  # aligned here, first
        ahead, aligned = aligned, aligned.result()
        if ahead.here:
            cpu0 += aligned.cpu_s  # t_cpu_s is the paper's method's: not the alignment's
    if isinstance(aligned, Aligned):
        log_ = aligned.log
    mapped = log_
    heldout: HeldOutAhead | None = None

    def start_heldout(stage: MappedStage) -> None:
        # the held-out residual needs the map, not its fit: a child computes it meanwhile
        nonlocal heldout
        from sonarproc.quality.ahead import HeldOutAhead

        heldout = HeldOutAhead.start(
            build_arc_map, stage.beams, stage.grid, params, stage.mmap.evidence
        )

    def measure(beams: Beams, grid: Grid, mmap: MethodMap, result: RunResult) -> None:
        from sonarproc.quality import measure_quality

        if result.surfaces is None and not quality_of_curves:
            return
        if on_fitted is not None:
            if isinstance(aligned, Aligned):
                result.alignment = aligned.record
            on_fitted(result)
        residual = heldout.residual if heldout is not None else None
        result.quality = measure_quality(
            mapped, params, build_arc_map, beams, grid, mmap, result, residual=residual
        )

    def build(lg: SonarLog) -> BuiltMap:
        return build_map(lg, params, build_arc_map, progress=progress, cpu_start=cpu0)

    def fit_ahead(built: BuiltMap) -> BuiltMap:
        # what fit = "auto" does with the map alone (not with the readings' echo points)
        if params.fit != "auto":
            return built
        import numpy as np

        from sonarproc.pipeline.surfacefit import start_fit

        _, beams, grid, mmap, _ = built.stage
        try:
            ix, iy = np.nonzero(mmap.processed.T)
            ahead = start_fit(mmap.processed, mmap.evidence, grid, beams, cells=(ix, iy))
        except Exception:  # the fit meets it again, where it reports it, if the map is kept
            return built
        return replace(built, fit_start=ahead)

    cpu_mapped = time.process_time()
    try:
        if pending is None:
            built = build(log_)
        else:
            # mapped as read while the log was aligned: that map, or its error (none of
            # its cells, say), is the run's only where the log keeps its poses
            as_read: BuiltMap | None = None
            try:
                as_read = build(log_)
            except Exception:
                if pending.result().log is log_:
                    raise
            else:
                # most logs keep their poses: the map as read is then the run's, and its
                # held-out refit and the first half of its fit start now, while this
                # process would wait for the decision
                start_heldout(as_read.stage)
                as_read = fit_ahead(as_read)
            aligned, pending = pending.result(), None  # the answer asked for above, kept
            if aligned.log is log_ and as_read is not None:
                built = as_read
            else:  # the poses were corrected: mapped again from them
                if heldout is not None:  # the dropped map's refit is not wanted
                    heldout.cancel()
                    heldout = None
                cpu0 += time.process_time() - cpu_mapped  # the dropped map is not the method's
                log_ = mapped = aligned.log
                built = build(log_)
        if on_mapped is not None:
            on_mapped(built.stage)
        if heldout is None:
            start_heldout(built.stage)
        result, _ = fit_map(built, measure=measure)
    finally:  # a failed run, or a result handed on unmeasured: no child is waited for
        if heldout is not None:
            heldout.cancel()
        if pending is not None:
            pending.cancel()
    if isinstance(aligned, Aligned):
        result.alignment = aligned.record
        result.timings_s = {"align": aligned.wall_s, **result.timings_s}
    return result


def load_log(
    path: str | Path,
    *,
    sensors: str | Path | None = None,
    truth: str | Path | None = None,
    robot: str | None = None,
    degrees: bool = False,
    pose_frame: str | None = None,
) -> SonarLog:
    """Read any log this tool reads, in memory.

    A sonarlog (``.h5``); with ``sensors``, a readings CSV; or, through
    :func:`sonarlog.sources.read_source`, a ROS 1 bag, a ROS 2 bag directory or a Player
    log (``sensors``, a YAML, or ``robot``, a shipped preset such as ``pioneer3-dx``, then
    gives the mounts). ``truth``: a truth CSV replacing the log's. ``degrees``: a readings
    CSV's ``theta`` and ``turret`` are in degrees. ``pose_frame``: a bag's poses in
    this fixed frame of its tf tree (``map``), composed down to the robot's base frame.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    ParameterError
        A CSV log without ``sensors``.
    InputError
        A directory that is not a ROS 2 bag.
    sonarlog.SonarLogError
        A log that cannot be read (damaged, or a bag missing what a map needs).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    truth_xy = None
    if truth is not None:
        from sonarlog.csvlog import read_truth_csv

        truth_xy = read_truth_csv(truth)
    is_sonarlog = p.is_file() and p.suffix.lower() in (".h5", ".hdf5")
    if robot is not None and is_sonarlog:
        raise ParameterError("robot", f"gives the mounts of a bag or a CSV log, not of {p}")
    if pose_frame is not None and (is_sonarlog or p.suffix.lower() == ".csv"):
        raise ParameterError("pose_frame", f"names a frame of a bag's tf tree; {p} is not a bag")
    if p.suffix.lower() == ".csv":
        sensors = sensors if sensors is not None else robot
        if sensors is None:
            raise ParameterError("sensors", f"is required for a CSV log ({p})")
        from sonarlog.csvlog import read_csv_log

        return read_csv_log(p, sensors, truth=truth_xy, degrees=degrees)
    if p.is_dir() and not (p / "metadata.yaml").is_file():
        raise InputError(
            f"{p}: is a directory, not a log (a sonarlog .h5, a readings CSV, a ROS 1 bag, "
            "a ROS 2 bag directory or a Player log)"
        )
    if not is_sonarlog:
        from sonarlog.sources import read_source  # rosbags: only for the logs that need it

        lg, _ = read_source(p, sensors=sensors, robot=robot, pose_frame=pose_frame)
    else:
        lg = read_log(p)
    return lg if truth_xy is None else replace(lg, truth=truth_xy)


def run_file(
    path: str | Path,
    params: RunParams,
    *,
    sensors: str | Path | None = None,
    truth: str | Path | None = None,
    robot: str | None = None,
    progress: Progress | None = None,
    degrees: bool = False,
    pose_frame: str | None = None,
) -> RunResult:
    """Read a log (:func:`load_log`) and :func:`process` it; ``t_cpu_s`` includes reading.

    The stages' modules (:func:`import_stage_modules`) are loaded before the clock starts.
    """
    import_stage_modules(params)
    cpu0 = time.process_time()
    wall0 = time.perf_counter()
    if progress is not None:
        progress("read")
    lg = load_log(
        path, sensors=sensors, truth=truth, robot=robot, degrees=degrees, pose_frame=pose_frame
    )
    read_s = time.perf_counter() - wall0
    result = process(lg, params, progress=progress, cpu_start=cpu0)
    result.timings_s = {"read": read_s, **result.timings_s}
    return result

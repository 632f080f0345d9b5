"""The one seam every map goes through: select, grid, build, then fit and measure.

A *builder* turns the selected readings (:class:`~sonarproc.pipeline.selection.Beams`)
into a :class:`MethodMap` on a grid: the paper's arcs and morphology
(:func:`sonarproc.pipeline.arcmap.build_arc_map`), or any method of
:mod:`sonarproc.methods`. :func:`map_log` runs one builder on a log (:func:`build_map`
then :func:`fit_map`, for a caller that decides between the two);
:func:`evaluate_map` fits and measures a map, and is also what the live accumulator
(:mod:`sonarproc.pipeline.live`) calls on its incrementally built count map. So every
map is judged the same way: same selection, same grid, same fit, same metrics.

``t_cpu_s`` is the process CPU time from ``cpu_start`` (default: when :func:`map_log`
began) to the metrics.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.fit import FitFailure
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.evaluation import SeenAhead, fit_and_measure, map_counts, no_arc_message
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams, plan_grid, select_beams

if TYPE_CHECKING:  # scipy's modules load with the fit, not with the map
    from sonarproc.pipeline.surfacefit import FitStart

__all__ = [
    "STAGES",
    "BuiltMap",
    "MapBuilder",
    "MappedStage",
    "Measure",
    "MethodMap",
    "OnMapped",
    "build_map",
    "evaluate_map",
    "fit_map",
    "map_log",
]

#: Stage names reported to a progress callback, in order.
STAGES = ("read", "align", "select", "grid", "rasterise", "morphology", "fit", "metrics", "quality")

Stage = Callable[[str], None]


@dataclass
class MethodMap:
    """What a builder makes on the grid.

    Attributes
    ----------
    processed : ndarray of bool, grid.shape
        The cells the surface is fitted to (the "processed map").
    evidence : ndarray of unsigned int, grid.shape
        Per-cell evidence (arc counts, hits, occupied-band counts): the figures show it, a
        robust fit weighs by it, and its nonzero columns are the f_c denominator when
        there is no truth profile.
    probability : ndarray of float, grid.shape, optional
        p(occupied) of a probabilistic method (0.5 = unknown); the ROS map uses it.
    """

    processed: npt.NDArray[np.bool_]
    evidence: npt.NDArray[np.unsignedinteger[Any]]
    probability: npt.NDArray[np.float64] | None = None


#: A method's map builder: ``build(beams, grid, params, stage) -> MethodMap``; it may
#: report its own stages (``"rasterise"``, ``"morphology"``) through ``stage``.
MapBuilder = Callable[[Beams, Grid, RunParams, "Stage | None"], MethodMap]
#: A measure of a finished map: ``measure(beams, grid, mmap, result)`` adds to ``result``.
Measure = Callable[[Beams, Grid, MethodMap, RunResult], None]


class MappedStage(NamedTuple):
    """A map as it is built, before its fit (what :data:`OnMapped` is told)."""

    source: str
    beams: Beams
    grid: Grid
    mmap: MethodMap
    counts: dict[str, int]


#: Told of a map as it is built, before its fit: ``on_mapped(stage)``.
OnMapped = Callable[[MappedStage], None]


def evaluate_map(
    log_: SonarLog,
    params: RunParams,
    grid: Grid,
    mmap: MethodMap,
    *,
    robot_xy: npt.NDArray[np.float64],
    counts: dict[str, int],
    cpu_start: float,
    stage: Stage | None = None,
    timings: dict[str, float] | None = None,
    empty_message: str | None = None,
    beams: Beams | None = None,
    fit_start: FitStart | None = None,
) -> RunResult:
    """Fit and measure a map; the record of the run.

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The log (its path names the source; its truth profile, if any, gives E1, E2).
    params : RunParams
        The fit and metric options.
    grid : Grid
        The grid of ``mmap``.
    mmap : MethodMap
        The processed map and its evidence.
    robot_xy : ndarray, (N, 2)
        Robot positions of the mapped readings (a polar fit's default centre; figures).
    counts : dict
        Reading counts from the selection; the map's counts are added.
    cpu_start : float
        ``time.process_time()`` at the start of the run.
    stage : callable, optional
        Told ``"fit"`` and ``"metrics"``.
    timings : dict, optional
        Wall times of earlier stages, kept in the record.
    empty_message : str, optional
        The error when the map is empty (default: no arc touches the map or bbox).
    beams : Beams, optional
        The mapped readings: ``fit = "auto"`` refits surfaces through their echo points.
    fit_start : sonarproc.pipeline.surfacefit.FitStart, optional
        The first half of ``fit = "auto"``'s choice on this map and these readings,
        computed already (:attr:`BuiltMap.fit_start`).

    Raises
    ------
    NothingToMapError
        The map has no cell set.
    """
    source = str(log_.path)
    empty = empty_message or no_arc_message(source, params.bbox)
    counts = {**counts, **map_counts(mmap.evidence, empty=empty)}
    if stage is not None:
        stage("fit")
    truth = None if log_.truth is None else np.asarray(log_.truth, dtype=np.float64)
    auto = None
    fit_params = params
    # the kept cells column by column, for the fit and auto's test of one function of x
    ix, iy = np.nonzero(mmap.processed.T)
    cells = (ix, iy)
    seen, seen_cpu = None, 0.0
    if params.fit == "auto":
        from sonarproc.pipeline.surfacefit import choose_fit, one_curve_at_a_glance

        # surfaces are measured against what the sonars saw of the truth: found meanwhile
        # (not for a map that is one curve y = f(x) at a glance, which has no use for it)
        ahead = None
        glance = truth is None or one_curve_at_a_glance(mmap.processed, grid.cell, cells=cells)
        if truth is not None and beams is not None and not glance:
            ahead = SeenAhead(truth, beams)
        try:
            auto = choose_fit(
                mmap.processed, mmap.evidence, grid, beams, cells=cells, start=fit_start
            )
        finally:  # no thread outlives the fit, even a failed one
            if ahead is not None:
                ahead.join()
        fit_params = replace(params, fit="poly")
        if ahead is not None:
            seen, seen_cpu = ahead.result(), ahead.cpu_s
    # The paper's E1 and E2 compare one curve y = f(x) with one true curve y = f(x).
    # (A polar fit compares r(phi) about a centre instead: any closed truth will do.)
    single = truth is None or params.fit == "polar" or not np.isnan(truth).any()
    profile_truth = truth if single else None
    found = None if auto is None else auto.surfaces
    unfitted = None
    if found is not None:
        n = len(found.surfaces)
        why = f"{n} surface(s) fitted one by one: see surfaces.csv"
        unfitted = FitFailure("surfaces", why if n else str(found.reason))
    ev = fit_and_measure(
        fit_params, grid, mmap.processed, mmap.evidence, truth=profile_truth,
        robot_xy=robot_xy, stage=stage, cells=cells,
        # the surfaces are the fit; a profile's only use would be E1 and E2 on the truth
        unfitted=unfitted if profile_truth is None else None,
    )  # fmt: skip
    if unfitted is not None:
        ev.fit = unfitted
    t_cpu = time.process_time() - cpu_start - seen_cpu  # the method's, not the measure's
    result = RunResult.of(
        ev,
        source=source,
        params=params,
        grid=grid,
        counts_map=mmap.evidence,
        processed=mmap.processed,
        truth=truth,
        counts=counts,
        t_cpu_s=t_cpu,
        timings_s=timings,
    )
    # A crashed or cut log is processed, but never silently (its state is in the report).
    if auto is not None:
        result.auto = auto.to_json()
        result.surfaces = auto.surfaces
    found = result.surfaces
    if found is not None and found.surfaces and truth is not None and beams is not None:
        # precision and completeness against a truth of several surfaces (every caller:
        # a plain run, a comparison's method, --auto's winner)
        from sonarproc.pipeline.surfacefit import measure_surfaces

        tp = beams.poses
        result.surface_metrics = measure_surfaces(
            found, truth, (tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading,
            beams.path), tx_half_beamwidth=tp.tx_half_beamwidth,
            rx_half_beamwidth=tp.rx_half_beamwidth, seen=seen,
        )  # fmt: skip
    result.log_state = log_.log_state
    result.log_warning = log_.integrity_warning()
    return result


def map_log(
    log_: SonarLog,
    params: RunParams,
    build: MapBuilder,
    *,
    progress: Stage | None = None,
    cpu_start: float | None = None,
    empty_message: str | None = None,
    measure: Measure | None = None,
    on_mapped: OnMapped | None = None,
) -> tuple[RunResult, MethodMap]:
    """Select the readings, lay the grid, build the map with ``build``, fit and measure.

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The log in memory.
    params : RunParams
        The run's parameters.
    build : MapBuilder
        The method's map builder.
    progress : callable, optional
        Called with each stage name of :data:`STAGES` as it starts.
    cpu_start : float, optional
        ``time.process_time()`` when the run began (default: now).
    empty_message : str, optional
        The error when the built map is empty (default: no arc touches the map or bbox).
    measure : callable, optional
        Called last as ``measure(beams, grid, mmap, result)`` to add a measure of the
        map to the record (``sonarproc run``: its truth-free quality,
        :mod:`sonarproc.quality`); its time is ``timings_s["quality"]``, outside
        ``t_cpu_s``.
    on_mapped : callable, optional
        Called with the :class:`MappedStage` as soon as the map is built, before its
        fit: work that needs the map but not its fit starts there (``run``'s held-out
        residual and arc map figure, in children while the fit runs here).

    Returns
    -------
    result : RunResult
    mmap : MethodMap
        The builder's map (with its probability layer, if any).
    """
    built = build_map(log_, params, build, progress=progress, cpu_start=cpu_start)
    if on_mapped is not None:
        on_mapped(built.stage)
    return fit_map(built, empty_message=empty_message, measure=measure)


class _StageClock:
    """Wall time per stage, each stage's from its start to the next's; a progress callback
    is told of each stage of :data:`STAGES` as it starts."""

    def __init__(self, progress: Stage | None) -> None:
        self.timings: dict[str, float] = {}
        self.progress = progress
        self.clock = time.perf_counter()

    def __call__(self, name: str) -> None:
        now = time.perf_counter()
        if self.timings:
            self.timings[next(reversed(self.timings))] += now - self.clock
        self.timings[name] = 0.0
        self.clock = now
        if self.progress is not None and name in STAGES:
            self.progress(name)


@dataclass(frozen=True, eq=False)
class BuiltMap:
    """A log's map as built, before its fit (:func:`build_map`; :func:`fit_map` goes on).

    Attributes
    ----------
    log : sonarlog.SonarLog
        The log mapped.
    params : RunParams
        The run's parameters.
    stage : MappedStage
        The selected readings, the grid, the builder's map and the reading counts.
    cpu_start : float
        ``time.process_time()`` when the run began.
    clock : callable
        The stages' clock, still running (the wait before the fit counts in the last
        build stage, as in :func:`map_log`).
    fit_start : sonarproc.pipeline.surfacefit.FitStart or None
        The first half of ``fit = "auto"``'s choice on this map, computed ahead
        (:func:`~sonarproc.pipeline.surfacefit.start_fit`); None: the fit does it.
    """

    log: SonarLog
    params: RunParams
    stage: MappedStage
    cpu_start: float
    clock: _StageClock
    fit_start: FitStart | None = None


def build_map(
    log_: SonarLog,
    params: RunParams,
    build: MapBuilder,
    *,
    progress: Stage | None = None,
    cpu_start: float | None = None,
) -> BuiltMap:
    """The first half of :func:`map_log`: select the readings, lay the grid, build the map.

    A caller that must decide, once the map is built, whether to fit it (``run``: whether
    the log's poses were corrected meanwhile) goes on with :func:`fit_map`.
    """
    cpu0 = time.process_time() if cpu_start is None else cpu_start
    clock = _StageClock(progress)
    clock("select")
    beams, counts = select_beams(log_, params)
    clock("grid")
    grid = plan_grid(log_, params, beams)
    mmap = build(beams, grid, params, clock)
    return BuiltMap(
        log_, params, MappedStage(str(log_.path), beams, grid, mmap, counts), cpu0, clock
    )


def fit_map(
    built: BuiltMap, *, empty_message: str | None = None, measure: Measure | None = None
) -> tuple[RunResult, MethodMap]:
    """The second half of :func:`map_log`: fit and measure a built map (its parameters)."""
    _, beams, grid, mmap, counts = built.stage
    stage = built.clock
    result = evaluate_map(
        built.log, built.params, grid, mmap, robot_xy=beams.robot_xy, counts=counts,
        cpu_start=built.cpu_start, stage=stage, timings=stage.timings,
        empty_message=empty_message, beams=beams, fit_start=built.fit_start,
    )  # fmt: skip
    if measure is not None:
        stage("quality")
        measure(beams, grid, mmap, result)
    stage("done")
    timings = stage.timings
    timings.pop("done")
    result.timings_s = timings
    return result, mmap

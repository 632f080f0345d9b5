"""The paper's method end to end: readings -> arc map -> morphology -> fit -> metrics.

:func:`process` is pure (a log in memory in, a :class:`RunResult` out); :func:`run_file`
adds the one piece of I/O, reading the log, so that ``t_cpu_s`` covers the whole run from
raw TOF as the paper measures it (process CPU time, ``time.process_time``).

Memory: the maps are unsigned-integer counts (from the rasteriser) and ``bool`` masks;
the processed map's cells are listed once (``np.nonzero`` on its transpose, which yields
them sorted by column and row) and every later step works on those index arrays.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import FLAG_CROSSTALK, FLAG_NO_ECHO, SonarLog, read_log
from sonarproc.arcs import arc_bounds, rasterize_arcs
from sonarproc.evaluation import (
    Evaluation,
    fit_and_measure,
    make_grid,
    map_counts,
    no_arc_message,
)
from sonarproc.fit import Fit, FitFailure
from sonarproc.grid import Grid
from sonarproc.metrics import Bins, Metrics
from sonarproc.params import RunParams
from sonarproc.voting import apply_chain, parse_chain

__all__ = ["METHOD", "STAGES", "RunResult", "load_log", "process", "run_file", "select_readings"]

log = logging.getLogger(__name__)

METHOD = "morphological processing of sonar arc maps (Baskent & Barshan 1999)"
#: Stage names reported to a progress callback, in order.
STAGES = ("read", "select", "grid", "rasterise", "morphology", "fit", "metrics")

Progress = Callable[[str], None]


@dataclass
class RunResult:
    """Everything a run produced; the report writers turn it into files."""

    source: str
    params: RunParams
    grid: Grid
    counts_map: npt.NDArray[np.unsignedinteger[Any]]
    processed: npt.NDArray[np.bool_]
    points_x: npt.NDArray[np.float64]
    points_y: npt.NDArray[np.float64]
    bins: Bins
    fit: Fit
    metrics: Metrics
    truth: npt.NDArray[np.float64] | None
    counts: dict[str, int]
    t_cpu_s: float = 0.0
    timings_s: dict[str, float] = field(default_factory=dict)
    centre: tuple[float, float] | None = None
    robot_xy: npt.NDArray[np.float64] | None = None

    @classmethod
    def of(
        cls,
        ev: Evaluation,
        *,
        source: str,
        params: RunParams,
        grid: Grid,
        counts_map: npt.NDArray[np.unsignedinteger[Any]],
        processed: npt.NDArray[np.bool_],
        truth: npt.NDArray[np.float64] | None,
        counts: dict[str, int],
        t_cpu_s: float,
        timings_s: dict[str, float] | None = None,
    ) -> RunResult:
        """The record of a run whose processed map ``ev`` evaluated (counts its points)."""
        if isinstance(ev.fit, FitFailure):
            log.info("%s: fit failed: %s", source, ev.fit.reason)
        return cls(
            source=source,
            params=params,
            grid=grid,
            counts_map=counts_map,
            processed=processed,
            points_x=ev.points_x,
            points_y=ev.points_y,
            bins=ev.bins,
            fit=ev.fit,
            metrics=ev.metrics,
            truth=truth,
            counts={**counts, "processed_cells": int(ev.points_x.size)},
            t_cpu_s=t_cpu_s,
            timings_s=timings_s or {},
            centre=ev.centre,
            robot_xy=ev.robot_xy,
        )


def select_readings(log_: SonarLog, *, drop_crosstalk: bool) -> tuple[np.ndarray, dict[str, int]]:
    """Keep the readings to map; count the skipped ones; refuse unusable input.

    Readings flagged out of range / no echo (bit 0) are skipped and counted, as are those
    whose range (half the path) lies outside the receiver's ``[min_range, max_range]``.

    Raises
    ------
    ValueError
        No readings; every reading skipped; a kept reading with tof <= 0 or NaN.
    sonarlog.InvalidLogError
        A reading names a transducer id with no ``/sensors`` row.
    """
    r = log_.readings
    name = str(log_.path)
    total = len(r)
    if total == 0:
        raise ValueError(f"{name}: the log holds no readings")
    log_.sensor_rows(r["tx"])  # raises on an unknown transducer id
    rows = log_.sensor_rows(r["rx"])
    flagged = (r["flags"] & FLAG_NO_ECHO) != 0
    crosstalk = (r["flags"] & FLAG_CROSSTALK) != 0
    keep = ~flagged
    if drop_crosstalk:
        keep &= ~crosstalk
    tof = r["tof"]
    bad = keep & ~(np.isfinite(tof) & (tof > 0))
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        raise ValueError(
            f"{name}: {int(bad.sum())} reading(s) have tof <= 0 or NaN without the "
            f"out-of-range flag (first at row {first}, tof={float(tof[first])!r})"
        )
    rng = np.zeros(total)
    rng[keep] = 0.5 * log_.path_lengths(r[keep])
    lo, hi = log_.sensors["min_range"][rows], log_.sensors["max_range"][rows]
    outside = keep & ((rng < lo) | (rng > hi))
    keep &= ~outside
    counts = {
        "readings_total": total,
        "readings_used": int(keep.sum()),
        "skipped_out_of_range": int(flagged.sum() + outside.sum()),
        "flagged_no_echo": int(flagged.sum()),
        "beyond_sensor_range": int(outside.sum()),
        "flagged_crosstalk": int(crosstalk.sum()),
        "skipped_crosstalk": int((crosstalk & ~flagged).sum()) if drop_crosstalk else 0,
        "dropped_torn_rows": int(log_.dropped_rows),
    }
    if counts["readings_used"] == 0:
        raise ValueError(
            f"{name}: all {total} readings are flagged or out of range; nothing to map"
        )
    return r[keep], counts


def process(
    log_: SonarLog,
    params: RunParams,
    *,
    progress: Progress | None = None,
    cpu_start: float | None = None,
) -> RunResult:
    """Run the method on a log in memory.

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The readings, sensors and (optionally) truth profile.
    params : RunParams
        Cell size, extent, operations, fit.
    progress : callable, optional
        Called with each stage name of :data:`STAGES` as it starts.
    cpu_start : float, optional
        ``time.process_time()`` when the run began (default: now).

    Returns
    -------
    RunResult
    """
    cpu0 = time.process_time() if cpu_start is None else cpu_start
    timings: dict[str, float] = {}
    source = str(log_.path)
    clock = time.perf_counter()

    def stage(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        if timings:
            timings[next(reversed(timings))] += now - clock
        timings[name] = 0.0
        clock = now
        if progress is not None and name in STAGES:
            progress(name)

    stage("select")
    ops = parse_chain(params.ops)
    readings, counts = select_readings(log_, drop_crosstalk=params.drop_crosstalk)
    tp = log_.transducer_poses(readings)
    path = log_.path_lengths(readings)
    stage("grid")
    arcs_args = (tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, path)
    beams = {"tx_half_beamwidth": tp.tx_half_beamwidth, "rx_half_beamwidth": tp.rx_half_beamwidth}
    try:
        bounds = arc_bounds(*arcs_args, **beams)
    except ValueError as err:
        raise ValueError(f"{source}: {err}") from err
    grid = make_grid(params, bounds, source)
    stage("rasterise")
    if params.arc_step is None:
        counts_map = rasterize_arcs(*arcs_args, **beams, grid=grid)
    else:  # paper-style: samples at a fixed angular step (optional, not the default)
        from sonarproc.arcs_sampled import rasterize_arcs_sampled

        counts_map = rasterize_arcs_sampled(
            *arcs_args, **beams, step_rad=params.arc_step, grid=grid
        )
    counts.update(map_counts(counts_map, empty=no_arc_message(source, params.bbox)))
    stage("morphology")
    processed = apply_chain(counts_map, ops)
    stage("fit")
    truth = None if log_.truth is None else np.asarray(log_.truth, dtype=np.float64)
    ev = fit_and_measure(
        params,
        grid,
        processed,
        counts_map,
        truth=truth,
        robot_xy=np.column_stack((readings["x"], readings["y"])).astype(np.float64),
        stage=stage,
    )
    t_cpu = time.process_time() - cpu0
    stage("done")
    timings.pop("done")
    return RunResult.of(
        ev,
        source=source,
        params=params,
        grid=grid,
        counts_map=counts_map,
        processed=processed,
        truth=truth,
        counts=counts,
        t_cpu_s=t_cpu,
        timings_s=timings,
    )


def load_log(
    path: str | Path, *, sensors: str | Path | None = None, truth: str | Path | None = None
) -> SonarLog:
    """Read a sonarlog (``.h5``) or, with ``sensors``, a readings CSV; optional truth CSV."""
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file", str(p))
    truth_xy = None
    if truth is not None:
        from sonarproc.csvlog import read_truth_csv

        truth_xy = read_truth_csv(truth)
    if sensors is not None or p.suffix.lower() == ".csv":
        if sensors is None:
            raise ValueError(f"{p}: a CSV log needs --sensors SENSORS.yaml")
        from sonarproc.csvlog import read_csv_log

        return read_csv_log(p, sensors, truth=truth_xy)
    lg = read_log(p)
    return lg if truth_xy is None else replace(lg, truth=truth_xy)


def run_file(
    path: str | Path,
    params: RunParams,
    *,
    sensors: str | Path | None = None,
    truth: str | Path | None = None,
    progress: Progress | None = None,
) -> RunResult:
    """Read a log and :func:`process` it; ``t_cpu_s`` includes reading the file."""
    cpu0 = time.process_time()
    wall0 = time.perf_counter()
    if progress is not None:
        progress("read")
    lg = load_log(path, sensors=sensors, truth=truth)
    read_s = time.perf_counter() - wall0
    result = process(lg, params, progress=progress, cpu_start=cpu0)
    result.timings_s = {"read": read_s, **result.timings_s}
    return result

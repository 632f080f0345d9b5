"""The whole multi-surface chain, as the pipeline is to run it (shared by tests/benchmarks).

simulate -> select readings -> arcs (count map) -> ``vote:2`` -> ridge across the wall
(:func:`sonarproc.surfaces.ridge_nms`) -> :func:`sonarproc.surfaces.find_surfaces` ->
refit through the readings' echo points (:func:`sonarproc.surfaces.refine_fits`) ->
truth the sonars saw (:func:`sonarproc.surfaces.seen_truth`) -> precision / completeness.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonarlog import SonarLog, read_log
from sonarproc.arcs import arc_geometry, rasterize
from sonarproc.grid import Grid
from sonarproc.morphology import apply_chain
from sonarproc.params import RunParams
from sonarproc.pipeline import select_readings
from sonarproc.pipeline.selection import make_grid
from sonarproc.simulate import simulate_to_log
from sonarproc.surfaces import (
    EchoGeometry,
    SurfaceMetrics,
    SurfaceParams,
    SurfaceSet,
    find_surfaces,
    refine_fits,
    ridge_nms,
    seen_truth,
    surface_metrics,
    truth_points,
)

#: The chain before the surfaces: the count ops the pipeline runs first.
OPS = "vote:2"


@dataclass
class ChainResult:
    """What one run of the chain produced."""

    grid: Grid
    counts: np.ndarray
    processed: np.ndarray
    found: SurfaceSet
    metrics: SurfaceMetrics | None
    timings_s: dict[str, float] = field(default_factory=dict)


def simulate(scenario: str, tmp: Path) -> SonarLog:
    """Simulate a shipped scenario into ``tmp`` and read it back."""
    out = tmp / f"{scenario}.h5"
    simulate_to_log(scenario, out)
    return read_log(out)


def run_chain(
    log: SonarLog,
    *,
    cell: float = 0.01,
    ops: str = OPS,
    params: SurfaceParams | None = None,
    measure: bool = True,
) -> ChainResult:
    """Run the chain on a log; the metrics need the log's truth."""
    t: dict[str, float] = {}
    t0 = time.perf_counter()
    readings, _ = select_readings(log, drop_crosstalk=False)
    tp = log.transducer_poses(readings)
    path = log.path_lengths(readings)
    args = (tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, path)
    beams = {"tx_half_beamwidth": tp.tx_half_beamwidth, "rx_half_beamwidth": tp.rx_half_beamwidth}
    arcs = arc_geometry(*args, **beams)
    grid = make_grid(RunParams(cell=cell), arcs.bounds(), str(log.path))
    counts = rasterize(arcs, grid)
    kept = apply_chain(counts, ops)
    t["arcs+morphology"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    processed = ridge_nms(kept, counts)
    t["ridge"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    found = find_surfaces(processed, grid, counts, params=params)
    if found.surfaces:
        fits, cells = refine_fits(
            found.surfaces, found.cells, EchoGeometry.from_beams(*args, **beams), cell=cell
        )
        found = SurfaceSet(fits, found.failures, found.cells_kept, found.cells_assigned,
                           None if fits else "no echoes", cells)  # fmt: skip
    t["surfaces"] = time.perf_counter() - t2
    metrics = None
    if measure and log.truth is not None:
        t3 = time.perf_counter()
        pts = np.concatenate(truth_points(log.truth))
        seen = seen_truth(pts, *args, **beams)
        metrics = surface_metrics(found.polylines(), log.truth, seen=seen)
        t["metrics"] = time.perf_counter() - t3
    return ChainResult(grid, counts, processed, found, metrics, t)


def summary(res: ChainResult) -> dict[str, Any]:
    """A short description for messages."""
    return {
        "surfaces": [
            (s.model, round(s.length_m, 2), round(s.rms_m, 4)) for s in res.found.surfaces
        ],
        "metrics": None if res.metrics is None else res.metrics.to_json(),
        "timings_s": {k: round(v, 3) for k, v in res.timings_s.items()},
    }

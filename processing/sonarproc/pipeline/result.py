"""The record of one run: maps, points, fit, metrics, counts and timings."""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.fit import Fit, FitFailure
from sonarproc.grid import Grid
from sonarproc.metrics import Bins, Metrics
from sonarproc.params import RunParams
from sonarproc.pipeline.evaluation import Evaluation

if TYPE_CHECKING:
    from sonarproc.surfaces import SurfaceSet

__all__ = ["RunResult"]

log = logging.getLogger(__name__)


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
    log_state: str = "closed"
    log_warning: str | None = None
    surfaces: SurfaceSet | None = None
    auto: dict[str, Any] | None = None
    surface_metrics: dict[str, Any] | None = None

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

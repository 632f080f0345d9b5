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
    from sonarproc.pipeline.alignment import AlignmentRecord
    from sonarproc.quality import Quality
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
    quality: Quality | None = None
    alignment: AlignmentRecord | None = None

    @property
    def surfaces_fit(self) -> bool:
        """Whether the run fitted several surfaces (``fit = "auto"`` chose surfaces)."""
        return self.surfaces is not None

    def fit_json(self) -> dict[str, Any]:
        """``report.json``'s ``fit`` (Contract 2).

        A surfaces fit is a successful fit: ``{"kind": "surfaces", "ok": true,
        "surfaces": N, ...}`` (see
        :func:`sonarproc.pipeline.surfacefit.surfaces_fit_record`); a profile fit is its
        own record, with the centre of a polar fit.
        """
        if self.surfaces is not None:
            from sonarproc.pipeline.surfacefit import surfaces_fit_record

            return surfaces_fit_record(self.surfaces)
        fit = dict(self.fit.to_json())
        if self.centre is not None:
            fit.setdefault("centre", list(self.centre))
        return fit

    def surfaces_json(self) -> list[dict[str, Any]] | None:
        """``report.json``'s ``surfaces``: one entry per surface (id, ``kind``, ``model``,
        ``length_m``, ``rms_m``, ``support``...), the failed ones last; None for a profile fit.
        """
        if self.surfaces is None:
            return None
        from sonarproc.pipeline.surfacefit import surface_kind

        entries = self.surfaces.to_json()
        for e in entries:
            if e.get("ok"):
                e.setdefault("kind", surface_kind(e.get("model")))
        return entries

    def metrics_json(self) -> dict[str, Any]:
        """``report.json``'s ``metrics``.

        Always ``e``, ``f_c``, ``t_cpu_s``, ``N``, ``N_k``. ``E1_m``, ``E2``, ``sigma_y_m``
        where they are defined: a profile fit on a log whose truth is one curve (or any
        closed truth, for a polar fit). ``precision_m``, ``completeness`` (and the counts
        behind them) beside them when surfaces were fitted on a log with a truth.
        """
        m = self.metrics.to_json()
        out: dict[str, Any] = {
            "e": m["e"],
            "f_c": m["f_c"],
            "t_cpu_s": self.t_cpu_s,
            "N": m["N"],
            "N_k": m["N_k"],
        }
        polar = self.params.fit == "polar"
        truth = self.truth
        if truth is not None and self.surfaces is None and (polar or not np.isnan(truth).any()):
            out.update(E1_m=m["E1_m"], E2=m["E2"], sigma_y_m=m["sigma_y_m"])
        if self.surface_metrics is not None:
            out.update(self.surface_metrics)
        return out

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

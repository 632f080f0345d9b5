"""From a processed map to a fitted profile and the paper's error measures.

Every map-building method ends the same way, so this is the one place that does it:
:func:`make_grid` lays out the grid ``sonarproc run`` uses, and :func:`fit_and_measure`
takes the cells a method kept to a fit (:mod:`sonarproc.fit`) and to e, f_c, E1, E2
(:mod:`sonarproc.metrics`): the paper's method (:func:`sonarproc.pipeline.process`), the
live accumulator (:mod:`sonarproc.pipeline.live`) and the other methods (:mod:`sonarproc.methods`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.errors import NothingToMapError
from sonarproc.fit import (
    Fit,
    FitFailure,
    PolyFit,
    fit_polar,
    fit_polynomial,
    fit_polynomial_robust,
    fit_spline,
    select_order_cv,
)
from sonarproc.grid import Grid
from sonarproc.metrics import (
    Bins,
    Metrics,
    bin_stats,
    polar_bins,
    profile_metrics,
    truth_on_columns,
    truth_on_polar_bins,
)
from sonarproc.params import MAX_AUTO_ORDER, RunParams

if TYPE_CHECKING:
    from sonarproc.pipeline.selection import Beams

__all__ = [
    "Evaluation",
    "SeenAhead",
    "fit_and_measure",
    "map_counts",
    "measure_profile",
    "no_arc_message",
]

Stage = Callable[[str], None]


@dataclass
class Evaluation:
    """The fit of a processed map and its metrics.

    Attributes
    ----------
    points_x, points_y : ndarray
        World coordinates of the processed map's cells, sorted by column then row.
    bins : Bins
        Per-column (or, for a polar fit, per-sector) statistics of those points.
    fit : Fit
        The fitted profile, or a :class:`~sonarproc.fit.FitFailure` saying why not.
    metrics : Metrics
        e, f_c and, with a truth profile, E1 and E2.
    centre : tuple of float or None
        The centre of a polar fit.
    robot_xy : ndarray
        Robot positions of the readings, for the figures.
    """

    points_x: npt.NDArray[np.float64]
    points_y: npt.NDArray[np.float64]
    bins: Bins
    fit: Fit
    metrics: Metrics
    centre: tuple[float, float] | None
    robot_xy: npt.NDArray[np.float64]


class SeenAhead:
    """Which truth points the readings could have produced, found on a second thread.

    What the sonars saw (:func:`sonarproc.surfaces.seen_truth`) depends on the truth and
    the readings only, not on any fit: it is found while the surfaces are fitted, on the
    core the fit leaves idle, and the surfaces' precision and completeness are then
    measured against it (:func:`sonarproc.pipeline.surfacefit.measure_surfaces`). The
    answer is the one found after the fit. Its work is array operations and k-d tree
    searches, which release the GIL.
    """

    def __init__(self, truth: npt.NDArray[np.float64], beams: Beams) -> None:
        self._seen: npt.NDArray[np.bool_] | None = None
        self._error: BaseException | None = None
        #: CPU seconds the thread took (a run's ``t_cpu_s`` leaves the measure out)
        self.cpu_s = 0.0
        self._thread = threading.Thread(
            target=self._run, args=(truth, beams), name="seen-truth", daemon=True
        )
        self._thread.start()

    def _run(self, truth: npt.NDArray[np.float64], beams: Beams) -> None:
        from sonarproc.pipeline.surfacefit import seen_of_truth

        cpu0 = time.thread_time()
        try:
            self._seen = seen_of_truth(truth, beams)
        except BaseException as err:  # handed to the caller, on its own thread
            self._error = err
        self.cpu_s = time.thread_time() - cpu0

    def join(self) -> None:
        """Wait for the thread to end."""
        self._thread.join()

    def result(self) -> npt.NDArray[np.bool_]:
        """The seen truth points (waits for the thread; raises what it raised)."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        assert self._seen is not None
        return self._seen


def _fit_binned(params: RunParams, bins: Bins) -> Fit:
    mean = np.nan_to_num(bins.mean)
    if params.fit == "spline":
        return fit_spline(bins.centres, mean, bins.count, lam=params.smooth)
    return fit_polynomial(bins.centres, mean, bins.count, order=params.fit_order)


def _fit_points(
    params: RunParams,
    px: npt.NDArray[np.float64],
    py: npt.NDArray[np.float64],
    weights: npt.NDArray[np.float64],
) -> Fit:
    """Beyond the paper: a fit over the individual points (robust and/or order by CV)."""
    robust = params.robust == "huber"
    w = weights if robust else np.ones_like(px)
    order = params.fit_order
    selection = None
    if params.auto_order:
        try:
            order, scores = select_order_cv(
                px, py, w, orders=range(0, MAX_AUTO_ORDER + 1), robust=robust
            )
        except ValueError as err:
            return FitFailure("poly", str(err), None)
        selection = {
            "method": "5-fold cross-validation over columns (Huber loss)",
            "scores": {str(k): v for k, v in scores.items()},
        }
    fit = fit_polynomial_robust(px, py, w, order=order, robust=robust)
    if isinstance(fit, PolyFit) and selection is not None:
        fit = replace(fit, selection=selection)
    return fit


def _polar(
    params: RunParams,
    grid: Grid,
    px: npt.NDArray[np.float64],
    py: npt.NDArray[np.float64],
    arc_map: npt.NDArray[np.bool_],
    truth: npt.NDArray[np.float64] | None,
    centre: tuple[float, float],
    stage: Stage,
) -> tuple[Bins, Fit, npt.NDArray[np.float64] | None, npt.NDArray[np.bool_] | None]:
    """Angular bins about ``centre`` about one cell wide at the points' typical radius."""
    r = np.hypot(px - centre[0], py - centre[1])
    r_typ = max(float(np.median(r)) if r.size else 1.0, params.cell)
    nbins = int(np.clip(np.ceil(2 * np.pi * r_typ / params.cell), 16, 10**6))
    bins = polar_bins(px, py, centre=centre, nbins=nbins)
    mean = np.nan_to_num(bins.mean)
    fit = fit_polar(bins.centres, mean, bins.count, centre=centre, order=params.fit_order)
    stage("metrics")
    if truth is not None:
        tb = truth_on_polar_bins(truth, centre=centre, nbins=nbins, step=params.cell / 2)
        return bins, fit, tb, None
    ay, ax = np.nonzero(arc_map)
    raw = polar_bins(*grid.to_world(ay, ax), centre=centre, nbins=nbins)
    return bins, fit, None, raw.occupied


def no_arc_message(source: str, bbox: tuple[float, ...] | None) -> str:
    """The error for an empty arc map: it names the bbox when one was given."""
    where = "the bbox " + ",".join(f"{v:g}" for v in bbox) if bbox else "the map"
    return f"{source}: no arc touches {where}"


def map_counts(evidence: npt.NDArray[Any], *, empty: str) -> dict[str, int]:
    """Cells set in a map and their total evidence; ``NothingToMapError(empty)`` if none is."""
    cells_set = int(np.count_nonzero(evidence))
    if cells_set == 0:
        raise NothingToMapError(empty)
    return {"map_cells_set": cells_set, "arc_cells": int(evidence.sum(dtype=np.int64))}


def fit_and_measure(
    params: RunParams,
    grid: Grid,
    processed: npt.NDArray[np.bool_],
    evidence: npt.NDArray[Any],
    *,
    truth: npt.NDArray[np.float64] | None,
    robot_xy: npt.NDArray[np.float64],
    stage: Stage | None = None,
    cells: tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]] | None = None,
    unfitted: FitFailure | None = None,
) -> Evaluation:
    """Fit the cells of ``processed`` and compute the metrics against ``truth``.

    Parameters
    ----------
    params : RunParams
        The fit kind and order, robust/automatic options, the judged span.
    grid : Grid
        The grid of both maps.
    processed : ndarray of bool
        The cells to fit.
    evidence : ndarray of int
        Per-cell evidence (arc counts, hits): the weights of a point-wise (robust) fit,
        at least 1 per kept cell; its nonzero columns are f_c's denominator without truth.
    truth : ndarray, shape (N, 2), optional
        The true surface, for E1 and E2.
    robot_xy : ndarray, shape (M, 2)
        Robot positions; their mean is a polar fit's default centre.
    stage : callable, optional
        Called with ``"metrics"`` when the fit is done (progress reporting).
    cells : tuple of ndarray, optional
        ``np.nonzero(processed.T)``, when the caller has it already.
    unfitted : FitFailure, optional
        No profile is fitted: this is the fit (the map's surfaces were fitted instead,
        and without ``truth`` no metric reads a profile). Not for a polar fit.

    Returns
    -------
    Evaluation
    """
    stage = stage or (lambda _name: None)
    raw = evidence > 0
    ix, iy = np.nonzero(processed.T) if cells is None else cells
    px, py = grid.to_world(iy, ix)
    if params.fit == "polar":
        centre = params.centre or (float(robot_xy[:, 0].mean()), float(robot_xy[:, 1].mean()))
        bins, fit, truth_bins, spanned = _polar(params, grid, px, py, raw, truth, centre, stage)
        metrics = profile_metrics(
            bins, truth=truth_bins, fit=None if isinstance(fit, FitFailure) else fit,
            spanned=spanned,
        )  # fmt: skip
        return Evaluation(px, py, bins, fit, metrics, centre, robot_xy)
    bins = bin_stats(ix, py, grid.centres_x(), presorted=True)
    if unfitted is not None:
        fit = unfitted
    elif params.fit == "poly" and (params.auto_order or params.robust != "none"):
        # a cell that closing or dilation added has no arc of its own: it still counts once
        weights = np.maximum(evidence[iy, ix], 1).astype(np.float64)
        fit = _fit_points(params, px, py, weights)
    else:
        fit = _fit_binned(params, bins)
    stage("metrics")
    metrics = measure_profile(
        params, grid, bins, fit, truth=truth, raw_columns=np.asarray(raw.any(axis=0), dtype=bool)
    )
    return Evaluation(px, py, bins, fit, metrics, None, robot_xy)


def measure_profile(
    params: RunParams,
    grid: Grid,
    bins: Bins,
    fit: Fit,
    *,
    truth: npt.NDArray[np.float64] | None,
    raw_columns: npt.NDArray[np.bool_],
) -> Metrics:
    """e, f_c, E1 and E2 of a profile ``fit`` to the map's column ``bins``.

    ``raw_columns`` marks the columns of the unprocessed map (f_c's denominator without
    truth); with ``params.span == "points"`` only the columns between the first and last
    with points are judged.
    """
    truth_bins, spanned = None, None
    if truth is None:
        spanned = raw_columns.copy()
    else:
        truth_bins = truth_on_columns(truth, bins.centres)
        _, _, bottom, top = grid.extent
        truth_bins[(truth_bins < bottom) | (truth_bins > top)] = np.nan
    if params.span == "points":
        # beyond the paper: judge only the columns between the first and last with points
        inside = np.zeros(bins.centres.size, dtype=bool)
        occ = np.flatnonzero(bins.occupied)
        if occ.size:
            inside[occ[0] : occ[-1] + 1] = True
        if truth_bins is not None:
            truth_bins[~inside] = np.nan
        if spanned is not None:
            spanned &= inside
    return profile_metrics(
        bins, truth=truth_bins, fit=None if isinstance(fit, FitFailure) else fit, spanned=spanned
    )

"""Each ``--auto`` candidate's scores: its maps, fits, held-out losses and hull.

:func:`fold_scores` scores every candidate on one fold: each method's map is built once
on the fold's training readings (candidates share methods), every setting's fit
predicts the held-out readings' paths, and the losses and baseline (a constant or a
line on the same map) go into the candidate's :class:`~sonarproc.auto.score.Score`.
:func:`whole_hulls` fits every profile setting to its method's map of all the scored
readings and records how far it leaves the map points' local hull and how much of the
columns the readings imply it reaches (the guard rails judge that fit: the one that
would be chosen).
Scoring fits merge adjacent columns down to :data:`FIT_COLUMNS` (:func:`fit_columns`).
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.arcs import rasterize
from sonarproc.auto.candidates import Candidate, spline_lambda
from sonarproc.auto.holdout import predicted_path, range_loss, subset_beams
from sonarproc.auto.hull import data_hull_excess
from sonarproc.auto.multisurface import fitted_surfaces, surfaces_path
from sonarproc.auto.score import SURFACES_MAX_CELLS, Score, robust_residual
from sonarproc.auto.separation import profile_map
from sonarproc.errors import NothingToMapError
from sonarproc.fit import Fit, FitFailure, fit_polynomial, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods import MethodMap
from sonarproc.methods.geometry import axis_points
from sonarproc.methods.morphological import Morphological
from sonarproc.metrics import Bins, bin_stats
from sonarproc.morphology import apply_chain
from sonarproc.params import RunParams
from sonarproc.pipeline.selection import Beams

__all__ = [
    "FIT_COLUMNS", "CountMaps", "WholeGuard", "fit_columns", "fold_scores", "implied_span",
    "mean_count", "whole_fit", "whole_hulls",
]  # fmt: skip

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Scoring fits merge adjacent columns down to at most this many (:func:`fit_columns`).
FIT_COLUMNS = 500


def fit_columns(bins: Bins, max_columns: int = FIT_COLUMNS) -> tuple[FloatArray, ...]:
    """Column centres, means and counts, adjacent columns merged to at most ``max_columns``.

    Scoring fits only: the smoothest wave a candidate may follow (orders <= 15, smoothing
    lengths >= 0.1 m) is far longer than the merged columns, and a fit's cost grows with
    its columns (a 20 m room at 1 cm has 2 000).

    Examples
    --------
    >>> y = np.array([1.0, 3, 2, np.nan, 5, 5])
    >>> b = Bins(np.arange(6.0), np.array([1, 1, 2, 0, 1, 1]), y, y)
    >>> [a.tolist() for a in fit_columns(b, 3)]
    [[0.5, 2.0, 4.5], [2.0, 2.0, 5.0], [2.0, 2.0, 2.0]]
    """
    x, y, w = bins.centres, np.nan_to_num(bins.mean), bins.count.astype(np.float64)
    g = int(np.ceil(x.size / max_columns))
    if g <= 1:
        return x, y, w
    n = x.size // g * g
    wx = np.add.reduceat(w[:n] * x[:n], np.arange(0, n, g))
    wy = np.add.reduceat(w[:n] * y[:n], np.arange(0, n, g))
    ww = np.add.reduceat(w[:n], np.arange(0, n, g))
    centre = x[:n].reshape(-1, g).mean(axis=1)
    safe = np.maximum(ww, 1e-300)
    xs = np.where(ww > 0, wx / safe, centre)
    tail = w[n:].sum()
    if tail > 0:
        xs = np.r_[xs, (w[n:] * x[n:]).sum() / tail]
        wy = np.r_[wy, (w[n:] * y[n:]).sum()]
        ww = np.r_[ww, tail]
        safe = np.maximum(ww, 1e-300)
    return xs, np.where(ww > 0, wy / safe, 0.0), ww


def _binned_fit(family: str, bins: Bins, setting: float, lam: float) -> Fit:
    x, y, w = fit_columns(bins)
    if family == "poly":
        return fit_polynomial(x, y, w, order=int(setting))
    return fit_spline(x, y, w, lam=lam)


def mean_count(bins: Bins) -> float:
    """Mean arc count of the columns holding points (1 if none): the smoothing's scale."""
    c = bins.count[bins.count > 0]
    return float(c.mean()) if c.size else 1.0


def _coverage(fit: Fit, implied: tuple[float, float]) -> float:
    """Fraction of the implied span ``implied`` (x0, x1) inside the fit's domain."""
    if isinstance(fit, FitFailure) or not hasattr(fit, "domain"):
        return 0.0
    lo, hi = fit.domain
    width = implied[1] - implied[0]
    if width <= 0:
        return 1.0
    return float(max(0.0, min(hi, implied[1]) - max(lo, implied[0])) / width)


def implied_span(beams: Beams) -> tuple[float, float]:
    """The columns the readings imply: 5th to 95th percentile of their line-of-sight x."""
    p = beams.poses
    apex, direction, dist = axis_points(p.tx_xy, p.tx_heading, p.rx_xy, p.rx_heading, beams.path)
    x = (apex[:, 0] + dist * direction[:, 0])[np.isfinite(dist)]
    if x.size == 0:
        return (0.0, 0.0)
    lo, hi = np.percentile(x, [5.0, 95.0])
    return (float(lo), float(hi))


def fold_scores(
    scores: list[Score],
    beams: Beams,
    grid: Grid,
    base: RunParams,
    train: npt.NDArray[np.bool_],
    held: npt.NDArray[np.intp],
    cap: float,
    *,
    lines_first: bool | None = None,
    counts: CountMaps | None = None,
) -> None:
    """Score every candidate on one fold (see the module notes): ``train`` marks the
    training readings of ``beams``, ``held`` indexes the held-out ones predicted.

    ``lines_first``: how the ``surfaces`` candidate finds its walls
    (:func:`sonarproc.auto.multisurface.fitted_surfaces`): as the run on the whole log
    will, not as a log of the fold's size would. ``counts``: the scored readings' arc
    count map, the fold's drawn from it (:class:`CountMaps`).
    """
    tb = subset_beams(beams, train)
    maps = _Maps(tb, grid, base, None if counts is None else counts.training(train))
    baselines: dict[_MapKey, npt.NDArray[np.float64]] = {}
    measured = beams.path[held]
    step = 2 * grid.cell
    for s in scores:
        c = s.candidate
        key, entry = maps.get(c)
        if entry is None:
            # a fold whose map is empty explains none of its held-out readings: each costs
            # the cap, as a reading the curve does not explain, so every candidate is
            # scored on the same readings (and its losses pair with the echo refit's)
            s.empty_folds += 1
            for setting in c.settings:
                s.losses.setdefault(setting, []).append(np.full(held.size, cap))
            s.base_losses.append(np.full(held.size, cap))
            continue
        mmap, bins, _, _ = entry
        if c.family == "surfaces":
            _score_surfaces(s, mmap, grid, beams, tb, held, measured, cap, step, lines_first)
        else:
            _score_profiles(s, bins, grid, beams, held, measured, cap)
        if key not in baselines:
            best = np.full(held.size, cap)
            for order in (0, 1):
                f = fit_polynomial(bins.centres, np.nan_to_num(bins.mean), bins.count, order=order)
                loss = range_loss(measured, predicted_path(f, beams, held, step), cap)
                if robust_residual(loss) < robust_residual(best):
                    best = loss
            baselines[key] = best
        s.base_losses.append(baselines[key])


_MapKey = tuple[str, tuple[tuple[str, Any], ...]]
_MapEntry = tuple[MethodMap, Bins, FloatArray, FloatArray]


class _Maps:
    """Each method's map on one set of readings, built once (candidates share methods).

    ``counts``: the arc count map of these readings, when the caller has it (a fold's is
    the whole scored set's minus its held-out firings', :class:`CountMaps`): the count
    map methods (``morphological``, ``arc-vote``) then apply their chains to it instead
    of drawing the arcs again.
    """

    def __init__(
        self,
        beams: Beams,
        grid: Grid,
        base: RunParams,
        counts: npt.NDArray[np.uint32] | None = None,
    ) -> None:
        self.beams, self.grid, self.base, self.counts = beams, grid, base, counts
        self.built: dict[_MapKey, _MapEntry | None] = {}

    def get(self, c: Candidate) -> tuple[_MapKey, _MapEntry | None]:
        """The key of ``c``'s map and the map (None when it left nothing)."""
        key = (c.method, tuple(sorted(c.options.items())))
        if key not in self.built:
            self.built[key] = _build(c, self.beams, self.grid, self.base, self.counts)
        return key, self.built[key]


class CountMaps:
    """The arc count map of all the scored readings, drawn once; a fold's training map is
    it minus the map of the fold's held-out readings.

    A cell's count is the number of distinct arcs crossing it, a sum over readings, so the
    difference is exactly the map the training readings draw (a quarter of the arcs drawn
    per fold instead of three quarters, and once for the two count map methods).
    Only for arcs drawn as chains (``arc_step`` unset); None otherwise.
    """

    def __init__(self, beams: Beams, grid: Grid, base: RunParams) -> None:
        self.beams, self.grid = beams, grid
        self.whole = None if base.arc_step is not None else rasterize(beams.arcs, grid)

    def training(self, train: npt.NDArray[np.bool_]) -> npt.NDArray[np.uint32] | None:
        """The count map of the readings ``train`` of the scored set."""
        if self.whole is None:
            return None
        held = subset_beams(self.beams, ~train)
        return self.whole - rasterize(held.arcs, self.grid)


def _build(
    c: Candidate,
    beams: Beams,
    grid: Grid,
    base: RunParams,
    counts: npt.NDArray[np.uint32] | None = None,
) -> _MapEntry | None:
    """The candidate's map on ``beams``, its column statistics and points; None if empty.

    ``counts``: the arc count map of ``beams``, drawn already (:class:`_Maps`).
    """
    method = c.make()
    try:
        params = method.params_for(base)
        if counts is not None and isinstance(method, Morphological):
            # build_arc_map's chain on the count map the caller drew
            mmap = MethodMap(apply_chain(counts, params.ops), counts)
        else:
            mmap = method.build(beams, grid, params)
    except (NothingToMapError, ValueError) as err:
        log.debug("%s: %s", c.name, err)
        return None
    if not mmap.processed.any():
        return None
    if c.family != "surfaces":
        mmap, _ = profile_map(mmap, grid)  # one chain of columns, stray clusters left out
    ix, iy = np.nonzero(mmap.processed.T)
    px, py = grid.to_world(iy, ix)
    return mmap, bin_stats(ix, py, grid.centres_x(), presorted=True), px, py


def _score_profiles(
    s: Score,
    bins: Bins,
    grid: Grid,
    beams: Beams,
    held: npt.NDArray[np.intp],
    measured: FloatArray,
    cap: float,
) -> None:
    """One fold of a profile y(x) candidate: every setting's fit and held-out losses."""
    c = s.candidate
    mc = mean_count(bins)
    s.mean_counts.append(mc)
    for setting in c.settings:
        fit = _binned_fit(c.family, bins, setting, spline_lambda(setting, mc, grid.cell))
        loss = range_loss(measured, predicted_path(fit, beams, held, 2 * grid.cell), cap)
        s.losses.setdefault(setting, []).append(loss)


def _score_surfaces(
    s: Score,
    mmap: MethodMap,
    grid: Grid,
    beams: Beams,
    train: Beams,
    held: npt.NDArray[np.intp],
    measured: FloatArray,
    cap: float,
    step: float,
    lines_first: bool | None,
) -> None:
    """One fold of the ``surfaces`` candidate (it stands aside where the map is y(x))."""
    setting = s.candidate.settings[0]
    if grid.nx * grid.ny > SURFACES_MAX_CELLS:
        s.too_large = grid.nx * grid.ny
        return
    lines = fitted_surfaces(mmap, grid, train, lines_first=lines_first)
    if lines is None:
        s.function_folds += 1
        s.losses.setdefault(setting, []).append(np.full(held.size, cap))
        return
    loss = range_loss(measured, surfaces_path(lines, beams, held, step), cap)
    s.losses.setdefault(setting, []).append(loss)


class WholeGuard:
    """The guard rails' fits, judged lazily: each profile candidate's settings fitted to
    its method's map of all the scored readings, when :func:`sonarproc.auto.select`
    first needs them (the maps are built once and shared by candidates of one method).

    A candidate's residual within the guard rails is never below its residual without
    them, so the candidates ranked below one already judged need not be: only the few
    at the top of the ranking are (the choice is the same as judging every candidate;
    the record says which were).
    """

    def __init__(
        self,
        beams: Beams,
        grid: Grid,
        base: RunParams,
        counts: npt.NDArray[np.uint32] | None = None,
    ) -> None:
        self.maps = _Maps(beams, grid, base, counts)
        self.beams, self.grid = beams, grid
        self._implied: tuple[float, float] | None = None

    def __call__(self, s: Score) -> None:
        """Judge ``s``: its whole fits, their coverage and hull; then ``s.finish``."""
        if s.guarded:
            return
        s.guarded = True
        c = s.candidate
        entry = None if c.family == "surfaces" else self.maps.get(c)[1]
        if entry is not None:
            if self._implied is None:
                self._implied = implied_span(self.beams)
            whole_fit(s, entry, self._implied, self.beams, self.grid)
        s.finish(self.grid.cell)


def whole_fit(
    s: Score, entry: _MapEntry, implied: tuple[float, float], beams: Beams, grid: Grid
) -> None:
    """One profile candidate's settings fitted to its map of all the scored readings
    (``entry``), their coverage of the ``implied`` columns and their hull excess."""
    c = s.candidate
    _, bins, px, py = entry
    s.whole_bins = bins
    mc = mean_count(bins)
    for setting in c.settings:
        fit = _binned_fit(c.family, bins, setting, spline_lambda(setting, mc, grid.cell))
        s.whole_fits[setting] = fit
        s.coverage[setting] = _coverage(fit, implied)
        if not isinstance(fit, FitFailure):
            s.hull[setting] = data_hull_excess(fit, px, py, beams, grid.cell)


def whole_hulls(scores: list[Score], beams: Beams, grid: Grid, base: RunParams) -> None:
    """Each profile setting's hull excess and coverage of the implied columns
    (:func:`implied_span`), fitted to its method's map of all ``beams``: every candidate
    judged (:class:`WholeGuard` judges them one at a time)."""
    guard = WholeGuard(beams, grid, base)
    for s in scores:
        guard(s)

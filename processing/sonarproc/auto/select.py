"""``--auto``: score every candidate on held-out firings, run the best on the whole log.

:func:`choose` scores :data:`~sonarproc.auto.candidates.CANDIDATES` by the held-out range
residual (:mod:`sonarproc.auto.holdout`) and applies the guard rails of
:mod:`sonarproc.auto.score` (a fit that leaves its points' hull, misses most of the
columns the readings imply, or does no better than a constant or a line, is never
chosen). The hull is judged on each setting's fit to the map of all the scored readings
(the fit that would be chosen), not on the folds' fits: a fold's fit sees part of the
points and may leave their hull where the whole fit does not. :func:`run_auto` then
runs the winner on every reading (the hull is checked again on that fit; a failure
hands over to the runner-up).

Large logs are scored on a random subset of at most ``max_readings`` readings (whole
firings), so ``--auto`` costs a few runs, whatever the log.
"""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.auto.candidates import CANDIDATES, Candidate, spline_lambda
from sonarproc.auto.holdout import (
    hull_excess,
    make_folds,
    predicted_path,
    range_loss,
    subset_beams,
)
from sonarproc.auto.multisurface import fitted_surfaces, surfaces_path
from sonarproc.auto.score import (
    CAP_CELLS,
    CRITERION,
    HULL_CELLS,
    SURFACES_MAX_CELLS,
    TRIM,
    AutoChoice,
    Score,
    robust_residual,
)
from sonarproc.errors import NothingToMapError
from sonarproc.fit import Fit, FitFailure, fit_polynomial, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods import MethodMap, MethodResult
from sonarproc.methods.geometry import axis_points
from sonarproc.metrics import Bins, bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import evaluate_map
from sonarproc.pipeline.selection import Beams, plan_grid, select_beams

__all__ = ["choose", "run_auto", "run_candidate"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Logs smaller than this many readings are split into folds again with other seeds (up
#: to :data:`MAX_REPEATS` times) so that about this many held-out predictions are scored.
REPEAT_READINGS = 1_200
MAX_REPEATS = 3
#: Scoring fits merge adjacent columns down to at most this many (:func:`fit_columns`).
FIT_COLUMNS = 500


def _sample_firings(readings: np.ndarray, limit: int, seed: int) -> npt.NDArray[np.bool_]:
    """At most about ``limit`` readings, whole firings at random."""
    n = len(readings)
    if n <= limit:
        return np.ones(n, dtype=bool)
    keys = np.column_stack((np.asarray(readings["t"], dtype=np.float64), readings["tx"]))
    _, firing = np.unique(keys, axis=0, return_inverse=True)
    firing = firing.reshape(-1)
    nf = int(firing.max()) + 1
    take = np.random.default_rng(seed + 1).random(nf) < limit / n
    return np.asarray(take[firing], dtype=bool)


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


def _mean_count(bins: Bins) -> float:
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


def _fold_scores(
    scores: list[Score],
    beams: Beams,
    grid: Grid,
    base: RunParams,
    train: npt.NDArray[np.bool_],
    held: npt.NDArray[np.intp],
    cap: float,
    implied: tuple[float, float],
) -> None:
    tb = subset_beams(beams, train)
    maps = _Maps(tb, grid, base)
    baselines: dict[_MapKey, npt.NDArray[np.float64]] = {}
    measured = beams.path[held]
    step = 2 * grid.cell
    for s in scores:
        c = s.candidate
        key, entry = maps.get(c)
        if entry is None:
            continue
        mmap, bins, px, py = entry
        if c.family == "surfaces":
            _score_surfaces(s, mmap, grid, beams, tb, held, measured, cap, step)
        else:
            _score_profiles(s, bins, px, py, grid, beams, held, measured, cap, implied)
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
    """Each method's map on one set of readings, built once (candidates share methods)."""

    def __init__(self, beams: Beams, grid: Grid, base: RunParams) -> None:
        self.beams, self.grid, self.base = beams, grid, base
        self.built: dict[_MapKey, _MapEntry | None] = {}

    def get(self, c: Candidate) -> tuple[_MapKey, _MapEntry | None]:
        """The key of ``c``'s map and the map (None when it left nothing)."""
        key = (c.method, tuple(sorted(c.options.items())))
        if key not in self.built:
            self.built[key] = _build(c, self.beams, self.grid, self.base)
        return key, self.built[key]


def _build(c: Candidate, beams: Beams, grid: Grid, base: RunParams) -> _MapEntry | None:
    """The candidate's map on ``beams``, its column statistics and points; None if empty."""
    method = c.make()
    try:
        mmap = method.build(beams, grid, method.params_for(base))
    except (NothingToMapError, ValueError) as err:
        log.debug("%s: %s", c.name, err)
        return None
    if not mmap.processed.any():
        return None
    ix, iy = np.nonzero(mmap.processed.T)
    px, py = grid.to_world(iy, ix)
    return mmap, bin_stats(ix, py, grid.centres_x(), presorted=True), px, py


def _score_profiles(
    s: Score,
    bins: Bins,
    px: FloatArray,
    py: FloatArray,
    grid: Grid,
    beams: Beams,
    held: npt.NDArray[np.intp],
    measured: FloatArray,
    cap: float,
    implied: tuple[float, float],
) -> None:
    """One fold of a profile y(x) candidate: every setting's fit, hull, coverage, losses."""
    c = s.candidate
    mc = _mean_count(bins)
    s.mean_counts.append(mc)
    for setting in c.settings:
        fit = _binned_fit(c.family, bins, setting, spline_lambda(setting, mc, grid.cell))
        s.coverage[setting] = min(s.coverage.get(setting, 1.0), _coverage(fit, implied))
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
) -> None:
    """One fold of the ``surfaces`` candidate (it stands aside where the map is y(x))."""
    setting = s.candidate.settings[0]
    if grid.nx * grid.ny > SURFACES_MAX_CELLS:
        s.too_large = grid.nx * grid.ny
        return
    lines = fitted_surfaces(mmap, grid, train)
    if lines is None:
        s.function_folds += 1
        s.losses.setdefault(setting, []).append(np.full(held.size, cap))
        return
    loss = range_loss(measured, surfaces_path(lines, beams, held, step), cap)
    s.losses.setdefault(setting, []).append(loss)


def choose(
    log_: SonarLog,
    base: RunParams,
    *,
    candidates: tuple[Candidate, ...] = CANDIDATES,
    folds: int = 4,
    repeats: int | None = None,
    max_readings: int = 6_000,
    heldout_per_fold: int = 300,
    seed: int = 0,
    folds_by: str = "firings",
) -> AutoChoice:
    """Score every candidate by its held-out range residual (no ground truth).

    Parameters
    ----------
    log_ : sonarlog.SonarLog
        The log.
    base : RunParams
        Grid and selection options (cell, bbox, crosstalk); each candidate sets the fit.
    candidates : tuple of Candidate
        What to choose from.
    folds : int
        Number of folds of firings.
    repeats : int, optional
        Times the folds are drawn (with other seeds); default: enough for about
        :data:`REPEAT_READINGS` held-out predictions, at most :data:`MAX_REPEATS`.
    max_readings : int
        Score on a random subset of at most about this many readings (whole firings).
    heldout_per_fold : int
        Held-out readings predicted per fold (a random subset).
    seed : int
        Seed of the folds and subsets.
    folds_by : str
        How the folds split the log: ``"firings"`` (whole firings at random, what
        ``--auto`` uses), ``"time"`` (contiguous time blocks) or ``"passes"`` (contiguous
        runs of each transmitter's firings); :mod:`sonarproc.studies.auto_rules`
        compares them.

    Returns
    -------
    AutoChoice

    Raises
    ------
    NothingToMapError, InputError, ParameterError
        As ``sonarproc run`` (no usable reading, a bad grid); ``ParameterError`` also for
        an unknown ``folds_by``.
    """
    beams, _ = select_beams(log_, base)
    grid = plan_grid(log_, base, beams)
    used = _sample_firings(beams.readings, max_readings, seed)
    beams = subset_beams(beams, used)
    n = int(used.sum())
    if repeats is None:
        repeats = int(np.clip(np.ceil(REPEAT_READINGS / max(n, 1)), 1, MAX_REPEATS))
    cap = max(CAP_CELLS * grid.cell, 0.05)
    implied = implied_span(beams)
    rng = np.random.default_rng(seed + 2)
    scores = [Score(c) for c in candidates]
    for rep in range(repeats):
        fold = make_folds(beams.readings, folds, by=folds_by, seed=seed + 1000 * rep)
        for f in range(folds):
            test = np.flatnonzero(fold == f)
            if test.size == 0:
                continue
            held = np.sort(rng.permutation(test)[:heldout_per_fold])
            _fold_scores(scores, beams, grid, base, fold != f, held, cap, implied)
    _whole_hulls(scores, beams, grid, base)
    for s in scores:
        s.finish(grid.cell)
    crit = CRITERION.format(k=folds, cap=cap, trim=TRIM, repeats=repeats)
    return AutoChoice(scores, crit, n, folds, repeats)


def _whole_hulls(scores: list[Score], beams: Beams, grid: Grid, base: RunParams) -> None:
    """Each profile setting's hull excess, fitted to its method's map of all ``beams``."""
    maps = _Maps(beams, grid, base)
    for s in scores:
        c = s.candidate
        entry = None if c.family == "surfaces" else maps.get(c)[1]
        if entry is None:
            continue
        _, bins, px, py = entry
        mc = _mean_count(bins)
        for setting in c.settings:
            fit = _binned_fit(c.family, bins, setting, spline_lambda(setting, mc, grid.cell))
            if not isinstance(fit, FitFailure):
                sampled = fit.sample(grid.cell)
                s.hull[setting] = hull_excess(sampled, px, py, window=10 * grid.cell)


def run_candidate(log_: SonarLog, base: RunParams, score: Score) -> MethodResult:
    """Run a scored candidate at its chosen setting on every reading of the log."""
    cpu0 = time.process_time()
    c = score.candidate
    method = c.make()
    beams, counts = select_beams(log_, base)
    grid = plan_grid(log_, base, beams)
    mmap = method.build(beams, grid, method.params_for(base))
    setting = score.setting if score.setting is not None else c.settings[0]
    lam = None
    if c.family == "spline":
        ix, iy = np.nonzero(mmap.processed.T)
        bins = bin_stats(ix, grid.to_world(iy, ix)[1], grid.centres_x(), presorted=True)
        lam = spline_lambda(setting, _mean_count(bins), grid.cell)
    params = method.params_for(c.params(base, setting, lam=lam))
    result = evaluate_map(
        log_, params, grid, mmap, robot_xy=beams.robot_xy, counts=counts, cpu_start=cpu0,
        empty_message=f"{log_.path}: the method left nothing on the map", beams=beams,
    )  # fmt: skip
    return MethodResult(method.name, dict(method.options), result, mmap.probability)


def run_auto(
    log_: SonarLog, base: RunParams, **kwargs: Any
) -> tuple[MethodResult, Score, AutoChoice]:
    """Choose (:func:`choose`) and run the winner on the whole log.

    Returns
    -------
    result : MethodResult
        The chosen candidate's run (its parameters in ``result.run.params``).
    chosen : Score
    choice : AutoChoice
        Every score; ``choice.to_json(chosen)`` is report.json's ``auto``.
    """
    choice = choose(log_, base, **kwargs)
    ranked = [s for s in choice.ranked if np.isfinite(s.residual_m)]
    last: tuple[MethodResult, Score] | None = None
    for s in ranked:
        try:
            res = run_candidate(log_, base, s)
        except NothingToMapError:
            continue
        if last is None:
            last = (res, s)
        r = res.run
        if r.surfaces is not None and r.surfaces.surfaces:
            return res, s, choice  # several surfaces: no profile hull to check
        if isinstance(r.fit, FitFailure):
            s.excluded = f"on every reading, the fit failed: {r.fit.reason}"
            continue
        if s.excluded is None:
            excess = hull_excess(
                r.fit.sample(r.grid.cell), r.points_x, r.points_y, window=10 * r.grid.cell
            )
            if excess > HULL_CELLS * r.grid.cell:
                s.excluded = f"on every reading, the fit leaves its hull by {100 * excess:.3g} cm"
                continue
            return res, s, choice
    if last is None:
        raise NothingToMapError(f"{log_.path}: no automatic candidate left anything on the map")
    return last[0], last[1], choice

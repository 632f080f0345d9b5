"""``--auto``: score every candidate on held-out firings, run the best on the whole log.

:func:`choose` scores :data:`~sonarproc.auto.candidates.CANDIDATES` by the held-out range
residual (:mod:`sonarproc.auto.holdout`) and applies two guard rails: a candidate whose
fit leaves its points' local hull by more than :data:`HULL_CELLS` cells (in any fold),
or whose residual is worse than a constant's or a straight line's fitted to the same
points, is never chosen. :func:`run_auto` then runs the winner on every reading (the
hull is checked again on that fit; a failure hands over to the runner-up).

Large logs are scored on a random subset of at most ``max_readings`` readings (whole
firings), so ``--auto`` costs a few runs, whatever the log.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.auto.candidates import CANDIDATES, Candidate, spline_lambda
from sonarproc.auto.holdout import (
    firing_folds,
    hull_excess,
    predicted_path,
    range_loss,
    subset_beams,
)
from sonarproc.errors import NothingToMapError
from sonarproc.fit import Fit, FitFailure, fit_polynomial, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods import MethodResult
from sonarproc.metrics import Bins, bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import evaluate_map
from sonarproc.pipeline.selection import Beams, plan_grid, select_beams

__all__ = ["CRITERION", "HULL_CELLS", "AutoChoice", "Score", "choose", "run_auto", "run_candidate"]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: A fit may leave its points' local hull by at most this many cells.
HULL_CELLS = 3.0
#: A reading's loss is capped at this many cells (or 5 cm, if more).
CAP_CELLS = 10.0
#: What report.json says the criterion is.
CRITERION = (
    "held-out range residual: firings split into {k} folds; each fold's readings predicted "
    "(first echo inside the beams, ellipse path for a pair) from the profile fitted to the "
    "other folds; mean |measured - predicted| range, capped at {cap:.3g} m (also where the "
    "curve misses the beams)"
)


@dataclass
class Score:
    """A candidate's held-out residual at each setting, its best, and the guard rails."""

    candidate: Candidate
    losses: dict[float, list[npt.NDArray[np.float64]]] = field(default_factory=dict)
    hull: dict[float, float] = field(default_factory=dict)
    base_losses: list[npt.NDArray[np.float64]] = field(default_factory=list)
    mean_counts: list[float] = field(default_factory=list)
    setting: float | None = None
    residual_m: float = np.inf
    baseline_m: float = np.inf
    hull_m: float = 0.0
    excluded: str | None = None

    def finish(self, cell: float) -> None:
        """Best setting within the hull; exclusion by the guard rails."""
        res = {k: float(np.concatenate(v).mean()) for k, v in self.losses.items() if v}
        self.baseline_m = (
            float(np.concatenate(self.base_losses).mean()) if self.base_losses else np.inf
        )
        inside = {k: r for k, r in res.items() if self.hull.get(k, 0.0) <= HULL_CELLS * cell}
        if not res:
            self.excluded = "the method left nothing on the map"
            return
        pool = inside or res
        self.setting = min(pool, key=lambda k: pool[k])
        self.residual_m = pool[self.setting]
        self.hull_m = self.hull.get(self.setting, 0.0)
        if not inside:
            self.excluded = f"every fit leaves its points' hull (by {100 * self.hull_m:.3g} cm)"
        elif self.residual_m > self.baseline_m + 0.25 * cell:
            self.excluded = (
                f"worse than a constant or a line on its points ({100 * self.baseline_m:.3g} cm)"
            )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready row."""
        return {
            "name": self.candidate.name,
            **self.candidate.describe(self.setting),
            "residual_m": _finite(self.residual_m),
            "baseline_residual_m": _finite(self.baseline_m),
            "excluded": self.excluded,
        }


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


@dataclass
class AutoChoice:
    """The outcome of :func:`choose`: the scores and the criterion."""

    scores: list[Score]
    criterion: str
    readings_scored: int
    folds: int

    @property
    def ranked(self) -> list[Score]:
        """Eligible candidates, best first (the ones the guard rails excluded last)."""
        return sorted(self.scores, key=lambda s: (s.excluded is not None, s.residual_m))

    def to_json(self, chosen: Score) -> dict[str, Any]:
        """The ``auto`` record of report.json."""
        others = [s.to_json() for s in self.ranked if s is not chosen]
        return {
            "criterion": self.criterion,
            "choice": chosen.candidate.name,
            **chosen.candidate.describe(chosen.setting),
            "residual_m": _finite(chosen.residual_m),
            "folds": self.folds,
            "readings_scored": self.readings_scored,
            "runners_up": others,
        }


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


def _binned_fit(family: str, bins: Bins, setting: float, lam: float) -> Fit:
    mean = np.nan_to_num(bins.mean)
    if family == "poly":
        return fit_polynomial(bins.centres, mean, bins.count, order=int(setting))
    return fit_spline(bins.centres, mean, bins.count, lam=lam)


def _mean_count(bins: Bins) -> float:
    c = bins.count[bins.count > 0]
    return float(c.mean()) if c.size else 1.0


def _fold_scores(
    scores: list[Score],
    beams: Beams,
    grid: Grid,
    base: RunParams,
    train: npt.NDArray[np.bool_],
    held: npt.NDArray[np.intp],
    cap: float,
) -> None:
    tb = subset_beams(beams, train)
    maps: dict[
        tuple[str, tuple[tuple[str, Any], ...]], tuple[Bins, FloatArray, FloatArray] | None
    ] = {}
    baselines: dict[tuple[str, tuple[tuple[str, Any], ...]], npt.NDArray[np.float64]] = {}
    measured = beams.path[held]
    step = 2 * grid.cell
    window = 10 * grid.cell
    for s in scores:
        c = s.candidate
        key = (c.method, tuple(sorted(c.options.items())))
        if key not in maps:
            method = c.make()
            try:
                mmap = method.build(tb, grid, method.params_for(base))
            except (NothingToMapError, ValueError) as err:
                log.debug("%s: %s", c.name, err)
                mmap = None
            if mmap is None or not mmap.processed.any():
                maps[key] = None
            else:
                ix, iy = np.nonzero(mmap.processed.T)
                px, py = grid.to_world(iy, ix)
                maps[key] = (bin_stats(ix, py, grid.centres_x(), presorted=True), px, py)
        entry = maps[key]
        if entry is None:
            continue
        bins, px, py = entry
        mc = _mean_count(bins)
        s.mean_counts.append(mc)
        for setting in c.settings:
            fit = _binned_fit(c.family, bins, setting, spline_lambda(setting, mc, grid.cell))
            if not isinstance(fit, FitFailure):
                h = hull_excess(fit.sample(grid.cell), px, py, window=window)
                s.hull[setting] = max(s.hull.get(setting, 0.0), h)
            if s.hull.get(setting, 0.0) > HULL_CELLS * grid.cell:
                # excluded whatever it predicts: spare the echo model
                s.losses.setdefault(setting, []).append(np.full(held.size, cap))
                continue
            loss = range_loss(measured, predicted_path(fit, beams, held, step), cap)
            s.losses.setdefault(setting, []).append(loss)
        if key not in baselines:
            best = np.full(held.size, cap)
            for order in (0, 1):
                f = fit_polynomial(bins.centres, np.nan_to_num(bins.mean), bins.count, order=order)
                loss = range_loss(measured, predicted_path(f, beams, held, step), cap)
                if loss.mean() < best.mean():
                    best = loss
            baselines[key] = best
        s.base_losses.append(baselines[key])


def choose(
    log_: SonarLog,
    base: RunParams,
    *,
    candidates: tuple[Candidate, ...] = CANDIDATES,
    folds: int = 4,
    max_readings: int = 6_000,
    heldout_per_fold: int = 300,
    seed: int = 0,
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
    max_readings : int
        Score on a random subset of at most about this many readings (whole firings).
    heldout_per_fold : int
        Held-out readings predicted per fold (a random subset).
    seed : int
        Seed of the folds and subsets.

    Returns
    -------
    AutoChoice

    Raises
    ------
    NothingToMapError, InputError, ParameterError
        As ``sonarproc run`` (no usable reading, a bad grid).
    """
    beams, _ = select_beams(log_, base)
    grid = plan_grid(log_, base, beams)
    fold = firing_folds(beams.readings, folds, seed=seed)
    used = _sample_firings(beams.readings, max_readings, seed)
    beams = subset_beams(beams, used)
    fold = fold[used]
    cap = max(CAP_CELLS * grid.cell, 0.05)
    rng = np.random.default_rng(seed + 2)
    scores = [Score(c) for c in candidates]
    for f in range(folds):
        test = np.flatnonzero(fold == f)
        if test.size == 0:
            continue
        held = np.sort(rng.permutation(test)[:heldout_per_fold])
        _fold_scores(scores, beams, grid, base, fold != f, held, cap)
    for s in scores:
        s.finish(grid.cell)
    crit = CRITERION.format(k=folds, cap=cap)
    return AutoChoice(scores, crit, int(used.sum()), folds)


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
        empty_message=f"{log_.path}: the method left nothing on the map",
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

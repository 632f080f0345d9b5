"""``--auto``: score every candidate on held-out firings, run the best on the whole log.

:func:`choose` scores :data:`~sonarproc.auto.candidates.CANDIDATES` by the held-out range
residual (:mod:`sonarproc.auto.holdout`) and applies the guard rails of
:mod:`sonarproc.auto.score` (a fit that leaves its points' hull, misses most of the
columns the readings imply, or does no better than a constant or a line, is never
chosen). The hull is judged on each setting's fit to the map of all the scored readings
(the fit that would be chosen), not on the folds' fits: a fold's fit sees part of the
points and may leave their hull where the whole fit does not. A guard can only raise a
candidate's residual or exclude it, so it is judged from the top of the ranking down
until a judged candidate is on top (:meth:`AutoChoice.next_ranked`): the same choice as
judging every candidate, for a few of them. :func:`run_auto` then runs the winner on
every reading (the hull is checked again on that fit; a failure hands over to the
runner-up).

Large logs are scored on a random subset of at most ``max_readings`` readings (whole
firings), so ``--auto`` costs a few runs, whatever the log.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.auto.candidates import CANDIDATES, Candidate, spline_lambda
from sonarproc.auto.constants import constants_record
from sonarproc.auto.echo_refit import TIE_SE, RefitChoice, choose_refit, range_noise
from sonarproc.auto.holdout import Split, firing_index, heldout_splits, subset_beams
from sonarproc.auto.hull import data_hull_excess
from sonarproc.auto.score import (
    CAP_CELLS,
    CRITERION,
    HULL_CELLS,
    TRIM,
    AutoChoice,
    Score,
    paired_se,
)
from sonarproc.auto.scoring import CountMaps, WholeGuard, fold_scores, mean_count
from sonarproc.auto.separation import LEFT_OUT, SEPARATION_RULE, profile_map
from sonarproc.auto.threads import in_threads
from sonarproc.errors import NothingToMapError
from sonarproc.fit import FitFailure, PolyFit, SplineFit
from sonarproc.grid import Grid
from sonarproc.methods import MethodResult
from sonarproc.metrics import Bins, bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline.evaluation import measure_profile
from sonarproc.pipeline.mapping import MethodMap, evaluate_map
from sonarproc.pipeline.selection import Beams, plan_grid, select_beams

__all__ = [
    "CandidateMap", "candidate_map", "choose", "evaluate_candidate", "run_auto", "run_candidate",
]  # fmt: skip

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Logs smaller than this many readings are split into folds again with other seeds (up
#: to :data:`MAX_REPEATS` times) so that about this many held-out predictions are scored.
REPEAT_READINGS = 1_200
MAX_REPEATS = 3
#: The echo refit starts from the winner's profile and from the next runners-up's, this
#: many profiles in all.
REFIT_STARTS = 3


def _sample_firings(readings: np.ndarray, limit: int, seed: int) -> npt.NDArray[np.bool_]:
    """At most about ``limit`` readings, whole firings at random."""
    n = len(readings)
    if n <= limit:
        return np.ones(n, dtype=bool)
    firing = firing_index(readings)
    nf = int(firing.max()) + 1
    take = np.random.default_rng(seed + 1).random(nf) < limit / n
    return np.asarray(take[firing], dtype=bool)


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
    workers: int | None = None,
    judge_all: bool = False,
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
        Seed of the folds (whole firings at random) and subsets.
    workers : int, optional
        Threads the folds are scored on (:func:`sonarproc.auto.threads.in_threads`;
        default: the CPUs, at most 4). The outcome is the same for any number.
    judge_all : bool
        Judge every candidate's guard rails (hull, coverage of the fits to the map of all
        the scored readings), not only those at the top of the ranking: the choice is
        the same, the record complete (:meth:`AutoChoice.next_ranked`).

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
    from sonarproc.pipeline.surfacefit import LINES_FIRST_READINGS  # scipy's graphs: lazily

    # the surfaces are scored as the run on every reading fits them
    lines_first = beams.path.size >= LINES_FIRST_READINGS
    used = _sample_firings(beams.readings, max_readings, seed)
    beams = subset_beams(beams, used)
    n = int(used.sum())
    if repeats is None:
        repeats = int(np.clip(np.ceil(REPEAT_READINGS / max(n, 1)), 1, MAX_REPEATS))
    cap = max(CAP_CELLS * grid.cell, 0.05)
    splits = heldout_splits(beams.readings, folds, repeats, heldout_per_fold, seed=seed)
    scores = [Score(c) for c in candidates]

    # the count map of every scored reading, drawn once: a fold's is it minus its held-out
    counts = CountMaps(beams, grid, base)

    def one_fold(split: Split) -> list[Score]:
        mine = [Score(c) for c in candidates]
        fold_scores(
            mine, beams, grid, base, split[0], split[1], cap,
            lines_first=lines_first, counts=counts,
        )  # fmt: skip
        return mine

    # each fold writes its losses into its own Scores, gathered in the folds' order
    jobs: list[Callable[[], list[Score]]] = [partial(one_fold, split) for split in splits]
    for per_fold in in_threads(lambda job: job(), jobs, workers):
        for s, part in zip(scores, per_fold, strict=True):
            s.absorb(part)
    for s in scores:
        s.finish(grid.cell)  # without the guard rails' fits: a lower bound of the residual
    crit = CRITERION.format(k=folds, cap=cap, trim=TRIM, repeats=repeats)
    choice = AutoChoice(scores, crit, n, folds, repeats, scored=beams, splits=splits)
    choice.constants = {
        **constants_record(), "REPEAT_READINGS": REPEAT_READINGS, "MAX_REPEATS": MAX_REPEATS,
        "REFIT_STARTS": REFIT_STARTS, "folds": folds, "heldout_per_fold": heldout_per_fold,
        "max_readings": max_readings,
    }  # fmt: skip
    choice.guard = WholeGuard(beams, grid, base, counts.whole)
    if judge_all:
        for s in scores:
            choice.guard(s)
    else:
        choice.next_ranked([])  # the best candidate, judged
    return choice


@dataclass
class CandidateMap:
    """A scored candidate's map on every reading, and the parameters of its fit."""

    beams: Beams
    counts: dict[str, int]
    grid: Grid
    mmap: MethodMap
    params: RunParams
    method_name: str
    method_options: dict[str, Any]


def candidate_map(log_: SonarLog, base: RunParams, score: Score) -> CandidateMap:
    """Build a scored candidate's map on every reading of the log (its setting's fit params)."""
    c = score.candidate
    method = c.make()
    beams, counts = select_beams(log_, base)
    grid = plan_grid(log_, base, beams)
    mmap = method.build(beams, grid, method.params_for(base))
    if c.family != "surfaces":
        # a profile y(x) is fitted to one chain of columns, stray clusters left out
        mmap, left_out = profile_map(mmap, grid)
        counts = {**counts, LEFT_OUT: left_out}
    setting = score.setting if score.setting is not None else c.settings[0]
    lam = None
    if c.family == "spline":
        ix, iy = np.nonzero(mmap.processed.T)
        bins = bin_stats(ix, grid.to_world(iy, ix)[1], grid.centres_x(), presorted=True)
        lam = spline_lambda(setting, mean_count(bins), grid.cell)
    params = method.params_for(c.params(base, setting, lam=lam))
    return CandidateMap(beams, counts, grid, mmap, params, method.name, dict(method.options))


def evaluate_candidate(
    log_: SonarLog,
    cm: CandidateMap,
    *,
    span: tuple[float, float] | None = None,
    cpu_start: float | None = None,
) -> MethodResult:
    """Fit and measure a candidate's map; with ``span`` (x0, x1) only its columns inside it.

    ``cpu_start`` is where the run's CPU time is counted from (by default, now: the fit
    alone; :func:`run_candidate` counts the map too).
    """
    cpu0 = time.process_time() if cpu_start is None else cpu_start
    mmap = cm.mmap
    if span is not None:
        x = cm.grid.centres_x()
        inside = (x >= span[0] - 1e-9) & (x <= span[1] + 1e-9)
        mmap = replace(mmap, processed=mmap.processed & inside[None, :])
    result = evaluate_map(
        log_, cm.params, cm.grid, mmap, robot_xy=cm.beams.robot_xy, counts=cm.counts,
        cpu_start=cpu0, empty_message=f"{log_.path}: the method left nothing on the map",
        beams=cm.beams,
    )  # fmt: skip
    return MethodResult(cm.method_name, dict(cm.method_options), result, mmap.probability)


def run_candidate(log_: SonarLog, base: RunParams, score: Score) -> MethodResult:
    """Run a scored candidate at its chosen setting on every reading of the log."""
    cpu0 = time.process_time()
    return evaluate_candidate(log_, candidate_map(log_, base, score), cpu_start=cpu0)


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
    max_readings = int(kwargs.get("max_readings", 6_000))
    seed = int(kwargs.get("seed", 0))
    workers = kwargs.get("workers")
    last: tuple[MethodResult, Score] | None = None
    tried: list[Score] = []
    while (s := choice.next_ranked(tried)) is not None:
        tried.append(s)
        if s.excluded is not None and last is not None:
            continue  # excluded while scoring: only the fallback is run
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
            excess = data_hull_excess(r.fit, r.points_x, r.points_y, choice.scored, r.grid.cell)
            if excess > HULL_CELLS * r.grid.cell:
                s.excluded = f"on every reading, the fit leaves its hull by {100 * excess:.3g} cm"
                continue
            return (
                _refitted(log_, base, res, s, choice, max_readings, seed, workers),
                s,
                choice,
            )
    if last is None:
        raise NothingToMapError(f"{log_.path}: no automatic candidate left anything on the map")
    res, s = last
    choice.fallback = (
        f"every candidate was excluded by the guard rails; the best ranked is returned "
        f"({s.excluded})"
    )
    # its refit through the echo points has guard rails of its own (the points' hull)
    return _refitted(log_, base, res, s, choice, max_readings, seed, workers), s, choice


def _refitted(
    log_: SonarLog,
    base: RunParams,
    res: MethodResult,
    s: Score,
    choice: AutoChoice,
    max_readings: int,
    seed: int,
    workers: int | None,
) -> MethodResult:
    """The run refitted through the echo points (:func:`_echo_refitted`), and the record
    of the map cells its profile left out."""
    refitted = _echo_refitted(log_, base, res, s, choice, max_readings, seed, workers)
    left_out = refitted.run.counts.get(LEFT_OUT, 0)
    choice.left_out = {
        "rule": SEPARATION_RULE,
        "cells_left_out": left_out,
        "cells": left_out + refitted.run.counts["processed_cells"],
    }
    return refitted


@dataclass
class RefitStart:
    """A profile the echo refit starts from: a candidate's fit, its map's columns, its grid."""

    score: Score
    fit: PolyFit | SplineFit
    bins: Bins
    grid: Grid


def _refit_starts(choice: AutoChoice, winner: Score, grid: Grid) -> list[RefitStart]:
    """The runners-up the echo refit also starts from (:data:`REFIT_STARTS` in all), each
    at its chosen setting's fit to its map of the scored readings (no map is built again)."""
    # by identity: Score is a dataclass whose equality would compare its arrays
    ranked = [s for s in choice.ranked if np.isfinite(s.residual_m)]
    tried = ranked[: next(i for i, s in enumerate(ranked) if s is winner) + 1]
    starts: list[RefitStart] = []
    while len(starts) < REFIT_STARTS - 1 and (s := choice.next_ranked(tried)) is not None:
        tried.append(s)
        fit = s.whole_fits.get(s.setting) if s.setting is not None else None
        if s.excluded is None and isinstance(fit, PolyFit | SplineFit) and s.whole_bins:
            starts.append(RefitStart(s, fit, s.whole_bins, grid))
    return starts


def _setting_losses(s: Score) -> FloatArray | None:
    """A score's held-out losses at its chosen setting, in the order of the folds."""
    losses = s.losses.get(s.setting) if s.setting is not None else None
    return np.concatenate(losses) if losses else None


def _pick_start(refits: list[RefitChoice]) -> int:
    """Which start's refit to keep: the winner's (index 0) unless another predicts the
    held-out readings better by more than :data:`TIE_SE` paired standard errors."""
    scored = {i: r.residual for i, r in enumerate(refits) if r.residual is not None}
    if not scored:
        return 0
    best = min(scored, key=lambda i: scored[i])
    mine, theirs = refits[0], refits[best]
    if mine.residual is None or mine.heldout is None or theirs.heldout is None:
        return best
    gap = mine.residual - scored[best]
    return best if gap > TIE_SE * np.nan_to_num(paired_se(mine.heldout, theirs.heldout)) else 0


def _echo_refitted(
    log_: SonarLog,
    base: RunParams,
    res: MethodResult,
    winner: Score,
    choice: AutoChoice,
    max_readings: int,
    seed: int,
    workers: int | None,
) -> MethodResult:
    """The winner's run with a profile refitted through the echo points, if that wins.

    The refit starts from the winner's profile and from the next runners-up's
    (:func:`_refit_starts`): it finds its echo points near the profile it starts from,
    and a rough start on a noisy log finds the wrong ones. Each start's refit is scored
    on the readings and folds the candidates were scored on
    (:func:`sonarproc.auto.echo_refit.choose_refit`) and judged against the winner's
    held-out losses; the winner's start is kept unless another's refit predicts the
    held-out readings better by more than :data:`TIE_SE` paired standard errors (then
    that runner-up is run on every reading for its map). The record says what it found.
    """
    beams = choice.scored
    if beams is None:
        beams, _ = select_beams(log_, base)
        beams = subset_beams(beams, _sample_firings(beams.readings, max_readings, seed))
    r = res.run
    # the winner's held-out losses, fold by fold as the refit's (same seeds and draws)
    mine = _setting_losses(winner)
    cap = max(CAP_CELLS * r.grid.cell, 0.05)
    if not isinstance(r.fit, PolyFit | SplineFit):
        choice.echo_refit = choose_refit(
            r.fit, r.bins, beams, r.grid, chosen_residual=winner.residual_m, cap=cap
        ).to_json()  # says that there is no profile y(x) to refit
        return res
    starts = [RefitStart(winner, r.fit, r.bins, r.grid)]
    starts += _refit_starts(choice, winner, r.grid)
    # one noise estimate for every start, so that their refits differ only by the start:
    # the lowest, from the profile that explains the readings best
    noise = min(in_threads(lambda st: range_noise(st.fit, beams, st.grid.cell), starts, workers))

    def refit_from(st: RefitStart) -> RefitChoice:
        return choose_refit(
            st.fit, st.bins, beams, st.grid, chosen_residual=winner.residual_m,
            chosen_losses=mine, splits=choice.splits, cap=cap, seed=seed, noise=noise,
        )  # fmt: skip

    refits = in_threads(refit_from, starts, workers)
    pick = _pick_start(refits)
    refit, start = refits[pick], starts[pick].score
    choice.echo_refit = record = refit.to_json()
    record["start"] = _start_label(start)
    record["starts"] = [
        {"start": _start_label(st.score), "residual_m": rf.residual, "fit_short": rf.fit_short}
        for rf, st in zip(refits, starts, strict=True)
    ]
    if pick:
        record["reason"] = (
            f"started from {_start_label(start)}, whose refit beats the winner's by more "
            f"than {TIE_SE:g} paired standard errors; " + refit.reason
        )
    if not refit.applied or refit.fit is None or isinstance(refit.fit, FitFailure):
        return res
    if pick:
        res = run_candidate(log_, base, start)
        r = res.run
    if isinstance(refit.fit, PolyFit):
        params = replace(r.params, fit="poly", order=refit.fit.order, smooth=None)
    else:
        params = replace(r.params, fit="spline", order=None, smooth=getattr(refit.fit, "lam", None))
    bins = r.bins
    if refit.echo_span is not None:
        # The profile is reported where readings echo from it: beyond the outermost echo
        # points only the map's column means carry it, with the map's bias (centimetres
        # to a decimetre at a wave's ends); with a truth, f_c says how much that leaves.
        x0, x1 = refit.echo_span
        half = 0.5 * r.grid.cell
        outside = (bins.centres < x0 - half) | (bins.centres > x1 + half)
        bins = replace(bins, count=np.where(outside, 0, bins.count),
                       mean=np.where(outside, np.nan, bins.mean),
                       median=np.where(outside, np.nan, bins.median))  # fmt: skip
    metrics = r.metrics
    if r.truth is not None:
        metrics = measure_profile(
            params, r.grid, bins, refit.fit, truth=r.truth,
            raw_columns=np.ones(r.bins.centres.size, dtype=bool),
        )  # fmt: skip
    return replace(res, run=replace(r, params=params, fit=refit.fit, metrics=metrics, bins=bins))


def _start_label(s: Score) -> str:
    """A candidate and its setting, as the record names a refit's start."""
    return f"{s.candidate.name} ({s.candidate.describe(s.setting)['fit_short']})"

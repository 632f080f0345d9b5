"""The scores of ``--auto``'s candidates: the trimmed held-out residual and the guard rails.

A :class:`Score` gathers one candidate's held-out losses at each of its settings over
the folds; :meth:`Score.finish` picks its best setting and says why the guard rails
exclude it, if they do: a fit that leaves its points' local hull by more than
:data:`HULL_CELLS` cells, reaches less than :data:`COVERAGE_MIN` of the columns the
readings imply, or does no better than a constant or a straight line on its points.
:class:`AutoChoice` ranks the scores and writes report.json's ``auto`` record.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.auto.candidates import Candidate
from sonarproc.auto.holdout import Split
from sonarproc.fit import Fit
from sonarproc.metrics import Bins
from sonarproc.pipeline.selection import Beams

__all__ = [
    "CAP_CELLS",
    "COVERAGE_MIN",
    "CRITERION",
    "HULL_CELLS",
    "SURFACES_MAX_CELLS",
    "TRIM",
    "AutoChoice",
    "Score",
    "clustered_paired_se",
    "paired_se",
    "robust_residual",
]

#: A fit may leave its points' local hull by at most this many cells.
HULL_CELLS = 3.0
#: A reading's loss is capped at this many cells (or 5 cm, if more).
CAP_CELLS = 10.0
#: The residual is the mean of this fraction of the held-out losses, the smallest ones: a
#: trimmed mean, so echoes off other surfaces and spurious echoes (a quarter of the log at
#: most) do not decide, and neither do the few readings at the ends of the profile that one
#: candidate's fit reaches and another's does not.
TRIM = 0.75
#: A fit must reach this fraction of the columns the readings imply (the span of their
#: line-of-sight points, 5th to 95th percentile): the fit to the map of all the scored
#: readings, as for the hull (a fold's map may be too sparse to fit at all, and a failed
#: fold already costs its held-out readings the cap).
COVERAGE_MIN = 0.5
#: The ``surfaces`` candidate is scored on grids of at most this many cells: its fit
#: (one surface model per group of cells) grows with the map (a 20 m room at 1 cm, 4 M
#: cells: about 0.4 s per fold, a third of ``--auto``'s time there); above it the
#: candidate stands aside, saying so.
SURFACES_MAX_CELLS = 5_000_000
#: What report.json says the criterion is.
CRITERION = (
    "held-out range residual: firings split into {k} folds; each fold's readings predicted "
    "(first echo inside the beams, ellipse path for a pair) from the profile fitted to the "
    "other folds; mean |measured - predicted| range, capped at {cap:.3g} m (also where the "
    "curve misses the beams); the residual is the mean of the smallest {trim:.0%} of these "
    "losses; {repeats} repetition(s) of the folds"
)


def robust_residual(losses: npt.NDArray[np.float64], trim: float = TRIM) -> float:
    """Mean of the smallest ``trim`` fraction of ``losses`` (a trimmed mean).

    Examples
    --------
    >>> robust_residual(np.array([0.01, 0.02, 0.03, 0.5]))
    0.02
    """
    if losses.size == 0:
        return float("inf")
    k = max(1, int(np.ceil(trim * losses.size)))
    return float(np.partition(losses, k - 1)[:k].mean())


def paired_se(
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    *,
    trim: float = TRIM,
    resamples: int = 200,
    seed: int = 0,
) -> float:
    """Standard error of ``robust_residual(b) - robust_residual(a)``, losses paired by reading.

    ``a`` and ``b`` are two settings' losses on the *same* held-out readings; the readings
    are resampled with their pairs kept together (a bootstrap), which is far less noisy
    than either residual's own error.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a = rng.random(400) * 0.01
    >>> paired_se(a, a + 0.001) < 1e-4 < paired_se(a, rng.random(400) * 0.01)
    True
    """
    if a.shape != b.shape:
        raise ValueError(f"paired losses differ in shape: {a.shape} and {b.shape}")
    if a.size < 2:
        return float("nan")
    idx = np.random.default_rng(seed).integers(0, a.size, (resamples, a.size))
    k = max(1, int(np.ceil(trim * a.size)))
    ta = np.partition(a[idx], k - 1, axis=1)[:, :k].mean(axis=1)
    tb = np.partition(b[idx], k - 1, axis=1)[:, :k].mean(axis=1)
    return float(np.std(tb - ta, ddof=1))


def clustered_paired_se(
    a: npt.NDArray[np.float64],
    b: npt.NDArray[np.float64],
    clusters: npt.NDArray[np.intp],
    *,
    trim: float = TRIM,
    resamples: int = 200,
    seed: int = 0,
) -> float:
    """Standard error of ``robust_residual(b) - robust_residual(a)``, clusters resampled.

    As :func:`paired_se`, but whole clusters of readings (``clusters``: each reading's
    cluster, e.g. its firing) are drawn, each reading's pair of losses kept together. The
    folds hold out whole firings, and one firing's readings (every pair listening) share
    its pose and its stretch of surface: counted one by one they overstate how much the
    held-out readings know. With one reading per cluster it is :func:`paired_se`.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a = rng.random(400) * 0.01
    >>> b = a + np.repeat(rng.normal(0.0, 0.001, 20), 20)  # one shift per firing
    >>> one = clustered_paired_se(a, b, np.arange(400))
    >>> by_firing = clustered_paired_se(a, b, np.arange(400) // 20)
    >>> bool(np.isclose(one, paired_se(a, b))), bool(by_firing > 2 * one)
    (True, True)
    """
    if a.shape != b.shape or clusters.shape != a.shape:
        raise ValueError(
            f"paired losses differ in shape: {a.shape}, {b.shape} (clusters {clusters.shape})"
        )
    if a.size < 2:
        return float("nan")
    _, cl = np.unique(clusters, return_inverse=True)
    nc = int(cl.max()) + 1
    if nc < 2:
        return float("nan")
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, nc, (resamples, nc))
    counts = np.zeros((resamples, nc))
    np.add.at(counts, (np.arange(resamples)[:, None], draws), 1.0)

    def trimmed(x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        order = np.argsort(x, kind="stable")
        w = counts[:, cl[order]]
        cw = np.cumsum(w, axis=1)
        k = np.maximum(1.0, np.ceil(trim * cw[:, -1]))[:, None]
        # each draw's lowest k losses by weight: the one that crosses k in part
        take = np.clip(k - (cw - w), 0.0, w)
        return (take * x[order]).sum(axis=1) / k[:, 0]

    return float(np.std(trimmed(b) - trimmed(a), ddof=1))


@dataclass
class Score:
    """A candidate's held-out residual at each setting, its best, and the guard rails."""

    candidate: Candidate
    losses: dict[float, list[npt.NDArray[np.float64]]] = field(default_factory=dict)
    #: each setting's hull excess (m), its fit to the map of all the scored readings
    hull: dict[float, float] = field(default_factory=dict)
    #: each setting's fit to that map, and the map's points per column (the echo refit
    #: starts from a runner-up's without building its map again)
    whole_fits: dict[float, Fit] = field(default_factory=dict)
    whole_bins: Bins | None = None
    #: each setting's share of the implied columns, that fit's too
    coverage: dict[float, float] = field(default_factory=dict)
    base_losses: list[npt.NDArray[np.float64]] = field(default_factory=list)
    mean_counts: list[float] = field(default_factory=list)
    setting: float | None = None
    residual_m: float = np.inf
    baseline_m: float = np.inf
    hull_m: float = 0.0
    coverage_frac: float = 1.0
    function_folds: int = 0
    #: folds whose map was empty (their held-out readings cost the cap)
    empty_folds: int = 0
    too_large: int = 0
    excluded: str | None = None
    #: whether the guard rails' fits (hull, coverage) were judged: only the candidates
    #: ranked at the top are (:class:`sonarproc.auto.scoring.WholeGuard`)
    guarded: bool = False

    def absorb(self, fold: Score) -> None:
        """Append one fold's losses, scored on a fresh Score of the same candidate."""
        for setting, losses in fold.losses.items():
            self.losses.setdefault(setting, []).extend(losses)
        self.base_losses.extend(fold.base_losses)
        self.mean_counts.extend(fold.mean_counts)
        self.function_folds += fold.function_folds
        self.empty_folds += fold.empty_folds
        self.too_large = max(self.too_large, fold.too_large)

    def finish(self, cell: float) -> None:
        """Best setting within the hull and coverage; exclusion by the guard rails."""
        self.excluded = None
        res = {k: robust_residual(np.concatenate(v)) for k, v in self.losses.items() if v}
        self.baseline_m = (
            robust_residual(np.concatenate(self.base_losses)) if self.base_losses else np.inf
        )
        inside = {k: r for k, r in res.items() if self.hull.get(k, 0.0) <= HULL_CELLS * cell}
        covering = {k: r for k, r in inside.items() if k in self.allowed(cell)}
        if self.too_large:
            self.excluded = (
                f"not scored: the grid has {self.too_large} cells, more than "
                f"{SURFACES_MAX_CELLS} (--auto's time budget for the surfaces fit)"
            )
            return
        folds = max((len(v) for v in self.losses.values()), default=0)
        if not res or self.empty_folds >= folds:
            self.excluded = "the method left nothing on the map"
            return
        pool = covering or inside or res
        self.setting = min(pool, key=lambda k: pool[k])
        self.residual_m = pool[self.setting]
        self.hull_m = self.hull.get(self.setting, 0.0)
        self.coverage_frac = self.coverage.get(self.setting, 1.0)
        if self.function_folds:
            self.excluded = "the map is one function of x (the y(x) candidates cover it)"
        elif not inside:
            self.excluded = f"every fit leaves its points' hull (by {100 * self.hull_m:.3g} cm)"
        elif not covering:
            self.excluded = (
                f"its fit reaches {self.coverage_frac:.0%} of the columns the readings imply "
                f"(at least {COVERAGE_MIN:.0%} needed)"
            )
        elif self.residual_m > self.baseline_m + 0.25 * cell:
            self.excluded = (
                f"worse than a constant or a line on its points ({100 * self.baseline_m:.3g} cm)"
            )

    def allowed(self, cell: float) -> set[float]:
        """Settings the guard rails allow: inside the hull (the fit to all the scored
        readings' map) and covering the columns (that fit too)."""
        return {
            k for k, v in self.losses.items()
            if v and self.hull.get(k, 0.0) <= HULL_CELLS * cell
            and self.coverage.get(k, 1.0) >= COVERAGE_MIN
        }  # fmt: skip

    def to_json(self) -> dict[str, Any]:
        """JSON-ready row."""
        return {
            "name": self.candidate.name,
            **self.candidate.describe(self.setting),
            "residual_m": _finite(self.residual_m),
            "baseline_residual_m": _finite(self.baseline_m),
            "coverage": round(self.coverage_frac, 4),
            "excluded": self.excluded,
            "guard_judged": self.guarded,
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
    repeats: int = 1
    #: The chosen profile's refit through the echo points (:mod:`sonarproc.auto.echo_refit`)
    echo_refit: dict[str, Any] | None = None
    #: The chosen profile's map cells left out of its fit (:mod:`sonarproc.auto.separation`)
    left_out: dict[str, Any] | None = None
    #: Why the choice is a candidate the guard rails excluded (all of them were), if so
    fallback: str | None = None
    #: The decision's constants by name (:func:`sonarproc.auto.constants.constants_record`)
    constants: dict[str, Any] | None = None
    #: The scored readings (the echo refit is scored on the same ones and folds)
    scored: Beams | None = field(default=None, repr=False, compare=False)
    #: The folds the candidates were scored on (training mask, held-out rows of
    #: :attr:`scored`): the echo refit is scored on these very folds
    splits: list[Split] | None = field(default=None, repr=False, compare=False)
    #: Judges a candidate's guard rails when first needed (:meth:`next_ranked`)
    guard: Callable[[Score], None] | None = field(default=None, repr=False, compare=False)

    @property
    def ranked(self) -> list[Score]:
        """Eligible candidates, best first (the ones the guard rails excluded last)."""
        return sorted(self.scores, key=lambda s: (s.excluded is not None, s.residual_m))

    def next_ranked(self, tried: list[Score]) -> Score | None:
        """The best-ranked candidate not in ``tried`` with a finite residual, its guard
        rails judged (:attr:`guard`); None when none is left.

        The top of the ranking is judged until a judged candidate is on top: judging can
        only raise a candidate's residual or exclude it, so the candidates below the one
        returned need not be judged.
        """
        while True:
            left = [
                s for s in self.ranked
                if np.isfinite(s.residual_m) and not any(s is t for t in tried)
            ]  # fmt: skip
            if not left:
                return None
            top = left[0]
            if top.guarded or self.guard is None:
                return top
            self.guard(top)

    def to_json(self, chosen: Score) -> dict[str, Any]:
        """The ``auto`` record of report.json."""
        others = [s.to_json() for s in self.ranked if s is not chosen]
        return {
            "criterion": self.criterion,
            "choice": chosen.candidate.name,
            **chosen.candidate.describe(chosen.setting),
            "residual_m": _finite(chosen.residual_m),
            "folds": self.folds,
            "repeats": self.repeats,
            "readings_scored": self.readings_scored,
            "runners_up": others,
            "echo_refit": self.echo_refit,
            "profile_columns": self.left_out,
            "fallback": self.fallback,
            "constants": self.constants,
        }

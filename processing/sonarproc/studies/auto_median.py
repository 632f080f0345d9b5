"""``--auto`` as a combination of its best candidates, judged by the truth (a study).

``python -m sonarproc.studies.auto_median [--scenarios DIR] [--held NAME ...]`` simulates
each scenario, runs ``--auto`` (:func:`sonarproc.auto.run_auto`) and every candidate at
every setting (:func:`sonarproc.studies.auto_study.candidate_runs`), and compares the
truth error of

``auto``
    ``--auto`` as built: the candidate with the lowest held-out residual.
``median2``, ``median3``, ``median4``
    The pointwise median of the profiles of the top 2, 3 or 4 ranked candidates of
    distinct methods (each at its own chosen setting, each passing the guard rails and
    the hull check on every reading), over the columns all of them cover.
``wmean3``
    The mean of the top 3, each weighted by the inverse square of its held-out residual.
``median3w``, ``wmean3w``
    The same on the columns the first member's points span (``--auto``'s columns where
    it is the first), each column combining the members that reach it.

with the best candidate's error (E1 over the columns with points, as
:mod:`sonarproc.studies.methods_table` judges). Where the winner is ``surfaces`` (several
surfaces) or fewer than two candidates qualify, every variant is ``--auto``'s run.
``auto@span`` is ``--auto``'s profile judged on ``median3``'s columns (the combination
is judged on fewer columns than its members: the ends, where fits stray most, drop out).
The ``--held`` scenarios (kept out of any tuning) are summarised apart.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.auto import AutoChoice, Score, run_auto
from sonarproc.auto.holdout import hull_excess
from sonarproc.auto.hull import HULL_WINDOW_CELLS
from sonarproc.auto.score import HULL_CELLS
from sonarproc.fit import FitFailure
from sonarproc.metrics import truth_on_columns
from sonarproc.params import RunParams
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import select_beams
from sonarproc.studies.auto_rules import HELD_ASIDE as RULES_HELD_ASIDE
from sonarproc.studies.auto_rules import ratio_summary, study_main
from sonarproc.studies.auto_study import (
    Judge,
    candidate_errors,
    candidate_runs,
    simulated_scenarios,
)

__all__ = [
    "HELD_ASIDE",
    "VARIANTS",
    "MedianRow",
    "combine",
    "main",
    "members",
    "paired",
    "render",
    "run_study",
    "summary",
]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

VARIANTS = (
    "auto", "auto@span", "median2", "median3", "median4", "wmean3", "median3w", "wmean3w",
)  # fmt: skip
#: The scenarios never used to tune ``--auto`` (the rules study's).
HELD_ASIDE = RULES_HELD_ASIDE


@dataclass
class MedianRow:
    """One scenario: the best candidate and each variant's members and error (m)."""

    best: str
    best_error_m: float
    members: dict[str, str]
    errors: dict[str, float]

    def ratio(self, variant: str) -> float:
        """The variant's error over the best candidate's."""
        e = self.errors[variant]
        return e / self.best_error_m if self.best_error_m > 0 else np.inf


def _label(s: Score) -> str:
    if s.candidate.family == "surfaces" or s.setting is None:
        return s.candidate.name
    return f"{s.candidate.name}@{s.setting:g}"


def members(
    choice: AutoChoice, runs: dict[str, RunResult], k: int
) -> list[tuple[Score, RunResult]]:
    """The top ``k`` ranked candidates of distinct methods, with their runs on every reading.

    Only candidates the guard rails keep, whose fit on every reading succeeds and stays
    inside its points' hull (as :func:`sonarproc.auto.run_auto` checks the winner); none
    where the first such candidate is ``surfaces`` (several surfaces are not combined).
    """
    out: list[tuple[Score, RunResult]] = []
    methods: set[str] = set()
    for s in choice.ranked:
        if s.excluded is not None or not np.isfinite(s.residual_m):
            continue
        if s.candidate.family == "surfaces":
            if not out:
                return []
            continue
        r = runs.get(_label(s))
        if r is None or isinstance(r.fit, FitFailure) or s.candidate.method in methods:
            continue
        cell = r.grid.cell
        excess = hull_excess(
            r.fit.sample(cell), r.points_x, r.points_y, window=HULL_WINDOW_CELLS * cell
        )
        if excess > HULL_CELLS * cell:
            continue
        methods.add(s.candidate.method)
        out.append((s, r))
        if len(out) == k:
            break
    return out


def combine(
    chosen: list[tuple[Score, RunResult]], how: str = "median", span: str = "common"
) -> tuple[FloatArray, FloatArray]:
    """The combined profile ``(x, y)`` of the members ``chosen`` (best first).

    ``how``: ``"median"`` (pointwise) or ``"wmean"`` (weights 1 / residual**2).
    ``span``: ``"common"``, the columns every member's points span; or ``"first"``, the
    columns the first member's points span, each combining the members that reach it
    (the first alone where no other does).

    Examples
    --------
    >>> from sonarproc.studies.auto_median import combine
    >>> combine([])[0].size
    0
    """
    if not chosen:
        return np.empty(0), np.empty(0)
    centres = chosen[0][1].bins.centres
    reach = np.zeros((len(chosen), centres.size), dtype=bool)
    for i, (_, r) in enumerate(chosen):
        occ = np.flatnonzero(r.bins.occupied)
        reach[i, occ[0] : occ[-1] + 1] = True
    cols = reach.all(axis=0) if span == "common" else reach[0]
    x = centres[cols]
    if x.size == 0:
        return x, x
    ys = np.stack([np.asarray(r.fit(x), dtype=np.float64) for _, r in chosen])  # type: ignore[operator]
    ys[~reach[:, cols]] = np.nan
    if how == "median":
        return x, np.nanmedian(ys, axis=0)
    w = np.array([1.0 / max(s.residual_m, 1e-6) ** 2 for s, _ in chosen])[:, None]
    w = np.where(np.isfinite(ys), w, 0.0)
    return x, np.nansum(w * ys, axis=0) / w.sum(axis=0)


def _e1(log_: SonarLog, r: RunResult, x: FloatArray, y: FloatArray) -> float:
    """RMS of ``y - truth`` at columns ``x`` inside the grid (inf where nothing to judge)."""
    if log_.truth is None or x.size == 0:
        return np.inf
    t = truth_on_columns(np.asarray(log_.truth, dtype=np.float64), x)
    _, _, bottom, top = r.grid.extent
    ok = np.isfinite(t) & (t >= bottom) & (t <= top)
    if not ok.any():
        return np.inf
    return float(np.sqrt(np.mean((y[ok] - t[ok]) ** 2)))


def scenario_row(log_: SonarLog, base: RunParams) -> MedianRow:
    """Every variant's error on one log, with the best candidate's."""
    res, chosen, choice = run_auto(log_, base)
    runs = candidate_runs(log_, base)
    errors = candidate_errors(log_, base, runs)
    best = min(errors, key=lambda k: errors[k])
    auto_e = candidate_errors(log_, base, {"auto": res.run})["auto"]
    names = {"auto": _label(chosen), "auto@span": _label(chosen)}
    errs = {"auto": auto_e, "auto@span": auto_e}
    profile = Judge(log_, select_beams(log_, base)[0]).metric == "E1_m"
    for variant in VARIANTS[2:]:
        k = int(variant.rstrip("w")[-1])
        chosen_k = members(choice, runs, k) if profile else []
        if len(chosen_k) < 2:
            names[variant], errs[variant] = names["auto"], auto_e
            continue
        how = "median" if variant.startswith("median") else "wmean"
        x, y = combine(chosen_k, how, "first" if variant.endswith("w") else "common")
        names[variant] = ", ".join(_label(s) for s, _ in chosen_k)
        errs[variant] = _e1(log_, res.run, x, y)
        if variant == "median3" and not isinstance(res.run.fit, FitFailure):
            errs["auto@span"] = _e1(log_, res.run, x, np.asarray(res.run.fit(x)))
    return MedianRow(best, errors[best], names, errs)


def run_study(scenario_dir: Path, *, cell: float = 0.01) -> dict[str, MedianRow]:
    """Simulate each scenario of ``scenario_dir`` and measure every variant on it."""
    out: dict[str, MedianRow] = {}
    base = RunParams(cell=cell)
    for name, lg in simulated_scenarios(scenario_dir):
        out[name] = scenario_row(lg, base)
        log.info("%s done", name)
    return out


def summary(rows: dict[str, MedianRow], variant: str) -> str:
    """Within 1.2x of the best, the geometric mean ratio, and the 5 cm rule's breaks.

    Examples
    --------
    >>> row = MedianRow("a@0.4", 0.01, {v: "a" for v in VARIANTS}, dict.fromkeys(VARIANTS, 0.02))
    >>> summary({"s": row}, "median3")
    '0/1 within 1.2x, mean ratio 2.00, 0 above 5 cm'
    """
    return ratio_summary(
        [r.errors[variant] for r in rows.values()],
        [r.ratio(variant) for r in rows.values()],
        [r.best_error_m for r in rows.values()],
    )


def paired(rows: dict[str, MedianRow], variant: str, ref: str) -> str:
    """Geometric mean of ``variant``'s error over ``ref``'s, and how often it is lower.

    Examples
    --------
    >>> errs = dict.fromkeys(VARIANTS, 0.02) | {"median3": 0.01}
    >>> paired({"s": MedianRow("a", 0.01, {}, errs)}, "median3", "auto@span")
    'mean 0.50, lower on 1/1, higher by > 10 % on 0'
    """
    ratios = np.array(
        [r.errors[variant] / r.errors[ref] for r in rows.values() if r.errors[ref] > 0]
    )
    if ratios.size == 0:
        return "none"
    gmean = float(np.exp(np.log(np.clip(ratios, 1e-3, 1e3)).mean()))
    lower = int((ratios < 1.0).sum())
    worse = int((ratios > 1.1).sum())
    return f"mean {gmean:.2f}, lower on {lower}/{ratios.size}, higher by > 10 % on {worse}"


def render(rows: dict[str, MedianRow], held: Sequence[str] = HELD_ASIDE) -> str:
    """Markdown: each variant's error ratio per scenario, the members, then the summaries."""
    head = "| scenario | best (cm) | " + " | ".join(f"`{v}`" for v in VARIANTS) + " | median3 of |"
    lines = [head, "|---" * (len(VARIANTS) + 3) + "|"]
    for name, r in rows.items():
        cells = " | ".join(f"{r.ratio(v):.2f}" for v in VARIANTS)
        mark = " (held aside)" if name in held else ""
        lines.append(
            f"| {name}{mark} | {100 * r.best_error_m:.2f} | {cells} | {r.members['median3']} |"
        )
    groups = {
        "tuned on": {k: v for k, v in rows.items() if k not in held},
        "held aside": {k: v for k, v in rows.items() if k in held},
        "auto3 only": {k: v for k, v in rows.items() if k.startswith("auto3-")},
    }
    lines.append("")
    for v in VARIANTS:
        parts = "; ".join(f"{g}: {summary(rs, v)}" for g, rs in groups.items())
        lines.append(f"- `{v}`: {parts}")
    for v, ref in (("median3", "auto@span"), ("wmean3", "auto@span"), ("median3w", "auto"),
                   ("wmean3w", "auto")):  # fmt: skip
        parts = "; ".join(f"{g}: {paired(rs, v, ref)}" for g, rs in groups.items())
        lines.append(f"- `{v}` against `{ref}` (the same columns): {parts}")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Print the comparison of ``--auto`` with the combinations of its best candidates."""
    return study_main(
        argv, prog="sonarproc.studies.auto_median", description=__doc__, study=run_study,
        render_rows=render,
    )  # fmt: skip


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

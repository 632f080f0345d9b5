"""Cutting ``--auto``'s profile to the span its evidence supports, judged by the truth.

``python -m sonarproc.studies.auto_ends [--scenarios DIR] [--held NAME ...]`` runs
``--auto`` (:func:`sonarproc.auto.run_auto`) and every candidate on each scenario, then
cuts the winner's map to the x-span each rule of :mod:`sonarproc.studies.end_cuts` finds (no
ground truth), refits it, and judges the cut profile by the truth (E1 over its own
columns, as the methods table does). Rules:

``auto``
    As built: nothing cut.
``support:F``
    The columns whose map support is at least ``F`` of the median.
``echoes:T``
    The 1st to 99th percentile of the echo points of the readings the whole fit explains
    within ``T`` times the winner's held-out residual (every reading of the log, or a
    random subset of :data:`ECHO_READINGS`; in-sample: the fit saw them).
``ends:K``
    End slices of readings whose median residual is above the median by ``K`` MADs dropped.
``shared3``, ``agree2``
    The columns of the top three eligible candidates' maps of distinct methods: all three
    (``shared3``), or at least two (``agree2``).

Every cut keeps at least :data:`sonarproc.studies.end_cuts.COVERAGE_FLOOR` of the winner's
columns (or is not made). Each rule's row gives the ratio of its error to the best
candidate's (judged on that candidate's own columns) and the fraction of the truth's
judged columns kept (``kept``: N after / N before, the completeness cost of the cut).
Where the winner is ``surfaces`` nothing is cut.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sonarproc.auto import AutoChoice, Score, run_auto
from sonarproc.auto.holdout import range_loss
from sonarproc.auto.score import CAP_CELLS
from sonarproc.auto.select import candidate_map, evaluate_candidate
from sonarproc.metrics import Bins
from sonarproc.params import RunParams
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams
from sonarproc.studies.auto_rules import HELD_ASIDE, ratio_summary, study_main
from sonarproc.studies.auto_study import Judge, candidate_errors, candidate_runs
from sonarproc.studies.auto_study import simulated_scenarios as _scenarios
from sonarproc.studies.end_cuts import (
    EndCut,
    echo_points,
    make_cut,
    span_by_echoes,
    span_by_end_residuals,
    span_by_support,
)

__all__ = [
    "ECHO_READINGS", "RULES", "EndsRow", "cuts_for", "main", "render", "run_ends", "summary",
]  # fmt: skip

log = logging.getLogger(__name__)

RULES = (
    "auto", "support:0.25", "support:0.5", "echoes:3", "echoes:5", "ends:3", "ends:2",
    "shared3", "agree2",
)  # fmt: skip
#: The ``echoes`` and ``ends`` rules predict at most this many readings (a random subset).
ECHO_READINGS = 3_000


@dataclass(frozen=True)
class EndsRow:
    """One scenario: the best candidate by the truth and each rule's cut profile.

    ``rules[rule]`` is ``(error_m, ratio to the best, columns kept, judged columns kept)``.
    """

    choice: str
    best: str
    best_error_m: float
    rules: dict[str, tuple[float, float, float, float]]


def _top_spans(choice: AutoChoice, runs: dict[str, RunResult], n: int = 3) -> list[Bins]:
    """The column statistics of the top ``n`` eligible candidates of distinct methods."""
    out: list[Bins] = []
    seen: set[str] = set()
    for s in choice.ranked:
        if s.excluded is not None or s.candidate.method in seen or s.setting is None:
            continue
        r = runs.get(f"{s.candidate.name}@{s.setting:g}")
        if r is None:
            continue
        seen.add(s.candidate.method)
        out.append(r.bins)
        if len(out) == n:
            break
    return out


def _method_spans(spans: list[Bins], need: int) -> tuple[float, float] | None:
    """The x-span covered by the point spans of at least ``need`` of ``spans``."""
    ends = []
    for b in spans:
        occ = np.flatnonzero(b.occupied)
        if occ.size:
            ends.append((float(b.centres[occ[0]]), float(b.centres[occ[-1]])))
    if len(ends) < need:
        return None
    lo = sorted(e[0] for e in ends)[need - 1]
    hi = sorted((e[1] for e in ends), reverse=True)[need - 1]
    return (lo, hi) if lo < hi else None


def cuts_for(
    lg_run: RunResult, chosen: Score, spans: list[Bins], cm_beams: Beams, cell: float
) -> dict[str, EndCut]:
    """Every rule's cut of the winner's run (no truth used)."""
    bins = lg_run.bins
    n = cm_beams.path.size
    rng = np.random.default_rng(7)
    rows = np.sort(rng.permutation(n)[:ECHO_READINGS]).astype(np.intp)
    path, ex = echo_points(lg_run.fit, cm_beams, rows, 2 * cell)
    cap = max(CAP_CELLS * cell, 0.05)
    loss = range_loss(cm_beams.path[rows], path, cap)
    res = chosen.residual_m if np.isfinite(chosen.residual_m) else cell
    out: dict[str, EndCut] = {"auto": make_cut("auto", bins, None, "nothing cut")}
    for f in (0.25, 0.5):
        out[f"support:{f:g}"] = make_cut("support", bins, span_by_support(bins, f), "thin")
    for t in (3, 5):
        out[f"echoes:{t}"] = make_cut("echoes", bins, span_by_echoes(ex, loss, t * res, 1.0), "e")
    for k in (3, 2):
        out[f"ends:{k}"] = make_cut("ends", bins, span_by_end_residuals(ex, loss, k), "ends")
    out["shared3"] = make_cut("shared3", bins, _method_spans(spans, 3), "shared")
    out["agree2"] = make_cut("agree2", bins, _method_spans(spans, 2), "agree")
    return out


def run_ends(scenario_dir: Path, *, cell: float = 0.01) -> dict[str, EndsRow]:
    """Every rule's cut, error and ratio to the best candidate on every scenario."""
    out: dict[str, EndsRow] = {}
    base = RunParams(cell=cell)
    for name, lg in _scenarios(scenario_dir):
        res, chosen, choice = run_auto(lg, base)
        runs = candidate_runs(lg, base)
        errors = candidate_errors(lg, base, runs)
        best = min(errors, key=lambda k: errors[k])
        be = errors[best]
        cm = candidate_map(lg, base, chosen)
        judge = Judge(lg, cm.beams)
        base_e = judge.error(res.run)[0]
        label = chosen.candidate.name + (
            "" if chosen.setting is None or chosen.candidate.family == "surfaces"
            else f"@{chosen.setting:g}"
        )  # fmt: skip
        surfaces = res.run.surfaces is not None and bool(res.run.surfaces.surfaces)
        n0 = res.run.metrics.N
        rules: dict[str, tuple[float, float, float, float]] = {}
        cuts = (
            {} if surfaces else cuts_for(res.run, chosen, _top_spans(choice, runs), cm.beams, cell)
        )
        for rule in RULES:
            cut = cuts.get(rule)
            if cut is None or not cut.cuts:
                rules[rule] = (base_e, base_e / be if be > 0 else np.inf, 1.0, 1.0)
                continue
            r = evaluate_candidate(lg, cm, span=(cut.x0, cut.x1)).run
            e = judge.error(r)[0]
            rules[rule] = (e, e / be if be > 0 else np.inf, cut.fraction, r.metrics.N / max(n0, 1))
        out[name] = EndsRow(label, best, be, rules)
        log.info("%s done", name)
    return out


def summary(rows: dict[str, EndsRow], rule: str) -> str:
    """Within 1.2x of the best, the geometric mean ratio, the 5 cm rule's breaks, kept."""
    if not rows:
        return "none"
    got = [r.rules[rule] for r in rows.values()]
    text = ratio_summary([g[0] for g in got], [g[1] for g in got],
                         [r.best_error_m for r in rows.values()])  # fmt: skip
    return f"{text}, judged columns kept {float(np.mean([g[3] for g in got])):.2f}"


def render(rows: dict[str, EndsRow], held: Sequence[str] = HELD_ASIDE) -> str:
    """Markdown: each rule's ratio (and judged columns kept) per scenario, then summaries.

    The summaries split the scenarios into the tuned set, the held-aside set and the
    ``auto4-*`` scenarios written for this study.

    Examples
    --------
    >>> row = EndsRow("a@0.4", "a@0.4", 0.01, {r: (0.02, 2.0, 0.9, 0.8) for r in RULES})
    >>> print(render({"s": row}, held=()).splitlines()[2].split(" | ")[:4])
    ['| s', 'a@0.4', '1.00', '2.00 (0.80)']
    """
    head = "| scenario | `--auto` chose | best (cm) | " + " | ".join(f"`{r}`" for r in RULES)
    lines = [head + " |", "|---" * (len(RULES) + 3) + "|"]
    for name, r in rows.items():
        cells = " | ".join(f"{r.rules[k][1]:.2f} ({r.rules[k][3]:.2f})" for k in RULES)
        mark = " (held aside)" if name in held or name.startswith("auto4-") else ""
        lines.append(f"| {name}{mark} | {r.choice} | {100 * r.best_error_m:.2f} | {cells} |")
    tuned = {k: v for k, v in rows.items() if k not in held and not k.startswith("auto4-")}
    aside = {k: v for k, v in rows.items() if k in held and not k.startswith("auto4-")}
    new = {k: v for k, v in rows.items() if k.startswith("auto4-")}
    lines.append("")
    for rule in RULES:
        lines.append(
            f"- `{rule}`: tuned on: {summary(tuned, rule)}; held aside: {summary(aside, rule)}; "
            f"auto4: {summary(new, rule)}"
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    """Print the comparison of the rules for the ends of the profile."""
    return study_main(
        argv, prog="sonarproc.studies.auto_ends", description=__doc__, study=run_ends,
        render_rows=render,
    )  # fmt: skip


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

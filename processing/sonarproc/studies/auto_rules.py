"""Selection rules for ``--auto`` compared on the shipped scenarios, judged by the truth.

``python -m sonarproc.studies.auto_rules [--scenarios DIR] [--held NAME ...]`` simulates
each scenario, measures every candidate at every setting against the truth
(:func:`sonarproc.studies.auto_study.candidate_errors`) and scores the candidates
(:func:`sonarproc.auto.choose`) with each fold scheme, then prints, per rule, the
setting it picks and its error's ratio to the best candidate's:

``lowest``
    ``--auto`` as built: the lowest held-out residual, folds of whole firings at random.
``one-se``
    The same winning candidate, at the smoothest of its allowed settings whose residual
    is within one paired standard error of its best
    (:func:`sonarproc.auto.score.one_se_setting`: the largest spline smoothing length,
    the lowest polynomial order).
``time``, ``passes``
    The same winning candidate, at the setting with the lowest residual when the folds
    are contiguous time blocks, or contiguous runs of each transmitter's firings
    (:func:`sonarproc.auto.holdout.make_folds`); ``time+se``, ``passes+se``: with the
    one-standard-error rule on those folds.

The ``--held`` scenarios (kept out of any tuning) are summarised apart. The winner is the
top of :attr:`sonarproc.auto.AutoChoice.ranked`: where the guard rails exclude every
candidate, ``--auto`` itself may differ (it re-checks the hull on the whole log).
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.auto import AutoChoice, Score, choose
from sonarproc.auto.score import one_se_setting, robust_residual
from sonarproc.params import RunParams
from sonarproc.studies.auto_study import candidate_errors, simulated_scenarios
from sonarsim.shipped import shipped_dir

__all__ = [
    "HELD_ASIDE", "RULES", "RuleRow", "main", "pick", "ratio_summary", "render", "run_rules",
    "study_main",
    "summary",
]  # fmt: skip

log = logging.getLogger(__name__)

RULES = ("lowest", "one-se", "time", "time+se", "passes", "passes+se")
#: The scenarios written to check ``--auto``, each before the rule it was written for was
#: tuned (docs/methods.md says which of them later showed a rule was needed).
HELD_ASIDE = (
    "wavy-ring-walk", "auto-sparse-gentle", "auto-bistatic-sinusoid", "auto-linear-sinusoid",
    "auto2-linear-wave", "auto2-sparse-curve", "auto2-bistatic-step",
    "auto3-sparse-tilted", "auto3-ring-wavy", "auto4-pair-tilted-wave", "auto4-ring-curve",
    "auto5-linear-bump", "auto5-ring-sine", "auto5-sparse-wave",
    "auto6-linear-crest", "auto6-bistatic-wave",
    "auto7-lab-tilted", "auto7-ring-hump", "auto7-bistatic-ramps", "auto7-noisy-random",
    "auto8-noisy-ring", "auto8-noisy-linear", "auto8-noisy-bistatic",
    "auto9-lab-arch", "auto9-lab-slant", "auto10-noisy-walk", "auto10-noisy-pairs",
    "auto11-slant-gap", "auto11-ring-dent", "auto11-linear-knee",
    "auto12-sparse-crests", "auto12-sparse-noisy", "auto12-pairs-bumps",
    "auto13-pairs-ledge", "auto13-ring-bumps", "auto13-linear-dip",
    "auto14-noisy-pairs-curve", "auto14-noisy-linear-wave", "auto14-noisy-ring-walk",
    "auto15-sparse-ripple", "auto15-noisy-pairs-wave", "auto15-sparse-pairs-steps",
    "auto16-sparse-swell", "auto16-sparse-from-above", "auto16-ring-ripple",
    "auto16-pairs-crest", "auto16-noisy-sparse",
    "auto17-pairs-notch", "auto17-linear-wave", "auto17-pairs-sparse-wave", "auto17-ring-steps",
    "auto17-noisy-pairs-bumps",
    "auto18-noisy-pairs-hump", "auto18-pairs-ripples", "auto18-linear-bumps", "auto18-ring-wave",
    "auto18-sparse-noisy-dent",
    "auto19-noisy-pairs-ripple", "auto19-noisy-pairs-dents", "auto19-sparse-pairs-bump",
    "auto19-ring-noisy-wave", "auto19-linear-noisy-steps",
)  # fmt: skip


def _label(s: Score, setting: float | None) -> str:
    if s.candidate.family == "surfaces" or setting is None:
        return f"{s.candidate.name}@0"
    return f"{s.candidate.name}@{setting:g}"


def _setting(s: Score, cell: float, *, se: bool) -> float | None:
    allowed = s.allowed(cell)
    if not allowed:
        return s.setting
    losses = {k: np.concatenate(v) for k, v in s.losses.items() if v}
    if se:
        return one_se_setting(s.candidate.family, losses, allowed)
    return min(allowed, key=lambda k: robust_residual(losses[k]))


def pick(rule: str, choices: dict[str, AutoChoice], cell: float) -> str:
    """``name@setting`` the rule picks from the choices made with each fold scheme."""
    win = choices["firings"].ranked[0]
    if rule == "lowest" or win.candidate.family == "surfaces":
        return _label(win, win.setting)
    if rule == "one-se":
        return _label(win, _setting(win, cell, se=True))
    scheme, _, se = rule.partition("+")
    other = next(s for s in choices[scheme].scores if s.candidate.name == win.candidate.name)
    return _label(win, _setting(other, cell, se=bool(se)))


@dataclass(frozen=True)
class RuleRow:
    """One scenario: the best candidate by the truth, and each rule's pick.

    ``picks[rule]`` is ``(name@setting, error_m, ratio to the best)``.
    """

    best: str
    best_error_m: float
    picks: dict[str, tuple[str, float, float]]


def run_rules(scenario_dir: Path, *, cell: float = 0.01) -> dict[str, RuleRow]:
    """Every rule's pick, error and ratio to the best candidate on every scenario."""
    out: dict[str, RuleRow] = {}
    base = RunParams(cell=cell)
    for name, lg in simulated_scenarios(scenario_dir):
        errors = candidate_errors(lg, base)
        choices = {by: choose(lg, base, folds_by=by) for by in ("firings", "time", "passes")}
        best = min(errors, key=lambda k: errors[k])
        picks = {}
        for rule in RULES:
            lab = pick(rule, choices, cell)
            err = errors.get(lab, np.inf)
            picks[rule] = (lab, err, err / errors[best] if errors[best] > 0 else np.inf)
        out[name] = RuleRow(best, errors[best], picks)
        log.info("%s done", name)
    return out


def summary(rows: dict[str, RuleRow], rule: str) -> str:
    """Within 1.2x of the best, the geometric mean ratio, and the 5 cm rule's breaks."""
    picks = [r.picks[rule] for r in rows.values()]
    return ratio_summary(
        [p[1] for p in picks], [p[2] for p in picks], [r.best_error_m for r in rows.values()]
    )


def ratio_summary(
    errors: Sequence[float], ratios: Sequence[float], best_errors: Sequence[float]
) -> str:
    """How a selection fares against the best candidate over a set of scenarios.

    Parameters
    ----------
    errors, ratios, best_errors : sequence of float
        Per scenario: the selection's error (m), its ratio to the best candidate's, and
        the best candidate's error (m).

    Returns
    -------
    str
        Scenarios within 1.2x, the geometric mean ratio (each capped at 100) and the
        breaks of the 5 cm rule (above 5 cm where the best is below 3 cm).

    Examples
    --------
    >>> ratio_summary([0.02, 0.06], [1.0, 4.0], [0.02, 0.015])
    '1/2 within 1.2x, mean ratio 2.00, 1 above 5 cm'
    """
    if len(ratios) == 0:
        return "none"
    r = np.minimum(np.asarray(ratios, dtype=np.float64), 100.0)
    breaks = sum(e > 0.05 and b < 0.03 for e, b in zip(errors, best_errors, strict=True))
    gmean = float(np.exp(np.log(r).mean()))
    within = int((r <= 1.2).sum())
    return f"{within}/{r.size} within 1.2x, mean ratio {gmean:.2f}, {breaks} above 5 cm"


def render(rows: dict[str, RuleRow], held: Sequence[str] = HELD_ASIDE) -> str:
    """Markdown: each rule's pick and ratio per scenario, then the summaries (held aside apart).

    Examples
    --------
    >>> row = RuleRow("a@0.4", 0.01, {r: ("a@0.1", 0.02, 2.0) for r in RULES})
    >>> print(render({"s": row}, held=()).splitlines()[2])
    | s | 1.00 | a@0.1 2.00 | a@0.1 2.00 | a@0.1 2.00 | a@0.1 2.00 | a@0.1 2.00 | a@0.1 2.00 |
    """
    head = "| scenario | best (cm) | " + " | ".join(f"`{r}`" for r in RULES) + " |"
    lines = [head, "|---" * (len(RULES) + 2) + "|"]
    for name, r in rows.items():
        cells = " | ".join(f"{r.picks[rule][0]} {r.picks[rule][2]:.2f}" for rule in RULES)
        mark = " (held aside)" if name in held else ""
        lines.append(f"| {name}{mark} | {100 * r.best_error_m:.2f} | {cells} |")
    tuned = {k: v for k, v in rows.items() if k not in held}
    aside = {k: v for k, v in rows.items() if k in held}
    lines.append("")
    for rule in RULES:
        lines.append(
            f"- `{rule}`: tuned on: {summary(tuned, rule)}; held aside: {summary(aside, rule)}"
        )
    return "\n".join(lines) + "\n"


def study_main(
    argv: Sequence[str] | None,
    *,
    prog: str,
    description: str | None,
    study: Callable[[Path], Any],
    render_rows: Callable[[Any, Sequence[str]], str],
) -> int:
    """The command line of a study over the scenarios with some kept aside (exit 0 or 2)."""
    ap = argparse.ArgumentParser(prog=f"python -m {prog}", description=description)
    ap.add_argument("--scenarios", type=Path, default=shipped_dir("scenarios"))
    ap.add_argument("--held", nargs="*", default=list(HELD_ASIDE), help="scenarios kept aside")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if not args.scenarios.is_dir():
        print(f"{prog}: error: --scenarios: no such folder {args.scenarios}", file=sys.stderr)
        return 2
    sys.stdout.write(render_rows(study(args.scenarios), args.held))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Print the comparison of the selection rules."""
    return study_main(
        argv, prog="sonarproc.studies.auto_rules", description=__doc__, study=run_rules,
        render_rows=render,
    )  # fmt: skip


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The per-figure tables: the paper's method with its n and m, and our automatic method.

:func:`run_paper` and :func:`run_auto` run one simulated log; :func:`paper_section` and
:func:`auto_section` render the two tables of ``docs/reproduction.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from sonarmorph_tools.reproduction.outcome import AutoOutcome, Outcome, fmt, pair, table_row
from sonarmorph_tools.reproduction.paper import AUTO, PaperRow, sigma_paper_cm
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, run_file

__all__ = [
    "HEAD",
    "auto_section",
    "paper_row_cells",
    "paper_section",
    "run_auto",
    "run_paper",
]

#: Header of a table of paper-method rows; ``{first}`` names the first column.
HEAD = (
    "| {first} | operations | m | e (paper / ours) | f_c | E1 cm | E2 | t_CPU s | readings "
    "| ours: E1 cm in the points' span |\n|---|---|---|---|---|---|---|---|---|---|"
)

_AUTO_INTRO = (
    "Our automatic method, the same logs, nothing taken from the truth or the paper: "
    "`sonarproc run LOG --ops vote:auto,ridge --robust huber --order auto --span points`. "
    "`vote:auto` keeps the cells crossed by at least K arcs, K = max(2, ceil(0.25 q90)) "
    "with q90 the 90th percentile of the per-column largest count; `ridge` keeps in each "
    "column the cells with at least half that column's largest count; the polynomial is a "
    "Huber IRLS fit over those cells weighted by their counts, its order m (0-15) chosen "
    "by 5-fold cross-validation over columns. e, f_c, E1 and E2 are over the columns "
    "between the first and last with points (`--span points`); the column *E1 whole* is "
    "the same fit judged like the paper's, over every column the truth spans in the map, "
    "extrapolating where no sonar saw the surface. sigma_y: the paper's (E1 / E2 of its "
    "figure) / ours (the simulated truth over the columns judged)."
)

_AUTO_HEAD = (
    "| scenario (paper figure) | K | m (CV) | e (paper / auto) | f_c | E1 cm | E2 "
    "| E1 whole cm | sigma_y cm | t_CPU s |\n|---|---|---|---|---|---|---|---|---|---|"
)


def run_paper(logpath: Path, paper: PaperRow, *, cell: float) -> tuple[RunResult, Outcome]:
    """The paper's operations and order on a log; the run and our numbers (with E1 in span)."""
    params = RunParams(cell=cell, ops=paper.ops, order=paper.order)
    result = run_file(logpath, params)
    in_span = run_file(logpath, replace(params, span="points"))
    return result, Outcome.of(result, in_span)


def run_auto(logpath: Path, paper: PaperRow, *, cell: float) -> tuple[RunResult, AutoOutcome]:
    """Our automatic method (:data:`AUTO`) on a log; the run and what it chose and scored."""
    from sonarproc.morphology import auto_vote_threshold

    auto = run_file(logpath, RunParams(cell=cell, **AUTO))  # type: ignore[arg-type]
    whole = run_file(logpath, RunParams(cell=cell, **{**AUTO, "span": "truth"}))  # type: ignore[arg-type]
    sig = auto.metrics.sigma_y_m
    return auto, AutoOutcome(
        k=auto_vote_threshold(auto.counts_map),
        order=auto.fit.order,
        ours=Outcome.of(auto),
        E1_whole_cm=None if whole.metrics.E1_m is None else 100 * whole.metrics.E1_m,
        sigma_paper_cm=sigma_paper_cm(paper),
        sigma_ours_cm=None if sig is None else 100 * sig,
    )


def paper_row_cells(label: str, p: PaperRow, o: Outcome) -> str:
    """One row of a paper-method table (:data:`HEAD`)."""
    return table_row(
        [
            label,
            f"`{p.ops}`",
            str(p.order),
            pair(p.e, o.e),
            pair(p.f_c, o.f_c),
            pair(p.E1_cm, o.E1_cm, 2),
            pair(p.E2, o.E2),
            pair(p.t_cpu_s, o.t_cpu_s, 2),
            str(o.readings),
            fmt(o.E1_span_cm, 2),
        ]
    )


def paper_section(scenarios: Sequence[tuple[str, PaperRow, Outcome, str]]) -> list[str]:
    """The first table: every scenario with the paper's n and m, then the notes."""
    lines = [
        "## Per-figure results: the paper's method with the paper's n and m",
        "",
        HEAD.format(first="scenario (paper figure)"),
    ]
    lines += [paper_row_cells(f"{name} ({p.figure})", p, o) for name, p, o, _ in scenarios]
    notes = [(n, p.note) for n, p, _, _ in scenarios if p.note]
    if notes:
        lines += ["", "Notes: " + "; ".join(f"{n}: {t}" for n, t in notes) + "."]
    return lines


def _auto_cells(name: str, p: PaperRow, a: AutoOutcome) -> str:
    o = a.ours
    return table_row(
        [
            f"{name} ({p.figure})",
            str(a.k),
            "—" if a.order is None else str(a.order),
            pair(p.e, o.e),
            pair(p.f_c, o.f_c),
            pair(p.E1_cm, o.E1_cm, 2),
            pair(p.E2, o.E2),
            fmt(a.E1_whole_cm, 2),
            pair(a.sigma_paper_cm, a.sigma_ours_cm, 1),
            fmt(o.t_cpu_s, 2),
        ]
    )


def auto_section(auto: Sequence[tuple[str, PaperRow, AutoOutcome]]) -> list[str]:
    """The second table: our automatic method on the same logs."""
    if not auto:
        return []
    lines = ["", "## Per-figure results: our automatic method (no ground truth)", ""]
    lines += [_AUTO_INTRO, "", _AUTO_HEAD]
    return lines + [_auto_cells(n, p, a) for n, p, a in auto]

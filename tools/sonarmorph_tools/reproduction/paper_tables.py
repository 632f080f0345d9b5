"""The paper's Table 1 (the Fig. 2 map) and Table 2 (the Fig. 18 surface), every operation.

:func:`run_table` runs every row's operations on a log; :func:`table_section` renders it
with one sentence on the thinning sweep (:func:`trend`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from sonarmorph_tools.reproduction.figures import HEAD, paper_row_cells, run_paper
from sonarmorph_tools.reproduction.outcome import Outcome
from sonarmorph_tools.reproduction.paper import PaperRow

__all__ = ["run_table", "table_section", "trend"]


def run_table(
    logpath: Path, study: Sequence[PaperRow], *, cell: float
) -> list[tuple[PaperRow, Outcome]]:
    """Every row of a paper table run on one log: (the paper's row, our numbers)."""
    return [(p, run_paper(logpath, p, cell=cell)[1]) for p in study]


def trend(rows: Sequence[tuple[PaperRow, Outcome]]) -> str:
    """One sentence on the thinning sweep n = 1..8 (the study trend of Table 1)."""
    sweep = [(int(p.ops.split(":")[1]), o) for p, o in rows if p.ops.startswith("thinning:")]
    if len(sweep) < 3:
        return ""
    e = [(n, o.e) for n, o in sweep if o.e is not None]
    e1 = [(n, o.E1_cm) for n, o in sweep if o.E1_cm is not None]
    text = (
        f"Thinning sweep (ours): f_c falls from {sweep[0][1].f_c:.3f} (n = {sweep[0][0]}) to "
        f"{sweep[-1][1].f_c:.3f} (n = {sweep[-1][0]})"
    )
    if len(e) >= 2:
        text += f"; e from {e[0][1]:.3f} to {e[-1][1]:.3f}"
    if e1:
        best = min(e1, key=lambda t: t[1])
        text += f"; E1 is lowest at n = {best[0]} ({best[1]:.2f} cm)"
    return text + "."


def table_section(title: str, rows: Sequence[tuple[PaperRow, Outcome]]) -> list[str]:
    """One paper table: every operation, paper / ours, and the sweep's trend."""
    lines = ["", f"## {title}", "", HEAD.format(first="operation")]
    lines += [paper_row_cells(p.figure, p, o) for p, o in rows]
    return [*lines, "", trend(rows)]

"""Paper-style sampled arcs: the paper's method with arcs drawn as samples every S degrees.

:func:`sampled_runs` runs one log at every step of
:data:`~sonarmorph_tools.reproduction.paper.ARC_STEPS_DEG`; :func:`sampled_section`
renders every scenario and Table 1's sweep beside our connected arcs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from sonarmorph_tools.reproduction.outcome import Outcome, fmt, series, table_row
from sonarmorph_tools.reproduction.paper import PaperRow
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, run_file

__all__ = ["SampledRow", "binary_cells", "sampled_runs", "sampled_section"]


@dataclass(frozen=True)
class SampledRow:
    """One run of the sampled-arcs study: the paper's row, ours connected, ours sampled.

    ``sampled`` holds one outcome per step of :data:`ARC_STEPS_DEG` (same order);
    ``cells`` the binary map's cells (count >= 1): connected first, then each step.
    """

    label: str
    paper: PaperRow
    connected: Outcome
    sampled: tuple[Outcome, ...]
    cells: tuple[int, ...] = ()


def binary_cells(r: RunResult) -> int:
    """Cells of a run's binary arc map (count >= 1)."""
    return int(r.counts["map_cells_set"])


def sampled_runs(
    logpath: Path, params: RunParams, steps: Sequence[float]
) -> tuple[tuple[Outcome, ...], tuple[int, ...]]:
    """The paper's method with arcs sampled every step (deg): outcomes and binary cells."""
    results = [run_file(logpath, replace(params, arc_step=math.radians(s))) for s in steps]
    return tuple(Outcome.of(r) for r in results), tuple(binary_cells(r) for r in results)


def _row(r: SampledRow, *, with_cells: bool) -> str:
    runs = (r.connected, *r.sampled)
    cells = [
        r.label,
        f"`{r.paper.ops}`",
        str(r.paper.order),
        series(r.paper.e, [o.e for o in runs]),
        series(r.paper.f_c, [o.f_c for o in runs]),
        series(r.paper.E1_cm, [o.E1_cm for o in runs], 2),
    ]
    if with_cells:
        cells.append(" / ".join(str(c) for c in r.cells))
    return table_row(cells)


def _steps_text(steps: Sequence[float]) -> str:
    return " / ".join(f"{s:g}°" for s in steps)


def sampled_section(
    rows: Sequence[SampledRow], table1: Sequence[SampledRow], steps: Sequence[float]
) -> list[str]:
    """The paper-style sampled arcs section: every scenario, then Table 1's sweep."""
    order = f"paper / connected / {_steps_text(steps)}"
    head = (
        f"| {{first}} | operations | m | e ({order}) | f_c | E1 cm |{{extra}}\n"
        f"|---|---|---|---|---|---|{{rule}}"
    )
    lines = [
        "",
        f"## Paper-style sampled arcs, steps {_steps_text(steps)}",
        "",
        "The paper's method (its n and m, as in the first table) on the same logs, with each "
        "arc drawn as separate samples every S degrees of eccentric anomaly (the polar angle "
        "about the sensor for a circle), one cell per sample (`sonarproc run --arc-step S`), "
        "instead of our gap-free 8-connected chains (the default, so no arc has holes). Each cell: "
        f"*{order}*; '—' where the paper reports nothing or nothing is left to fit. The "
        "last column counts the cells of the binary arc map (count >= 1), connected / "
        f"{_steps_text(steps)}: the sparser the map, the more thinning removes.",
        "",
        head.format(first="scenario (paper figure)", extra=" binary map cells |", rule="---|"),
    ]
    lines += [_row(r, with_cells=True) for r in rows]
    if table1:
        lines += [
            "",
            "Table 1 (scenario fig02, m = 9) with sampled arcs:",
            "",
            head.format(first="operation", extra="", rule=""),
        ]
        lines += [_row(r, with_cells=False) for r in table1]
        lines += ["", _trend(table1, steps)]
    return lines


def _trend(table1: Sequence[SampledRow], steps: Sequence[float]) -> str:
    """f_c after pruning and after erosion (n = 1 and n = 8): paper, connected, each step."""
    by_ops = {r.paper.ops: r for r in table1}
    n1, n8 = by_ops.get("thinning:1"), by_ops.get("thinning:8")
    if n1 is None or n8 is None:
        return ""
    parts = [
        f"{name} {a.f_c:.3f} -> {b.f_c:.3f}"
        for name, a, b in zip(
            ["connected", *(f"{s:g}°" for s in steps)],
            (n1.connected, *n1.sampled),
            (n8.connected, *n8.sampled),
            strict=True,
        )
    ]
    return (
        f"f_c from pruning (n = 1) to erosion (n = 8): paper {fmt(n1.paper.f_c)} -> "
        f"{fmt(n8.paper.f_c)}; " + "; ".join(parts) + "."
    )

"""Our numbers for one run, and the markdown cell formats every table of the study shares."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from sonarmorph_tools.reproduction.paper import PaperRow
from sonarproc.pipeline import RunResult

__all__ = ["AutoOutcome", "Outcome", "fmt", "outcome_line", "pair", "series", "table_row"]


@dataclass(frozen=True)
class Outcome:
    """Our numbers for one run."""

    e: float | None
    f_c: float
    E1_cm: float | None
    E2: float | None
    t_cpu_s: float
    readings: int
    fit_ok: bool
    #: E1 over the columns between the first and last with points (``--span points``).
    E1_span_cm: float | None = None

    @classmethod
    def of(cls, r: RunResult, span: RunResult | None = None) -> Outcome:
        """Our numbers from a run (and, optionally, the same run judged over its points)."""
        m = r.metrics
        e1_span = None if span is None or span.metrics.E1_m is None else 100 * span.metrics.E1_m
        return cls(
            m.e,
            m.f_c,
            None if m.E1_m is None else 100.0 * m.E1_m,
            m.E2,
            r.t_cpu_s,
            r.counts["readings_used"],
            r.fit.ok,
            e1_span,
        )


@dataclass(frozen=True)
class AutoOutcome:
    """Our automatic method on one scenario: the choices it made and its numbers."""

    k: int
    order: int | None
    ours: Outcome
    E1_whole_cm: float | None
    sigma_paper_cm: float | None
    sigma_ours_cm: float | None


def fmt(v: float | None, digits: int = 3) -> str:
    """One table cell: ``—`` for nothing, whole numbers from 1000 on.

    Examples
    --------
    >>> fmt(None), fmt(0.12345), fmt(2.5, 2), fmt(1915.45)
    ('—', '0.123', '2.50', '1915')
    """
    if v is None:
        return "—"
    if abs(v) >= 1000:
        return f"{v:.0f}"
    return f"{v:.{digits}f}"


def pair(paper: float | None, ours: float | None, digits: int = 3) -> str:
    """A *paper / ours* cell.

    Examples
    --------
    >>> pair(0.052, None)
    '0.052 / —'
    """
    return f"{fmt(paper, digits)} / {fmt(ours, digits)}"


def series(paper: float | None, ours: Sequence[float | None], digits: int = 3) -> str:
    """A *paper / ours / ours / ...* cell."""
    return " / ".join(fmt(v, digits) for v in (paper, *ours))


def table_row(cells: Sequence[str]) -> str:
    """One markdown table row.

    Examples
    --------
    >>> table_row(["a", "b"])
    '| a | b |'
    """
    return "| " + " | ".join(cells) + " |"


def outcome_line(name: str, paper: PaperRow, ours: Outcome) -> str:
    """One human line for a scenario: our E1 (cm) beside the paper's, e and f_c.

    Examples
    --------
    >>> outcome_line("fig12", PaperRow("Fig. 12", "thinning:3", 9, E1_cm=3.59),
    ...              Outcome(0.5, 1.0, 3.3, 0.9, 0.2, 100, True))
    'fig12 (Fig. 12): E1 3.30 cm (paper 3.59 cm), e 0.500, f_c 1.00'
    """
    from sonarproc.report.units import MISSING, number, sig3

    e1 = MISSING if ours.E1_cm is None else f"{sig3(ours.E1_cm)} cm"
    theirs = "" if paper.E1_cm is None else f" (paper {sig3(paper.E1_cm)} cm)"
    return f"{name} ({paper.figure}): E1 {e1}{theirs}, e {number(ours.e)}, f_c {number(ours.f_c)}"

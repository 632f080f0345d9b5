"""The terminal view of the ``--auto`` record.

The record (:meth:`sonarproc.auto.AutoChoice.to_json`) holds the criterion, the choice
(method, options, fit), its held-out residual and the runners-up with theirs (and why
the guard rails excluded any). The report writers put it into ``report.json`` /
``compare.json`` as ``auto`` and show it in the HTML pages
(:mod:`sonarproc.report.auto_record`); :func:`record_table` is its table for the terminal,
with a last row for the chosen profile's refit through the echo points.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["chosen_note", "record_table", "refit_row", "refit_summary"]


def _cm(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.3g} cm"


def refit_summary(refit: Mapping[str, Any]) -> tuple[str, float | None]:
    """The echo refit's fit in a few words and its held-out residual (m).

    Records written before the tied lengths were averaged have neither ``fit_short`` nor
    ``residual_m``: their refit is the one length's spline.

    Examples
    --------
    >>> refit_summary({"smoothing_length_m": 0.4, "residuals_m": {"0.4": 0.002}})
    ('spline L=0.4 m', 0.002)
    >>> refit_summary({"smoothing_length_m": 0.2, "fit_short": "mean of splines L=0.2, 0.4 m",
    ...                "residual_m": 0.001, "residuals_m": {}})
    ('mean of splines L=0.2, 0.4 m', 0.001)
    """
    length = refit.get("smoothing_length_m")
    fit_short = refit.get("fit_short") or f"spline L={length:g} m"
    residual = refit.get("residual_m")
    if residual is None and length is not None:
        residual = refit.get("residuals_m", {}).get(f"{length:g}")
    return str(fit_short), residual


def refit_row(record: Mapping[str, Any]) -> tuple[str, float | None, str] | None:
    """The echo refit's row of the record's tables: its fit, residual (m) and a note that
    says whether it was applied and why; None when no refit was tried.

    Examples
    --------
    >>> refit_row({"echo_refit": {"smoothing_length_m": 0.4, "residuals_m": {"0.4": 0.002},
    ...                           "applied": True, "reason": "it beats the candidate"}})
    ('spline L=0.4 m', 0.002, 'applied: it beats the candidate')
    >>> refit_row({"echo_refit": {"smoothing_length_m": None}}) is None
    True
    >>> refit_row({"echo_refit": {"smoothing_length_m": None, "fit_short": "poly m=6",
    ...                           "residual_m": 0.003, "applied": False, "reason": "worse"}})
    ('poly m=6', 0.003, 'not applied: worse')
    """
    refit = record.get("echo_refit")
    if not refit or refit.get("fit_short", refit.get("smoothing_length_m")) is None:
        return None
    fit_short, residual = refit_summary(refit)
    note = ("applied: " if refit["applied"] else "not applied: ") + str(refit["reason"])
    return fit_short, residual, note


def chosen_note(record: Mapping[str, Any]) -> str:
    """The chosen row's note: ``chosen``, and the map cells its profile left out, if any.

    Examples
    --------
    >>> chosen_note({"profile_columns": {"cells_left_out": 406, "cells": 849}})
    'chosen; 406 of its 849 map cells left out of the profile (stray clusters)'
    >>> chosen_note({"profile_columns": None})
    'chosen'
    >>> chosen_note({"fallback": "every candidate was excluded (hull)"})
    'chosen: every candidate was excluded (hull)'
    """
    note = "chosen"
    if record.get("fallback"):
        note += f": {record['fallback']}"
    sep = record.get("profile_columns")
    if not sep or not sep.get("cells_left_out"):
        return note
    return (
        f"{note}; {sep['cells_left_out']} of its {sep['cells']} map cells left out of the "
        "profile (stray clusters)"
    )


def record_table(record: dict[str, Any]) -> Any:
    """A rich Table: the choice and each runner-up, with held-out residuals."""
    from rich.table import Table

    reps = record.get("repeats", 1)
    title = f"--auto: held-out range residual, {record['folds']} folds of firings" + (
        f" x {reps}" if reps > 1 else ""
    )
    table = Table(title=title, title_justify="left")
    # the names, fits and residuals keep their width; the notes (why a candidate was
    # excluded, what the refit did) wrap, so the table fits a terminal of 80 columns
    table.add_column("candidate", no_wrap=True)
    table.add_column("fit", no_wrap=True)
    table.add_column("residual", justify="right", no_wrap=True)
    table.add_column("note", overflow="fold")
    table.add_row(
        f"[bold]{record['choice']}[/bold]", record["fit_short"], _cm(record["residual_m"]),
        chosen_note(record),
    )  # fmt: skip
    for r in record["runners_up"]:
        table.add_row(r["name"], r["fit_short"], _cm(r["residual_m"]), r["excluded"] or "")
    row = refit_row(record)
    if row is not None:
        fit_short, residual, note = row
        table.add_row("echo refit", fit_short, _cm(residual), note)
    return table

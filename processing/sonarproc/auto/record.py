"""What ``--auto`` adds to a report: the ``auto`` record in a JSON file, and a table.

The record (:meth:`sonarproc.auto.AutoChoice.to_json`) holds the criterion, the choice
(method, options, fit), its held-out residual and the runners-up with theirs (and why
the guard rails excluded any). :func:`add_record` puts it into an already written
``report.json`` or ``compare.json`` (rewritten atomically); :func:`record_table` is the
terminal view of it.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

__all__ = ["add_record", "record_table"]


def add_record(path: str | Path, doc: dict[str, Any], record: dict[str, Any]) -> dict[str, Any]:
    """``doc`` with ``doc["auto"] = record``, written to ``path`` (atomic replace)."""
    doc = {**doc, "auto": record}
    target = Path(path)
    tmp = target.with_name(target.name + ".tmp")
    tmp.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, target)
    return doc


def _cm(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.3g} cm"


def record_table(record: dict[str, Any]) -> Any:
    """A rich Table: the choice and each runner-up, with held-out residuals."""
    from rich.table import Table

    title = f"--auto: held-out range residual, {record['folds']} folds of firings"
    table = Table(title=title, title_justify="left")
    for col in ("candidate", "fit", "residual", "note"):
        table.add_column(col, justify="right" if col == "residual" else "left", no_wrap=True)
    table.add_row(
        f"[bold]{record['choice']}[/bold]", record["fit_short"], _cm(record["residual_m"]),
        "chosen",
    )  # fmt: skip
    for r in record["runners_up"]:
        table.add_row(r["name"], r["fit_short"], _cm(r["residual_m"]), r["excluded"] or "")
    return table

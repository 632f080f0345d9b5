"""The summary of a batch: one row per log, ``summary.csv`` and ``summary.jsonl``.

A row is a digest of the log's ``report.json`` (counts, fit, metrics, quality), or of
why there is none (``status`` ``error`` and the one-line ``error``). Timings are left
out (each report keeps its own ``t_cpu_s``), so the same logs with the same options give
the same summary byte for byte, whichever engine ran them.
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sonarproc.report.jsonable import to_jsonable

__all__ = ["SUMMARY_COLUMNS", "error_row", "summary_row", "write_summary"]

#: Columns of the summary, in order.
SUMMARY_COLUMNS = (
    "index",
    "log",
    "report",
    "status",
    "error",
    "log_state",
    "readings_total",
    "readings_used",
    "processed_cells",
    "fit",
    "fit_ok",
    "surfaces",
    "e",
    "f_c",
    "E1_m",
    "E2",
    "precision_m",
    "completeness",
    "N",
    "N_k",
    "quality",
)


def _blank(index: int, log: str, report: str) -> dict[str, Any]:
    row: dict[str, Any] = dict.fromkeys(SUMMARY_COLUMNS)
    row.update(index=index, log=log, report=report)
    return row


def summary_row(index: int, log: str, report: str, doc: dict[str, Any]) -> dict[str, Any]:
    """The row of a log from its ``report.json`` content ``doc``.

    ``quality`` is the report's truth-free quality record where the run has one (a
    dict, written as JSON text in the CSV), else empty.

    Examples
    --------
    >>> doc = {"log_state": "closed", "counts": {"readings_total": 9, "readings_used": 8,
    ...        "processed_cells": 5}, "fit": {"kind": "poly", "ok": True},
    ...        "metrics": {"e": 0.5, "f_c": 1.0, "N": 5, "N_k": 5, "t_cpu_s": 0.1}}
    >>> r = summary_row(0, "a.h5", "a", doc)
    >>> r["status"], r["fit"], r["readings_used"], r["E1_m"], "t_cpu_s" in r
    ('ok', 'poly', 8, None, False)
    """
    row = _blank(index, log, report)
    counts, fit, metrics = doc.get("counts", {}), doc.get("fit", {}), doc.get("metrics", {})
    row.update(
        status="ok",
        log_state=doc.get("log_state"),
        readings_total=counts.get("readings_total"),
        readings_used=counts.get("readings_used"),
        processed_cells=counts.get("processed_cells"),
        fit=fit.get("kind"),
        fit_ok=bool(fit.get("ok")),
        surfaces=fit.get("surfaces"),
        quality=doc.get("quality"),
    )
    for key in ("e", "f_c", "E1_m", "E2", "precision_m", "completeness", "N", "N_k"):
        row[key] = metrics.get(key)
    return dict(to_jsonable(row))


def error_row(index: int, log: str, error: str) -> dict[str, Any]:
    """The row of a log that gave no report: ``status`` ``error`` and why, on one line."""
    row = _blank(index, log, "")
    row.update(status="error", error=" ".join(error.split()))
    return row


def _csv_value(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (dict, list)):
        return json.dumps(v, sort_keys=True)
    return str(v)


def _replace_atomically(path: Path, text: str) -> None:
    """Write ``path`` whole or not at all: a temporary file beside it, then a rename."""
    tmp = path.with_name(f".{path.name}.partial")
    try:
        tmp.write_text(text, encoding="utf-8", newline="")
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_summary(rows: Sequence[dict[str, Any]], out_dir: Path) -> tuple[Path, Path]:
    """Write ``summary.csv`` and ``summary.jsonl`` (:data:`SUMMARY_COLUMNS`) into ``out_dir``.

    Each file is complete or absent: written beside its name and renamed over it.
    """
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(SUMMARY_COLUMNS)
    for r in rows:
        w.writerow([_csv_value(r.get(k)) for k in SUMMARY_COLUMNS])
    lines = "".join(json.dumps({k: r.get(k) for k in SUMMARY_COLUMNS}) + "\n" for r in rows)
    csv_path, jsonl_path = out_dir / "summary.csv", out_dir / "summary.jsonl"
    _replace_atomically(csv_path, buf.getvalue())
    _replace_atomically(jsonl_path, lines)
    return csv_path, jsonl_path

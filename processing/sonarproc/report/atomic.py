"""A report directory rewritten while someone may be reading it.

Each file is written under a temporary directory beside the report and moved over the
old one with ``os.replace``, ``report.json`` last, so a reader never sees half a file and
a reader that polls ``report.json`` sees the other files of that update already.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sonarproc.pipeline.result import RunResult
from sonarproc.report.run_report import DEFAULT_FIGURES

__all__ = ["write_report_atomic"]


def write_report_atomic(
    result: RunResult,
    out_dir: Path,
    *,
    live: dict[str, Any],
    refresh_s: float | None,
    figures: Sequence[str] = DEFAULT_FIGURES,
) -> dict[str, Any]:
    """Write a report directory with atomic per-file replacement.

    Parameters
    ----------
    result : RunResult
        The snapshot to report.
    out_dir : Path
        Report directory (created).
    live : dict
        Added to ``report.json`` as ``live`` (updates, readings seen, writer state).
    refresh_s : float or None
        ``report.html`` reloads itself after this many seconds; None: no reload.
    figures : sequence of str
        Figure formats (``png``, ``svg``); empty: no figures.

    Returns
    -------
    dict
        The ``report.json`` content.
    """
    from sonarproc.report.run_report import write_report

    out_dir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".watch-", dir=out_dir))
    try:
        doc = write_report(result, tmp, figures=figures)
        doc["live"] = live
        (tmp / "report.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
        if refresh_s is not None:
            page = (tmp / "report.html").read_text(encoding="utf-8")
            meta = f'<meta http-equiv="refresh" content="{max(1, round(refresh_s))}">'
            page = page.replace("<head>", "<head>" + meta, 1)
            (tmp / "report.html").write_text(page, encoding="utf-8")
        # report.json last: a reader that polls it sees the other files of that update
        for name in sorted(os.listdir(tmp), key=lambda n: (n == "report.json", n)):
            os.replace(tmp / name, out_dir / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return doc

"""The ``--auto`` record on a report page: criterion, choice, residual and runners-up.

``report.json`` and ``compare.json`` carry the record as ``auto``
(:meth:`sonarproc.auto.AutoChoice.to_json`); :func:`auto_record_html` is its section of
``report.html`` and ``compare.html``.
"""

from __future__ import annotations

import html
from collections.abc import Mapping
from typing import Any

from sonarproc.report.units import MISSING, length_cm

__all__ = ["auto_record_html"]


def _cm(v: Any) -> str:
    return MISSING if not isinstance(v, (int, float)) else length_cm(float(v))


def auto_record_html(record: Mapping[str, Any]) -> str:
    """An HTML section: the criterion, the choice with its residual, the runners-up table.

    The chosen profile's refit through the echo points, when tried, is the table's last row.

    Examples
    --------
    >>> rec = {"criterion": "held-out", "choice": "a", "fit_short": "poly m=2",
    ...        "residual_m": 0.004, "folds": 4, "runners_up": [
    ...        {"name": "b", "fit_short": "spline", "residual_m": None, "excluded": "hull"}]}
    >>> page = auto_record_html(rec)
    >>> "0.400 cm" in page and "<td>b</td>" in page and "hull" in page
    True
    """
    # imported here: a report without an --auto record need not load the --auto machinery
    from sonarproc.auto.record import chosen_note, refit_row

    rows = [
        (f"<b>{html.escape(str(record['choice']))}</b>", record.get("fit_short"),
         record.get("residual_m"), chosen_note(record)),
    ] + [
        (html.escape(str(r["name"])), r.get("fit_short"), r.get("residual_m"),
         r.get("excluded") or "")
        for r in record.get("runners_up", [])
    ]  # fmt: skip
    refit = refit_row(record)
    if refit is not None:
        rows.append(("echo refit", *refit))
    body = "".join(
        f"<tr><td>{name}</td><td>{html.escape(str(fit or ''))}</td>"
        f"<td>{html.escape(_cm(res))}</td><td>{html.escape(str(note))}</td></tr>"
        for name, fit, res, note in rows
    )
    return (
        "<h2>--auto: the choice without ground truth</h2>"
        f"<p>Criterion: {html.escape(str(record['criterion']))}.</p>"
        f"<p>Chosen: <b>{html.escape(str(record['choice']))}</b> "
        f"({html.escape(str(record.get('fit_short', '')))}), held-out residual "
        f"{html.escape(_cm(record.get('residual_m')))}.</p>"
        "<table><tr><th>candidate</th><th>fit</th><th>residual</th><th>note</th></tr>"
        f"{body}</table>"
    )

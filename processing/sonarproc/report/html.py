"""A self-contained ``report.html``: the figures as data URIs, parameters, counts, fit and
metrics tables. No scripts, no external resources; any browser or none (the tables read
fine as text). The PNGs are embedded; a report with SVG figures only embeds those, and a
report without figures (``--figures none``) says so instead of showing broken images."""

from __future__ import annotations

import base64
import html
import json
from collections.abc import Mapping, Sequence
from typing import Any

from sonarproc.report.auto_record import auto_record_html
from sonarproc.report.units import MISSING, length_cm, metric, number, seconds

__all__ = ["alignment_section", "quality_section", "render_html", "surfaces_table"]

_STEMS = ("arcmap", "processed", "fit", "alignment")
_MIME = {"png": "image/png", "svg": "image/svg+xml"}

_CSS = """
body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1100px;color:#222}
h1{font-size:1.4em}h2{font-size:1.1em;margin-top:1.6em}
table{border-collapse:collapse;margin:.4em 0}
td,th{border:1px solid #ccc;padding:.25em .7em;text-align:left;font-variant-numeric:tabular-nums}
th{background:#f3f3f3}.fail{color:#b00;font-weight:bold}
figure{display:inline-block;margin:.5em}figcaption{font-size:.9em;color:#555}
img{max-width:100%;border:1px solid #ddd}code{font-size:.9em}
"""

_METRIC_LABELS = {
    "e": "e (Eq. 1)",
    "f_c": "f_c = N_k / N",
    "E1_m": "E1 (Eq. 3)",
    "E2": "E2 (Eq. 4)",
    "t_cpu_s": "t_CPU",
    "N": "N (columns spanned)",
    "N_k": "N_k (columns with points)",
    "sigma_y_m": "σ_y",
    "precision_m": "precision (mean distance to the truth)",
    "completeness": "completeness (share of the seen truth found)",
    "truth_points": "truth points",
    "seen_points": "truth points the sonars saw",
    "found_points": "seen truth points found",
    "completeness_within_m": "found: a surface within",
}

#: The columns of the surfaces table: report.json key, heading.
_SURFACE_COLUMNS = (
    ("surface", "surface"),
    ("kind", "kind"),
    ("model", "model"),
    ("length_m", "length"),
    ("rms_m", "RMS"),
    ("support", "support (cells)"),
)


def _fmt(v: Any) -> str:
    if v is None:
        return MISSING
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, dict)):
        return json.dumps(v)
    return str(v)


def _table(
    rows: Mapping[str, Any], labels: Mapping[str, str] | None = None, *, human: bool = False
) -> str:
    """A two-column table; ``human``: numbers by their key's unit (lengths in cm)."""

    def cell(k: str, v: Any) -> str:
        return metric(k, v) if human and not isinstance(v, (list, dict)) else _fmt(v)

    names = labels or {}
    body = "".join(
        f"<tr><th>{html.escape(names.get(k, k))}</th><td>{html.escape(cell(k, v))}</td></tr>"
        for k, v in rows.items()
    )
    return f"<table>{body}</table>"


def _grid_rows(grid: Mapping[str, Any]) -> dict[str, Any]:
    if not {"nx", "ny", "cell", "x0", "y0"} <= set(grid):
        return dict(grid)
    extent = grid.get("extent") or []
    rows = {
        "cells": f"{grid['nx']} × {grid['ny']}",
        "cell size": length_cm(grid["cell"]),
        "origin (x0, y0)": f"{grid['x0']:.3f} m, {grid['y0']:.3f} m",
    }
    if len(extent) == 4:
        rows["extent"] = f"x {extent[0]:.3f}…{extent[1]:.3f} m, y {extent[2]:.3f}…{extent[3]:.3f} m"
    return rows


def surfaces_table(surfaces: Sequence[Mapping[str, Any]]) -> str:
    """The surfaces of a surfaces fit, one row each (lengths through the units function).

    Reads report.json's ``surfaces`` of any version: an entry without ``kind`` (a v2
    report) shows its model's kind; a surface no model fitted shows its reason.

    >>> surfaces_table([{"surface": 0, "ok": True, "model": "line", "length_m": 2.0,
    ...                  "rms_m": 0.004, "support": 180}]).count("<tr>")
    2
    """
    from sonarproc.pipeline.surfacefit import surface_kind

    head = "".join(f"<th>{html.escape(h)}</th>" for _, h in _SURFACE_COLUMNS)
    rows = [f"<tr>{head}</tr>"]
    for s in surfaces:
        if s.get("ok", True):
            values = {**s, "kind": s.get("kind") or surface_kind(s.get("model"))}
            cells = [metric(k, values.get(k)) for k, _ in _SURFACE_COLUMNS]
        else:
            reason = f"not fitted: {s.get('reason')}"
            cells = [str(s.get("surface")), MISSING, reason, MISSING, MISSING,
                     str(s.get("support", MISSING))]  # fmt: skip
        rows.append("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in cells) + "</tr>")
    return '<table class="surfaces">' + "".join(rows) + "</table>"


def _fit_section(doc: Mapping[str, Any]) -> str:
    """The fit: its record, or why it failed; for several surfaces, their table.

    An old report (v2) recorded a surfaces fit as failed with the surfaces listed: it is
    shown as the success it was.
    """
    fit = dict(doc["fit"])
    surfaces = [dict(s) for s in doc.get("surfaces") or []]
    fitted = [s for s in surfaces if s.get("ok", True)]
    if fit.get("kind") == "surfaces":
        n = int(fit.get("surfaces", len(fitted)))
        if n == 0:
            return f'<p class="fail">No surface fitted: {html.escape(str(fit.get("reason")))}</p>'
        from sonarproc.pipeline.surfacefit import surface_kind

        kinds: dict[str, int] = {}
        for s in fitted:
            k = str(s.get("kind") or surface_kind(s.get("model")))
            kinds[k] = kinds.get(k, 0) + 1
        what = ", ".join(f"{c} {k}" for k, c in sorted(kinds.items()))
        return f"<p>{n} surface(s) fitted ({html.escape(what)}).</p>" + surfaces_table(surfaces)
    fit_rows: dict[str, Any] = {"kind": fit.get("kind"), "order": fit.get("order")}
    if fit.get("ok"):
        for key in ("basis", "domain", "centre", "smoothing_lambda", "coefficients"):
            if key in fit:
                fit_rows[key] = fit[key]
        return _table(fit_rows)
    return f'<p class="fail">Fit failed: {html.escape(str(fit.get("reason")))}</p>' + _table(
        fit_rows
    )


def quality_section(quality: Mapping[str, Any] | None) -> str:
    """The truth-free quality (report.json's ``quality``): the map against its own readings.

    >>> quality_section(None)
    '<p>Not measured (a report from before quality was measured).</p>'
    """
    if not quality:
        return "<p>Not measured (a report from before quality was measured).</p>"
    tol = length_cm(quality.get("tolerance_m"))
    frac = quality.get("explained_fraction")
    rows = {
        f"readings explained within {tol}": (
            MISSING if frac is None else f"{frac:.3f} of {quality.get('explained_readings')}"
        ),
        "held-out range residual, median": length_cm(quality.get("heldout_residual_median_m")),
        "held-out range residual, 90th percentile": length_cm(
            quality.get("heldout_residual_p90_m")
        ),
        "held-out readings predicted": _fmt(quality.get("heldout_readings")),
        "share the held-out map predicts": _fmt(quality.get("heldout_predicted_fraction")),
        "held-out scheme": _fmt(quality.get("heldout_scheme")),
    }
    if quality.get("reason"):
        rows["not measured"] = str(quality["reason"])
    per = quality.get("surfaces") or []
    table = ""
    if per:
        head = "<tr><th>surface</th><th>readings it echoes</th><th>explained</th></tr>"
        body = "".join(
            f"<tr><td>{html.escape(_fmt(e.get('surface')))}</td>"
            f"<td>{html.escape(_fmt(e.get('readings')))}</td>"
            f"<td>{html.escape(number(e.get('explained_fraction')))}</td></tr>"
            for e in per
        )
        table = f'<table class="quality">{head}{body}</table>'
    return _table(rows) + table


def alignment_section(alignment: Mapping[str, Any] | None) -> str:
    """The drift correction (report.json's ``alignment``), or nothing when not tried."""
    if not alignment:
        return ""
    rows = {
        "applied": _fmt(alignment.get("applied")),
        "why": str(alignment.get("reason")),
        "largest position shift": length_cm(alignment.get("max_shift_m")),
        "mean position shift": length_cm(alignment.get("mean_shift_m")),
        "largest heading shift": _fmt(alignment.get("max_turn_rad")) + " rad",
    }
    return "<h2>Odometry drift correction</h2>" + _table(rows)


def _figure(name: str, data: bytes, caption: str) -> str:
    mime = _MIME[name.rsplit(".", 1)[-1]]
    uri = f"data:{mime};base64," + base64.b64encode(data).decode("ascii")
    return (
        f'<figure><img src="{uri}" alt="{html.escape(name)}">'
        f"<figcaption>{html.escape(caption)} (<code>{html.escape(name)}</code>)"
        "</figcaption></figure>"
    )


def render_html(doc: Mapping[str, Any], images: Mapping[str, bytes]) -> str:
    """Render the report dict and the PNGs into one HTML page.

    Parameters
    ----------
    doc : mapping
        :func:`sonarproc.report.report_dict` output.
    images : mapping of str to bytes
        The figure files written (``arcmap.png``, ``fit.svg``...) and their contents:
        each figure is shown once, as its PNG if there is one, else its SVG.
    """
    fit_html = _fit_section(doc)
    captions = {
        "arcmap": "Arc map: number of arcs through each cell",
        "processed": "The processed map",
        "fit": "Processed map (grey), true surface (dashed), fit or surfaces (solid)",
        "alignment": "Robot path: raw odometry and as corrected for drift",
    }
    shown = [
        next(f"{stem}.{ext}" for ext in ("png", "svg") if f"{stem}.{ext}" in images)
        for stem in _STEMS
        if f"{stem}.png" in images or f"{stem}.svg" in images
    ]
    figures = "".join(_figure(n, images[n], captions[n.split(".")[0]]) for n in shown)
    if not figures:
        figures = "<p>No figures were written (<code>--figures none</code>).</p>"
    svgs = [f"{stem}.svg" for stem in _STEMS if f"{stem}.svg" in images]
    svg_links = (
        "<p>Figures as vector graphics: " + ", ".join(f'<a href="{n}">{n}</a>' for n in svgs) + ". "
        if svgs
        else "<p>"
    )
    title = f"sonarproc report: {doc['source']}"
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>"
        f"<p>{html.escape(str(doc['method']))}; sonarmorph "
        f"{html.escape(str(doc['software']['sonarmorph']))}.</p>"
        "<h2>Metrics</h2>"
        + _table(doc["metrics"], _METRIC_LABELS, human=True)
        + "<h2>Fit</h2>"
        + fit_html
        + "<h2>Quality (no truth needed)</h2>"
        + quality_section(doc.get("quality"))
        + alignment_section(doc.get("alignment"))
        + (auto_record_html(doc["auto"]) if doc.get("auto") else "")
        + "<h2>Figures</h2>"
        + figures
        + "<h2>Parameters</h2>"
        + _table(doc["parameters"])
        + "<h2>Counts</h2>"
        + _table(doc["counts"])
        + "<h2>Grid</h2>"
        + _table(_grid_rows(doc["grid"]))
        + "<h2>Timings (wall)</h2>"
        + _table({k: seconds(v) for k, v in doc["timings_s"].items()})
        + svg_links
        + "Every number in SI units: <code>report.json</code>.</p>"
        + "</body></html>\n"
    )

"""The comparison files: ``compare.json``, ``compare.csv``, ``compare.png``, ``compare.html``.

``compare.png`` has one panel per method: its map, the truth dashed, the fit solid;
``compare.html`` is self-contained. Every number comes from
:func:`sonarproc.methods.compare.comparison_doc`.
"""

from __future__ import annotations

import base64
import csv
import html
import io
import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from sonarproc.fit import FitFailure
from sonarproc.methods.base import MethodResult
from sonarproc.methods.compare import COLUMNS, comparison_doc
from sonarproc.params import RunParams
from sonarproc.report.plots import block_max

__all__ = [
    "COMPARE_FILES",
    "render_compare_html",
    "render_compare_png",
    "write_comparison",
]

log = logging.getLogger(__name__)

COMPARE_FILES = ("compare.json", "compare.csv", "compare.png", "compare.html")


def _fmt(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def write_csv(path: Path, rows: Sequence[Mapping[str, Any]]) -> None:
    """``compare.csv``: header :data:`COLUMNS`, one row per method, empty = undefined."""
    with path.open("w", encoding="utf-8", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(COLUMNS)
        for row in rows:
            w.writerow([_fmt(row[c]) for c in COLUMNS])


def render_compare_png(results: Sequence[MethodResult]) -> bytes:
    """Side by side, one panel per method: its map (grey), truth dashed, fit solid."""
    n = max(len(results), 1)
    cols = min(n, 3)
    rows = (n + cols - 1) // cols
    g = results[0].run.grid
    aspect = float(np.clip(g.ny / g.nx, 0.3, 1.5))
    fig = Figure(figsize=(4.2 * cols, 4.2 * aspect * rows + 0.8), dpi=100)
    FigureCanvasAgg(fig)
    for k, r in enumerate(results):
        ax = fig.add_subplot(rows, cols, k + 1)
        run = r.run
        left, right, bottom, top = run.grid.extent
        ax.imshow(
            block_max(run.processed, 600),
            origin="lower",
            extent=(left, right, bottom, top),
            cmap="Greys",
            vmin=0,
            vmax=1,
            interpolation="nearest",
        )
        if run.truth is not None:
            ax.plot(run.truth[:, 0], run.truth[:, 1], "k--", lw=1.0, label="truth")
        if not isinstance(run.fit, FitFailure):
            pts = run.fit.sample(run.grid.cell)
            ax.plot(pts[:, 0], pts[:, 1], "-", color="tab:red", lw=1.4, label="fit")
        m = run.metrics
        e1 = "—" if m.E1_m is None else f"{100 * m.E1_m:.2f} cm"
        ax.set_title(f"{r.method}\nf_c={m.f_c:.2f}  E1={e1}", fontsize=9)
        ax.set_xlim(left, right)
        ax.set_ylim(bottom, top)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
        if k == 0:
            ax.legend(loc="upper right", fontsize=7)
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png")
    return buf.getvalue()


_CSS = (
    "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;color:#222}"
    "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:.25em .7em;"
    "font-variant-numeric:tabular-nums}th{background:#f3f3f3}img{max-width:100%}"
)


def render_compare_html(doc: Mapping[str, Any], png: bytes) -> str:
    """A self-contained page: the metrics table, the options and the figure embedded."""
    head = "".join(f"<th>{html.escape(c)}</th>" for c in COLUMNS)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(_fmt(row[c]))}</td>" for c in COLUMNS) + "</tr>"
        for row in doc["methods"]
    )
    uri = "data:image/png;base64," + base64.b64encode(png).decode("ascii")
    opts = html.escape(json.dumps(doc["options"], indent=1))
    params = html.escape(json.dumps(doc["parameters"]))
    return (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>sonarproc compare: {html.escape(str(doc['source']))}</title>"
        f"<style>{_CSS}</style></head><body>"
        f"<h1>Map-building methods on {html.escape(str(doc['source']))}</h1>"
        "<p>Same grid, same fit, same metrics (e, f_c, E1 in m, E2, t_cpu in s) for every "
        "method; empty = undefined.</p>"
        f"<table><tr>{head}</tr>{body}</table>"
        f'<figure><img src="{uri}" alt="compare.png"><figcaption>each method\'s map '
        "(grey), the truth dashed, the fit solid</figcaption></figure>"
        f"<h2>Run parameters</h2><pre>{params}</pre><h2>Method options</h2><pre>{opts}</pre>"
        "</body></html>\n"
    )


def write_comparison(
    source: str, params: RunParams, results: Sequence[MethodResult], out_dir: str | Path
) -> dict[str, Any]:
    """Write :data:`COMPARE_FILES` into ``out_dir``; return the ``compare.json`` dict."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    doc = comparison_doc(source, params, results)
    (out / "compare.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    write_csv(out / "compare.csv", doc["methods"])
    png = render_compare_png(results)
    (out / "compare.png").write_bytes(png)
    (out / "compare.html").write_text(render_compare_html(doc, png), encoding="utf-8")
    return doc

"""The comparison files: ``compare.json``, ``compare.csv``, ``compare.png``, ``compare.html``.

``compare.png`` (and ``compare.svg``) has one panel per method on a shared scale: its
map, the truth dashed, the fit solid over the whole truth span;
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
from sonarproc.report.auto_record import auto_record_html
from sonarproc.report.plots import block_max, broken_at_jumps, fit_curve
from sonarproc.report.units import MISSING, length_cm, number, sig3

__all__ = [
    "COMPARE_FILES",
    "compare_figure",
    "render_compare",
    "render_compare_html",
    "render_compare_png",
    "write_comparison",
]

log = logging.getLogger(__name__)

COMPARE_FILES = ("compare.json", "compare.csv", "compare.png", "compare.svg", "compare.html")
DPI = 150


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


def _grid_shape(n: int, aspect: float) -> tuple[int, int]:
    """Rows and columns for ``n`` panels of height/width ``aspect``, about 4:3 overall."""
    best = (n, 1)
    best_cost = float("inf")
    for cols in range(1, n + 1):
        rows = -(-n // cols)
        if rows * cols - n > 1:  # at most one spare slot (it holds the legend)
            continue
        shape = (rows * aspect) / cols
        cost = abs(np.log(shape / 0.75)) + 0.3 * (rows * cols - n)
        if cost < best_cost:
            best, best_cost = (rows, cols), cost
    return best


def compare_figure(results: Sequence[MethodResult], source: str = "") -> Figure:
    """One panel per method on a shared scale: its map (grey), truth dashed, fit solid.

    Every fit is drawn over the whole truth span (:func:`~sonarproc.report.plots.fit_curve`),
    so a fit that leaves its points shows its error. Axis labels sit on the outer panels;
    the legend takes the spare slot of the grid, or goes below it.
    """
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n = max(len(results), 1)
    g = results[0].run.grid
    left, right, bottom, top = g.extent
    aspect = float(np.clip((top - bottom) / max(right - left, 1e-9), 0.15, 3.0))
    rows, cols = _grid_shape(n, aspect)
    panel_w = float(np.clip(4.0 / max(aspect, 0.25) ** 0.5, 3.2, 6.5))  # wide maps: wider
    size = (max(panel_w * cols + 0.6, 6.5), panel_w * aspect * rows + 0.55 * rows + 1.2)
    fig = Figure(figsize=size, dpi=DPI)
    FigureCanvasAgg(fig)
    axes = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
    for k, ax in enumerate(axes.flat):
        if k >= len(results):
            ax.set_axis_off()
            continue
        r = results[k]
        run = r.run
        ax.imshow(
            block_max(run.processed, 600),
            origin="lower",
            extent=run.grid.extent,
            cmap="Greys",
            vmin=0,
            vmax=1.6,  # kept cells mid-grey, so the black truth and red fit stay visible
            interpolation="nearest",
        )
        if run.truth is not None:
            truth = broken_at_jumps(run.truth)
            ax.plot(truth[:, 0], truth[:, 1], "k--", lw=1.0)
        if not isinstance(run.fit, FitFailure):
            pts = fit_curve(run.fit, run.truth, run.grid.cell)
            ax.plot(pts[:, 0], pts[:, 1], "-", color="tab:red", lw=1.4)
        m = run.metrics
        fit_note = "" if not isinstance(run.fit, FitFailure) else ", fit failed"
        ax.set_title(
            f"{r.method}\nf_c {number(m.f_c)}, E1 {length_cm(m.E1_m)}{fit_note}", fontsize=9
        )
        ax.set_xlim(left, right)
        ax.set_ylim(bottom, top)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=8)
        if k % cols == 0:
            ax.set_ylabel("y (m)", fontsize=9)
        if k // cols == rows - 1 or k + cols >= len(results):
            ax.set_xlabel("x (m)", fontsize=9)
            ax.xaxis.set_tick_params(labelbottom=True)
    handles = [
        Patch(facecolor="0.6", label="method's map (kept cells)"),
        Line2D([], [], color="k", ls="--", lw=1.0, label="true surface"),
        Line2D([], [], color="tab:red", lw=1.4, label="fit (whole truth span)"),
    ]
    name = Path(source).name if source else ""
    fig.suptitle(
        f"{name}: map-building methods, same grid, fit and metrics".lstrip(": "), fontsize=10.5
    )
    if len(results) < rows * cols:
        spare = axes.flat[rows * cols - 1]
        spare.legend(handles=handles, loc="center", fontsize=9, frameon=False)
        fig.tight_layout()
    else:
        fig.legend(handles=handles, loc="lower center", ncols=3, fontsize=9, frameon=False)
        fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def render_compare(results: Sequence[MethodResult], source: str = "") -> tuple[bytes, bytes]:
    """``compare.png`` (150 dpi) and ``compare.svg``."""
    fig = compare_figure(results, source)
    png, svg = io.BytesIO(), io.BytesIO()
    fig.savefig(png, format="png", dpi=DPI)
    fig.savefig(svg, format="svg")
    return png.getvalue(), svg.getvalue()


def render_compare_png(results: Sequence[MethodResult], source: str = "") -> bytes:
    """``compare.png`` alone."""
    return render_compare(results, source)[0]


_CSS = (
    "body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1200px;color:#222}"
    "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:.25em .7em;"
    "font-variant-numeric:tabular-nums}th{background:#f3f3f3}img{max-width:100%}"
)


def _human_column(column: str) -> str:
    """A column heading for people: ``E1_m`` -> ``E1 (cm)``, ``t_cpu_s`` -> ``t_cpu (s)``."""
    if column.endswith("_m"):
        return f"{column[:-2]} (cm)"
    if column.endswith("_s"):
        return f"{column[:-2]} (s)"
    return column


def _human(column: str, value: Any) -> str:
    """A cell for people: lengths in cm and times in s (the unit is in the heading)."""
    if value is None:
        return MISSING
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float) and column.endswith("_m"):
        return sig3(100.0 * value)
    if isinstance(value, float):
        return sig3(value)
    return str(value)


def render_compare_html(doc: Mapping[str, Any], png: bytes) -> str:
    """A self-contained page: the metrics table, the options and the figure embedded."""
    head = "".join(f"<th>{html.escape(_human_column(c))}</th>" for c in COLUMNS)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(_human(c, row[c]))}</td>" for c in COLUMNS) + "</tr>"
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
        "<p>Same grid, same fit, same metrics for every method; lengths in cm, "
        f"{MISSING} = undefined (compare.json and compare.csv keep SI units).</p>"
        f"<table><tr>{head}</tr>{body}</table>"
        f'<figure><img src="{uri}" alt="compare.png"><figcaption>each method\'s map '
        "(grey), the truth dashed, the fit solid</figcaption></figure>"
        + (auto_record_html(doc["auto"]) if doc.get("auto") else "")
        + f"<h2>Run parameters</h2><pre>{params}</pre><h2>Method options</h2><pre>{opts}</pre>"
        "</body></html>\n"
    )


def write_comparison(
    source: str,
    params: RunParams,
    results: Sequence[MethodResult],
    out_dir: str | Path,
    *,
    auto: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Write :data:`COMPARE_FILES` into ``out_dir``; return the ``compare.json`` dict.

    ``auto``: the ``--auto`` record (compare.json's ``auto``, a section of compare.html).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    doc = comparison_doc(source, params, results)
    if auto is not None:
        doc["auto"] = auto
    (out / "compare.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    write_csv(out / "compare.csv", doc["methods"])
    png, svg = render_compare(results, source)
    (out / "compare.png").write_bytes(png)
    (out / "compare.svg").write_bytes(svg)
    (out / "compare.html").write_text(render_compare_html(doc, png), encoding="utf-8")
    return doc

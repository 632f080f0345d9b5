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
import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sonarproc.fit import FitFailure
from sonarproc.methods.base import MethodResult
from sonarproc.methods.compare import COLUMNS, comparison_doc
from sonarproc.params import RunParams
from sonarproc.pipeline.result import RunResult
from sonarproc.report import style
from sonarproc.report.auto_record import auto_record_html
from sonarproc.report.plots import FIGURE_FORMATS, figure_bytes
from sonarproc.report.run_report import DEFAULT_FIGURES
from sonarproc.report.units import MISSING, length_cm, number, sig3
from sonarproc.report.view import block_max, broken_at_jumps, clip_polyline, fit_curve, view_box

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

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


FIT_LABEL = "fit (whole truth span)"


def compare_figure(results: Sequence[MethodResult], source: str = "") -> Figure:
    """One panel per method on a shared scale: its map (grey), truth dashed, fit solid.

    Every fit is drawn over the whole truth span (:func:`~sonarproc.report.view.fit_curve`),
    so a fit that leaves its points shows its error; a method's surfaces each get their
    colour (:func:`~sonarproc.report.style.surface_style`). Every line is cut to the view
    first. Axis labels sit on the outer panels; the legend takes the spare slot of the
    grid, or goes below it. The style is :mod:`sonarproc.report.style`'s.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n = max(len(results), 1)
    g = results[0].run.grid
    left, right, bottom, top = g.extent
    view = view_box(g.extent)
    aspect = float(np.clip((top - bottom) / max(right - left, 1e-9), 0.15, 3.0))
    rows, cols = _grid_shape(n, aspect)
    panel_w = float(np.clip(4.0 / max(aspect, 0.25) ** 0.5, 3.2, 6.5))  # wide maps: wider
    size = (max(panel_w * cols + 0.6, 6.5), panel_w * aspect * rows + 0.55 * rows + 1.2)
    with style.drawing():
        fig = Figure(figsize=size, dpi=style.DPI)
        FigureCanvasAgg(fig)
        axes = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False)
        for k, ax in enumerate(axes.flat):
            if k >= len(results):
                ax.set_axis_off()
                continue
            _panel(ax, results[k], view)
            ax.set_xlim(left, right)
            ax.set_ylim(bottom, top)
            ax.set_aspect("equal")
            if k % cols == 0:
                ax.set_ylabel("y (m)")
            if k // cols == rows - 1 or k + cols >= len(results):
                ax.set_xlabel("x (m)")
                ax.xaxis.set_tick_params(labelbottom=True)
        handles = [
            Patch(facecolor="0.6", label="method's map (kept cells)"),
            Line2D([], [], label="true surface", **style.TRUTH_STYLE),
        ]
        drew = [r.run.surfaces is not None and bool(r.run.surfaces.surfaces) for r in results]
        if not all(drew):  # some panel drew a single fit
            fit = Line2D([], [], color=style.FIT_COLOUR, lw=style.FIT_WIDTH, label=FIT_LABEL)
            handles.append(fit)
        if any(drew):
            colour, dash = style.surface_style(0)
            handles.append(Line2D([], [], color=colour, ls=dash, lw=style.FIT_WIDTH,
                                  label="surfaces (one colour each)"))  # fmt: skip
        name = Path(source).name if source else ""
        title = f"{name}: map-building methods, same grid, fit and metrics".lstrip(": ")
        fig.suptitle(style.wrap_title(title, size[0] - 0.4), fontsize=style.TITLE_SIZE)
        if len(results) < rows * cols:
            spare = axes.flat[rows * cols - 1]
            spare.legend(handles=handles, loc="center")
            fig.tight_layout()
        else:
            fig.legend(handles=handles, loc="lower center", ncols=min(len(handles), 4))
            fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def _panel(ax: Axes, r: MethodResult, view: tuple[float, float, float, float]) -> None:
    """One method's panel: its map, the truth, its fit or surfaces, cut to ``view``."""
    run = r.run
    ax.imshow(
        block_max(run.processed, 600),
        extent=run.grid.extent,
        cmap="Greys",
        vmin=0,
        vmax=1.6,  # kept cells mid-grey, so the black truth and red fit stay visible
        interpolation="none",
    )
    if run.truth is not None:
        truth = clip_polyline(broken_at_jumps(run.truth), view)
        ax.plot(truth[:, 0], truth[:, 1], **style.TRUTH_STYLE)
    if run.surfaces is not None and run.surfaces.surfaces:
        for k, s in enumerate(run.surfaces.surfaces):
            colour, dash = style.surface_style(k)
            pts = clip_polyline(s.polyline, view)
            ax.plot(pts[:, 0], pts[:, 1], color=colour, ls=dash, lw=style.FIT_WIDTH)
    elif not isinstance(run.fit, FitFailure):
        pts = clip_polyline(fit_curve(run.fit, run.truth, run.grid.cell), view)
        ax.plot(pts[:, 0], pts[:, 1], color=style.FIT_COLOUR, lw=style.FIT_WIDTH)
    ax.set_title(f"{r.method}\n{_panel_note(run)}", fontsize=style.LABEL_SIZE)


def _panel_note(run: RunResult) -> str:
    """A panel's second title line: f_c, then E1, or the surfaces and their precision."""
    m = run.metrics
    if run.surfaces is not None and run.surfaces.surfaces:
        note = f"f_c {number(m.f_c)}, {len(run.surfaces.surfaces)} surfaces"
        precision = (run.surface_metrics or {}).get("precision_m")
        return note + (f", precision {length_cm(precision)}" if precision is not None else "")
    fit_note = "" if not isinstance(run.fit, FitFailure) else ", fit failed"
    return f"f_c {number(m.f_c)}, E1 {length_cm(m.E1_m)}{fit_note}"


def render_compare(
    results: Sequence[MethodResult],
    source: str = "",
    formats: Sequence[str] = FIGURE_FORMATS,
) -> dict[str, bytes]:
    """``compare.png`` (150 dpi) and/or ``compare.svg``, by ``formats``, as bytes."""
    if not formats:
        return {}
    fig = compare_figure(results, source)
    return {f"compare.{fmt}": figure_bytes(fig, fmt) for fmt in formats}


def render_compare_png(results: Sequence[MethodResult], source: str = "") -> bytes:
    """``compare.png`` alone."""
    return render_compare(results, source, ("png",))["compare.png"]


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


def render_compare_html(doc: Mapping[str, Any], images: Mapping[str, bytes]) -> str:
    """A self-contained page: the metrics table, the options and the figure embedded.

    ``images``: the figure files written (``compare.png`` and/or ``compare.svg``); the
    PNG is embedded if there is one, else the SVG; none: the page says so.
    """
    head = "".join(f"<th>{html.escape(_human_column(c))}</th>" for c in COLUMNS)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(_human(c, row[c]))}</td>" for c in COLUMNS) + "</tr>"
        for row in doc["methods"]
    )
    figure = "<p>No figure was written (<code>--figures none</code>).</p>"
    for name, mime in (("compare.png", "image/png"), ("compare.svg", "image/svg+xml")):
        if name in images:
            uri = f"data:{mime};base64," + base64.b64encode(images[name]).decode("ascii")
            figure = (
                f'<figure><img src="{uri}" alt="{name}"><figcaption>each method\'s map '
                "(grey), the truth dashed, the fit solid</figcaption></figure>"
            )
            break
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
        + figure
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
    figures: Sequence[str] = DEFAULT_FIGURES,
) -> dict[str, Any]:
    """Write :data:`COMPARE_FILES` into ``out_dir``; return the ``compare.json`` dict.

    ``auto``: the ``--auto`` record (compare.json's ``auto``, a section of compare.html);
    ``figures``: the figure formats (``png``, ``svg``; empty: no figure).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    doc = comparison_doc(source, params, results)
    if auto is not None:
        doc["auto"] = auto
    (out / "compare.json").write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    write_csv(out / "compare.csv", doc["methods"])
    images = render_compare(results, source, figures)
    for name, data in images.items():
        (out / name).write_bytes(data)
    (out / "compare.html").write_text(render_compare_html(doc, images), encoding="utf-8")
    return doc

"""The run report's figures: arc map, processed map and fit, each as PNG and SVG.

Each figure is a :class:`~sonarproc.report.figure.MapFigure` (labelled axes in metres, a
title naming the log, a colour bar where grey means a count, the legend below the axes)
drawn by :mod:`~sonarproc.report.canvas` (PNG, 150 dpi) and :mod:`~sonarproc.report.svg`
without matplotlib, whose import alone costs more than a run's processing. Large maps
are reduced by block maximum to at most :data:`MAX_DISPLAY` pixels a side, which keeps a
4000 x 4000 map as cheap to draw as a small one and loses no set cell.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from sonarproc.fit import Fit, FitFailure
from sonarproc.pipeline import RunResult
from sonarproc.report.canvas import to_png
from sonarproc.report.figure import ColourBar, Line, MapFigure, Raster, Swatch, layout
from sonarproc.report.svg import to_svg
from sonarproc.report.units import length_cm, number

__all__ = [
    "FIGURES",
    "MAX_DISPLAY",
    "SURFACE_COLOURS",
    "Rendered",
    "arcmap_figure",
    "block_max",
    "broken_at_jumps",
    "fit_curve",
    "fit_figure",
    "grey_ramp",
    "processed_figure",
    "render",
    "render_all",
]

MAX_DISPLAY = 1000
#: One colour per fitted surface (colour-blind-safe, cycled).
SURFACE_COLOURS = ("#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#f0e442")
FIT_COLOUR = "#d62728"
PATH_COLOUR = "#1f77b4"
CELL_GREY = "#9a9a9a"

#: The figure files of a run report, by stem: ``NAME.png`` and ``NAME.svg``.
FIGURES = ("arcmap", "processed", "fit")

Rendered = dict[str, bytes]


def block_max(a: npt.NDArray[np.generic], limit: int = MAX_DISPLAY) -> npt.NDArray[np.generic]:
    """Reduce a 2-D map by block maximum so neither side exceeds ``limit``.

    Examples
    --------
    >>> block_max(np.arange(16).reshape(4, 4), limit=2).tolist()
    [[5, 7], [13, 15]]
    """
    f = int(np.ceil(max(a.shape) / limit))
    if f <= 1:
        return a
    ny, nx = a.shape
    py, px = (-ny) % f, (-nx) % f
    if py or px:
        a = np.pad(a, ((0, py), (0, px)))
    return a.reshape(a.shape[0] // f, f, a.shape[1] // f, f).max(axis=(1, 3))


def grey_ramp() -> npt.NDArray[np.uint8]:
    """256 RGB steps from white (no arcs) to black (the most)."""
    v = np.linspace(255, 0, 256).round().astype(np.uint8)
    return np.repeat(v[:, None], 3, axis=1)


def _shown(result: RunResult, cells: npt.NDArray[np.bool_] | None) -> npt.NDArray[np.bool_]:
    return cells if cells is not None else np.asarray(block_max(result.processed), dtype=bool)


def _base(result: RunResult, what: str) -> MapFigure:
    x0, x1, y0, y1 = result.grid.extent
    name = Path(result.source).name or result.source
    return MapFigure(title=f"{name}: {what}", xlim=(x0, x1), ylim=(y0, y1))


def broken_at_jumps(xy: npt.NDArray[np.float64], factor: float = 8.0) -> npt.NDArray[np.float64]:
    """``xy`` with a NaN row wherever a step is ``factor`` times the median step.

    A truth profile of several walls is one polyline; drawn as is, it joins the walls.

    Examples
    --------
    >>> broken_at_jumps(np.array([[0.0, 0], [1, 0], [2, 0], [50, 0], [51, 0]]))[3].tolist()
    [nan, nan]
    """
    if xy.shape[0] < 3:
        return xy
    step = np.hypot(*np.diff(xy, axis=0).T)
    jumps = np.flatnonzero(step > factor * max(float(np.median(step)), 1e-12))
    if jumps.size == 0:
        return xy
    return np.insert(xy, jumps + 1, np.nan, axis=0)


def _truth(fig: MapFigure, result: RunResult) -> None:
    if result.truth is not None and result.truth.size:
        xy = broken_at_jumps(result.truth)
        fig.lines.append(Line(xy, "#000000", 1.6, dashed=True, label="true surface"))


def arcmap_figure(result: RunResult) -> MapFigure:
    """The arc map: how many arcs cross each cell, with its colour bar and the robot path."""
    fig = _base(result, f"arc map, {result.counts.get('readings_used', 0)} arcs")
    img = np.asarray(block_max(result.counts_map))
    pos = img[img > 0]
    vmax = max(float(np.percentile(pos, 99)) if pos.size else 1.0, 1.0)
    vmax = float(np.ceil(vmax))
    ramp = grey_ramp()
    level = np.minimum(img.astype(np.float32) * (255.0 / vmax), 255.0).astype(np.uint8)
    fig.rasters.append(Raster(255 - level, result.grid.extent))  # the ramp, as grey
    clipped = pos.size > 0 and float(pos.max()) > vmax
    fig.colourbar = ColourBar(
        ramp, 0.0, vmax, "arcs through the cell",
        top_label=f"≥{vmax:g}" if clipped else None,
    )  # fmt: skip
    if result.robot_xy is not None and result.robot_xy.size:
        xy = result.robot_xy[:: max(result.robot_xy.shape[0] // 5000, 1)]
        x0, x1, y0, y1 = result.grid.extent
        inside = (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
        if np.any(inside):  # no legend entry for a path drawn outside the map
            fig.lines.append(Line(xy, PATH_COLOUR, 1.5, label="robot path"))
    return fig


def processed_figure(result: RunResult, cells: npt.NDArray[np.bool_] | None = None) -> MapFigure:
    """The processed (binary) map after the morphological operations.

    ``cells`` is the processed map already reduced by :func:`block_max`, if at hand.
    """
    m = result.metrics
    extra = f", e = {number(m.e)}" if m.e is not None else ""
    fig = _base(result, f"after {result.params.ops}: f_c = {number(m.f_c)}{extra}")
    grey = np.where(_shown(result, cells), np.uint8(0), np.uint8(255))
    fig.rasters.append(Raster(grey, result.grid.extent))
    fig.swatches.append(Swatch("#000000", f"kept cell ({100 * result.grid.cell:.3g} cm)"))
    return fig


def fit_figure(result: RunResult, cells: npt.NDArray[np.bool_] | None = None) -> MapFigure:
    """The processed cells (grey), the true surface (dashed) and the fit or surfaces."""
    fit = result.fit
    m = result.metrics
    if result.surfaces is not None:
        what = f"{len(result.surfaces.surfaces)} surfaces, a line, arc or spline each"
        if result.surface_metrics is not None:
            sm = result.surface_metrics
            what += f", precision {length_cm(sm['precision_m'])}"
            what += f", completeness {number(sm['completeness'])}"
    elif isinstance(fit, FitFailure):
        what = f"{fit.kind} fit failed: {fit.reason}"
    else:
        what = f"{fit.kind} fit, order {fit.order}"
    if m.E1_m is not None and m.E2 is not None:
        what += f", E1 = {length_cm(m.E1_m)}, E2 = {number(m.E2)}"
    fig = _base(result, what)
    grey = np.where(_shown(result, cells), np.uint8(0x9A), np.uint8(255))
    fig.rasters.append(Raster(grey, result.grid.extent))
    fig.swatches.append(Swatch(CELL_GREY, "processed map"))
    _truth(fig, result)
    surfaces = result.surfaces
    if surfaces is not None and surfaces.surfaces:
        for k, s in enumerate(surfaces.surfaces):
            colour = SURFACE_COLOURS[k % len(SURFACE_COLOURS)]
            fig.lines.append(Line(s.polyline, colour, 2.4, label=f"surface {k + 1} ({s.model})"))
    elif not isinstance(fit, FitFailure):
        curve = fit_curve(fit, result.truth, result.grid.cell)
        fig.lines.append(Line(curve, FIT_COLOUR, 2.4, label=f"{fit.kind} fit"))
    return fig


def fit_curve(
    fit: Fit, truth: npt.NDArray[np.float64] | None, step: float
) -> npt.NDArray[np.float64]:
    """The fit sampled every ``step`` over its points *and* the whole truth span.

    E1 and E2 are measured over the truth's columns, so a curve drawn only over the
    points would hide the error where the fit leaves them (extrapolation).

    Examples
    --------
    >>> from sonarproc.fit import PolyFit
    >>> line = PolyFit(order=1, coef=np.array([0.0, 1.0]), domain=(0.0, 1.0))
    >>> c = fit_curve(line, np.array([[-1.0, 0.0], [2.0, 0.0]]), 0.5)
    >>> float(c[0, 0]), float(c[-1, 0])
    (-1.0, 2.0)
    """
    if isinstance(fit, FitFailure):
        return np.zeros((0, 2))
    if fit.kind == "polar" or truth is None or not truth.size:
        return fit.sample(step)
    lo = min(float(fit.domain[0]), float(np.min(truth[:, 0])))
    hi = max(float(fit.domain[1]), float(np.max(truth[:, 0])))
    n = min(int(np.floor((hi - lo) / step)) + 1, 20_000)
    x = np.linspace(lo, hi, max(n, 2))
    return np.column_stack((x, fit(x)))


def render(fig: MapFigure) -> tuple[bytes, bytes]:
    """One figure as PNG bytes and SVG bytes (one layout for both)."""
    lay = layout(fig)
    return to_png(fig, lay), to_svg(fig, lay).encode("utf-8")


def render_all(result: RunResult) -> Rendered:
    """Every figure of :data:`FIGURES` as ``{"arcmap.png": ..., "arcmap.svg": ..., ...}``."""
    cells = _shown(result, None)
    figures = (arcmap_figure(result), processed_figure(result, cells), fit_figure(result, cells))
    out: Rendered = {}
    for stem, fig in zip(FIGURES, figures, strict=True):
        png, svg = render(fig)
        out[f"{stem}.png"], out[f"{stem}.svg"] = png, svg
    return out


def render_arcmap(result: RunResult) -> bytes:
    """``arcmap.png``."""
    return render(arcmap_figure(result))[0]


def render_processed(result: RunResult) -> bytes:
    """``processed.png``."""
    return render(processed_figure(result))[0]


def render_fit(result: RunResult) -> bytes:
    """``fit.png``."""
    return render(fit_figure(result))[0]

"""A map figure as data, and its layout: what :mod:`canvas` and :mod:`svg` both draw.

A :class:`MapFigure` is one equal-aspect plot in world metres: raster layers (maps),
line layers (truth, fits, surfaces, robot path), an optional colour bar, a title and
labelled axes. :func:`layout` places everything in pixels at :data:`~glyphs.DPI`: the
plot box sized to the map's aspect, tick labels, the colour bar on the right and the
legend below the axes, outside the data. The PNG (:func:`sonarproc.report.canvas.to_png`)
and the SVG (:func:`sonarproc.report.svg.to_svg`) are two renderings of one layout, so
they always agree.

>>> nice_ticks(0.0, 2.0, 5)
[0.0, 0.5, 1.0, 1.5, 2.0]
>>> tick_labels([0.0, 0.5, 1.0])
['0.0', '0.5', '1.0']
>>> tick_labels([0.0, 2.0, 4.0])
['0', '2', '4']
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from sonarproc.report.glyphs import text_height, text_width

__all__ = [
    "ColourBar",
    "Layout",
    "Line",
    "MapFigure",
    "Raster",
    "Swatch",
    "layout",
    "nice_ticks",
    "tick_labels",
]

#: Largest plot box (pixels) and the least height or width it is padded to.
MAX_BOX = (960, 880)
MIN_SIDE = 200
TICK = 5


@dataclass
class Raster:
    """An image over ``extent`` (x0, x1, y0, y1 in m); row 0 is the lowest y.

    ``rgb`` is H x W x 3, or H x W for grey (a third of the bytes to encode).
    """

    rgb: npt.NDArray[np.uint8]
    extent: tuple[float, float, float, float]


@dataclass
class Line:
    """A polyline in world coordinates (m), drawn ``width`` pixels wide."""

    xy: npt.NDArray[np.float64]
    colour: str
    width: float = 2.0
    dashed: bool = False
    label: str | None = None


@dataclass
class Swatch:
    """A legend entry without a line: a filled square (e.g. the processed map's cells)."""

    colour: str
    label: str


@dataclass
class ColourBar:
    """A vertical colour bar: ``ramp`` (256 x 3) from ``vmin`` (bottom) to ``vmax``."""

    ramp: npt.NDArray[np.uint8]
    vmin: float
    vmax: float
    label: str
    top_label: str | None = None  # e.g. "≥ 12" when the scale clips


@dataclass
class MapFigure:
    """One equal-aspect map plot with everything a printed figure needs."""

    title: str
    xlim: tuple[float, float]
    ylim: tuple[float, float]
    xlabel: str = "x (m)"
    ylabel: str = "y (m)"
    rasters: list[Raster] = field(default_factory=list)
    lines: list[Line] = field(default_factory=list)
    swatches: list[Swatch] = field(default_factory=list)
    colourbar: ColourBar | None = None


@dataclass
class Layout:
    """Pixel positions (origin top left, y down) of every part of a :class:`MapFigure`."""

    width: int
    height: int
    box: tuple[int, int, int, int]  # left, top, width, height of the plot area
    xlim: tuple[float, float]
    ylim: tuple[float, float]
    xticks: list[tuple[int, str]]
    yticks: list[tuple[int, str]]
    title_xy: tuple[int, int]  # baseline, centred on x
    xlabel_xy: tuple[int, int]
    ylabel_xy: tuple[int, int]  # baseline centre, the text turned 90 degrees
    legend: list[tuple[int, int, Line | Swatch]]  # x, baseline y, entry
    cbar_box: tuple[int, int, int, int] | None = None
    cbar_ticks: list[tuple[int, str]] = field(default_factory=list)
    cbar_label_xy: tuple[int, int] = (0, 0)

    def to_px(self, xy: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
        """World (m) to canvas pixels (column, row) as floats."""
        left, top, w, h = self.box
        (x0, x1), (y0, y1) = self.xlim, self.ylim
        px = left + (xy[:, 0] - x0) / (x1 - x0) * w
        py = top + h - (xy[:, 1] - y0) / (y1 - y0) * h
        return np.stack((px, py), axis=1)


def nice_ticks(lo: float, hi: float, most: int) -> list[float]:
    """At most ``most`` round tick values (1, 2, 2.5, 5 x 10^k steps) within [lo, hi]."""
    span = hi - lo
    if not (span > 0) or not math.isfinite(span):
        return [lo]
    raw = span / max(most - 1, 1)
    mag = 10.0 ** math.floor(math.log10(raw))
    step = next(s * mag for s in (1.0, 2.0, 2.5, 5.0, 10.0) if s * mag >= raw)
    first = math.ceil(lo / step - 1e-9) * step
    n = math.floor((hi - first) / step + 1e-9) + 1
    return [round(first + k * step, 12) + 0.0 for k in range(n)]


def tick_labels(values: list[float]) -> list[str]:
    """Labels with one number of decimals, as few as show every tick exactly."""
    for decimals in range(0, 7):
        texts = [f"{v:.{decimals}f}" for v in values]
        if all(
            abs(float(t) - v) < 1e-9 * max(1.0, abs(v)) for t, v in zip(texts, values, strict=True)
        ):
            return [t.replace("-", "−") if t.startswith("-") else t for t in texts]
    return [f"{v:g}" for v in values]


def _box_size(fig: MapFigure) -> tuple[int, int, tuple[float, float], tuple[float, float]]:
    (x0, x1), (y0, y1) = fig.xlim, fig.ylim
    dx, dy = max(x1 - x0, 1e-9), max(y1 - y0, 1e-9)
    scale = min(MAX_BOX[0] / dx, MAX_BOX[1] / dy)
    w, h = dx * scale, dy * scale
    if h < MIN_SIDE:  # a long thin map: pad y around the data, keep the aspect
        pad = (MIN_SIDE / scale - dy) / 2
        y0, y1, h = y0 - pad, y1 + pad, MIN_SIDE
    if w < MIN_SIDE:
        pad = (MIN_SIDE / scale - dx) / 2
        x0, x1, w = x0 - pad, x1 + pad, MIN_SIDE
    return round(w), round(h), (x0, x1), (y0, y1)


def layout(fig: MapFigure) -> Layout:
    """Place the plot box, ticks, labels, colour bar and legend of ``fig`` in pixels."""
    bw, bh, xlim, ylim = _box_size(fig)
    t_asc, t_desc = text_height("tick")
    l_asc, l_desc = text_height("label")
    h_asc, h_desc = text_height("title")
    xt = nice_ticks(*xlim, max(3, min(9, bw // 110)))
    yt = nice_ticks(*ylim, max(4, min(9, bh // 70)))
    xl, yl = tick_labels(xt), tick_labels(yt)
    ytw = max(text_width(t, "tick") for t in yl)
    left = 12 + l_asc + l_desc + 8 + ytw + 4 + TICK
    top = 14 + h_asc + h_desc + 10
    right = 24
    cbar_box = None
    cbar_ticks: list[tuple[int, str]] = []
    cbar_label_xy = (0, 0)
    if fig.colourbar is not None:
        cb = fig.colourbar
        ct = nice_ticks(cb.vmin, cb.vmax, 6)
        ctl = tick_labels(ct)
        if cb.top_label is not None and ct and ct[-1] == cb.vmax:
            ctl[-1] = cb.top_label
        cx = left + bw + 22
        cbar_box = (cx, top, 18, bh)
        span = (cb.vmax - cb.vmin) or 1.0
        cbar_ticks = [
            (round(top + bh - (v - cb.vmin) / span * bh), s) for v, s in zip(ct, ctl, strict=True)
        ]
        ctw = max(text_width(s, "tick") for s in ctl)
        lab_x = cx + 18 + TICK + 4 + ctw + 8 + l_asc
        cbar_label_xy = (lab_x, top + bh // 2)
        right = lab_x + l_desc + 14 - (left + bw)
    width = left + bw + right
    # the legend below the x label, wrapped to the figure's width
    entries: list[Line | Swatch] = [ln for ln in fig.lines if ln.label] + list(fig.swatches)
    row_h = t_asc + t_desc + 8
    base_y = top + bh + TICK + 4 + t_asc + t_desc + 6 + l_asc + l_desc + 10 + t_asc
    legend: list[tuple[int, int, Line | Swatch]] = []
    x, row = left, 0
    for entry in entries:
        w = 34 + text_width(entry.label or "", "tick") + 22
        if x > left and x + w > width - 10:
            x, row = left, row + 1
        legend.append((x, base_y + row * row_h, entry))
        x += w
    rows = (legend[-1][1] - base_y) // row_h + 1 if legend else 0
    height = top + bh + TICK + 4 + t_asc + t_desc + 6 + l_asc + l_desc + 12 + rows * row_h
    width = max(width, max((x for x, _, _ in legend), default=0))
    px = lambda v: round(left + (v - xlim[0]) / (xlim[1] - xlim[0]) * bw)  # noqa: E731
    py = lambda v: round(top + bh - (v - ylim[0]) / (ylim[1] - ylim[0]) * bh)  # noqa: E731
    return Layout(
        width=int(width),
        height=int(height),
        box=(left, top, bw, bh),
        xlim=xlim,
        ylim=ylim,
        xticks=[(px(v), s) for v, s in zip(xt, xl, strict=True)],
        yticks=[(py(v), s) for v, s in zip(yt, yl, strict=True)],
        title_xy=(left + bw // 2, 14 + h_asc),
        xlabel_xy=(left + bw // 2, top + bh + TICK + 4 + t_asc + t_desc + 6 + l_asc),
        ylabel_xy=(12 + l_asc, top + bh // 2),
        legend=legend,
        cbar_box=cbar_box,
        cbar_ticks=cbar_ticks,
        cbar_label_xy=cbar_label_xy,
    )

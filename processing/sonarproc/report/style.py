"""One look for every figure ``run``, ``compare`` and ``watch`` draw.

Colours, fonts, line widths, the figure size and resolution, the colour bar and where the
legend goes are decided here and nowhere else. Nothing here imports matplotlib at module
level: a run that writes no figure never pays for it. The figures are drawn under
:data:`RC` (:func:`drawing`), so a user's own ``matplotlib.rcParams`` are left alone, and
every artist carries its style, so a returned :class:`~matplotlib.figure.Figure` can be
restyled and saved outside this module.

>>> len(set(SURFACE_COLOURS))
20
>>> surface_style(0), surface_style(20)[1]
(('#0072b2', '-'), '--')
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "CELL_GREY",
    "DPI",
    "FIT_COLOUR",
    "LINE_STYLES",
    "PATH_COLOUR",
    "POINT_MARKERS",
    "POINT_SIZE",
    "RC",
    "SURFACE_COLOURS",
    "TITLE_SIZE",
    "TRUTH_STYLE",
    "WIDTH_IN",
    "cells_rgba",
    "count_colour_bar",
    "count_rgba",
    "drawing",
    "legend_below",
    "map_figure",
    "surface_style",
    "wrap_title",
]

#: Raster resolution of every PNG (dots per inch).
DPI = 150
#: Width of a single-map figure (inches); its height follows the map's aspect.
WIDTH_IN = 7.0
#: Least and largest height of a map's axes (inches): a long thin map stays legible, a
#: tall one fits a screen.
MIN_AXES_IN = 1.4
MAX_AXES_IN = 7.5
#: Legend entries in a row below the axes.
LEGEND_COLUMNS = 4
#: Font sizes (points): title, axis labels, ticks and legend.
TITLE_SIZE = 10.5
LABEL_SIZE = 9.5
TICK_SIZE = 8.5
#: A tick's length and its label's gap (points, matplotlib's defaults), and how far below
#: the axes the x label's top sits (ticks, their labels and a gap; inches).
TICK_PAD_PT = 3.5 + 3.5
X_LABEL_DROP_IN = (TICK_PAD_PT + 1.2 * TICK_SIZE + 3.0) / 72

#: matplotlib settings every figure is drawn under. DejaVu Sans (matplotlib's own font)
#: has σ, °, µ, − and ≥; SVG text is written as paths, so the SVG shows the font it was
#: laid out with; lines and text are antialiased. Legend and colour bar sit outside the
#: axes, in margins :func:`map_figure` leaves for them.
RC: dict[str, Any] = {
    "font.family": "DejaVu Sans",
    "font.size": LABEL_SIZE,
    "axes.titlesize": TITLE_SIZE,
    "axes.labelsize": LABEL_SIZE,
    "xtick.labelsize": TICK_SIZE,
    "ytick.labelsize": TICK_SIZE,
    "legend.fontsize": TICK_SIZE,
    "legend.frameon": False,
    "legend.handlelength": 2.6,
    "lines.antialiased": True,
    "patch.antialiased": True,
    "text.antialiased": True,
    "axes.unicode_minus": True,
    "svg.fonttype": "path",
    "savefig.dpi": DPI,
    "figure.dpi": DPI,
    "image.origin": "lower",
}

#: One colour per fitted surface, 20 before any repeats: Okabe & Ito's colour-blind-safe
#: seven first, then colours chosen to stay apart from them and from each other (CIELAB
#: ΔE ≥ 15, checked by the tests), none grey or black (the map's cells and the truth).
SURFACE_COLOURS = (
    "#0072b2", "#d55e00", "#009e73", "#cc79a7", "#e69f00", "#56b4e9", "#f0e442",
    "#882255", "#332288", "#117733", "#aa4499", "#999933", "#661100", "#44aa99",
    "#ff7f7f", "#8c564b", "#17becf", "#bcbd22", "#6a3d9a", "#b15928",
)  # fmt: skip
#: After every colour is used, repeats differ in line style.
LINE_STYLES: tuple[str, ...] = ("-", "--", "-.", ":")
#: The single fit (not surfaces), the robot's path and the processed map's cells.
FIT_COLOUR = "#d62728"
PATH_COLOUR = "#1f77b4"
CELL_GREY = "#9a9a9a"
#: Colour map of counts (arcs through a cell): white (none) to black (the most).
COUNT_CMAP = "Greys"
#: The true surface: black and dashed, under the fits.
TRUTH_STYLE: dict[str, Any] = {"color": "black", "linestyle": (0, (5, 3)), "linewidth": 1.3}
#: Width of fitted curves and surfaces (points).
FIT_WIDTH = 1.8
#: Point reflectors are drawn as markers, one shape per kind (a concave corner a square,
#: a convex edge a triangle), filled with the surface's colour and outlined in black.
POINT_MARKERS = {"corner": "s", "edge": "^"}
POINT_SIZE = 7.0


def surface_style(k: int) -> tuple[str, str]:
    """Colour and line style of surface ``k`` (0-based): distinct for the first 20.

    >>> surface_style(1), surface_style(21)
    (('#d55e00', '-'), ('#d55e00', '--'))
    """
    n = len(SURFACE_COLOURS)
    return SURFACE_COLOURS[k % n], LINE_STYLES[(k // n) % len(LINE_STYLES)]


@contextmanager
def drawing() -> Iterator[None]:
    """Draw (and save) under :data:`RC` without touching the user's rcParams."""
    import matplotlib

    with matplotlib.rc_context(RC):  # type: ignore[arg-type]  # (a dict of str keys)
        yield


def wrap_title(text: str, width_in: float, size: float = TITLE_SIZE) -> str:
    """``text`` wrapped to lines that fit ``width_in`` inches at ``size`` points.

    DejaVu Sans averages under 0.62 em a character, so a line holds
    ``width_in * 72 / (0.62 * size)`` characters; a long title wraps, it is never cut.

    >>> wrap_title("a " * 40, 3.0).count("\\n")
    2
    """
    chars = max(int(width_in * 72.0 / (0.62 * size)), 10)
    return "\n".join(textwrap.wrap(text, chars, break_on_hyphens=False)) or text


def _chars_in(size: float, chars: int) -> float:
    """Width (inches) of ``chars`` characters at ``size`` points (0.6 em each)."""
    return chars * 0.6 * size / 72.0


def map_figure(
    extent: tuple[float, float, float, float],
    title: str,
    *,
    colour_bar: float | None = None,
    legend_entries: int = 0,
) -> tuple[Figure, Axes, Axes | None]:
    """An equal-aspect map figure over ``extent`` (x0, x1, y0, y1 in m), titled.

    Returns the figure, its map axes and, when ``colour_bar`` (the bar's largest value)
    is given, the colour bar's axes. The figure is :data:`WIDTH_IN` wide and as tall as
    the map's aspect, the title (wrapped to the width, never cut) and the legend rows
    below the axes ask for. A map thinner than :data:`MIN_AXES_IN` is shown with its y
    range padded around it (its aspect kept); a tall one is at most :data:`MAX_AXES_IN`
    high. The margins are computed from the lengths of the texts around the axes, not
    measured by a layout engine (which costs a third of the drawing time), so they are
    the same in the PNG and the SVG.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    x0, x1, y0, y1 = extent
    y_chars = max(len(f"{v:.2f}") for v in (y0, y1))
    left = 0.14 + LABEL_SIZE / 72 + 0.12 + _chars_in(TICK_SIZE, y_chars) + 0.1
    right = 0.25
    if colour_bar is not None:
        right = 0.15 + 0.16 + 0.1 + _chars_in(TICK_SIZE, len(f"{colour_bar:g}")) + 0.12
        right += LABEL_SIZE / 72 + 0.12
    # the title is centred over the axes: wrap it to what fits either side of their centre
    centre = left + (WIDTH_IN - left - right) / 2
    wrapped = wrap_title(title, 2 * min(centre, WIDTH_IN - centre) - 0.3)
    top = 0.2 + 1.25 * TITLE_SIZE / 72 * (wrapped.count("\n") + 1)
    rows = -(-legend_entries // LEGEND_COLUMNS)
    bottom = 0.1 + 1.2 * (TICK_SIZE + LABEL_SIZE) / 72 + 0.2  # x ticks and label
    if rows:
        bottom += 0.08 + rows * 1.9 * TICK_SIZE / 72
    plot_w = WIDTH_IN - left - right
    span_x, span_y = max(x1 - x0, 1e-9), max(y1 - y0, 1e-9)
    axes_h = plot_w * span_y / span_x
    if axes_h < MIN_AXES_IN:  # pad y so the map is not a sliver
        pad = (MIN_AXES_IN / plot_w * span_x - span_y) / 2
        y0, y1, axes_h = y0 - pad, y1 + pad, MIN_AXES_IN
    if axes_h > MAX_AXES_IN:  # a tall map: narrower axes, centred
        axes_h = MAX_AXES_IN
        narrower = axes_h * span_x / span_y
        left += (plot_w - narrower) / 2
        plot_w = narrower
    height = bottom + axes_h + top
    fig = Figure(figsize=(WIDTH_IN, height), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_axes((left / WIDTH_IN, bottom / height, plot_w / WIDTH_IN, axes_h / height))
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    # Title and axis labels at positions computed here: matplotlib otherwise measures
    # every tick label to place them, at each save, about a third of a figure's time.
    ax.set_title(wrapped, y=1.0, pad=6.0)
    ax.xaxis.set_label_coords(0.5, -X_LABEL_DROP_IN / axes_h)
    y_gap = (TICK_PAD_PT / 72 + _chars_in(TICK_SIZE, y_chars) + 0.05) / plot_w
    ax.yaxis.set_label_coords(-y_gap, 0.5)
    cax = None
    if colour_bar is not None:
        at = (left + plot_w + 0.15) / WIDTH_IN
        cax = fig.add_axes((at, bottom / height, 0.16 / WIDTH_IN, axes_h / height))
        c_chars = len(f"{colour_bar:g}") + 1
        c_gap = (TICK_PAD_PT / 72 + _chars_in(TICK_SIZE, c_chars) + 0.05) / 0.16
        cax.yaxis.set_label_coords(1.0 + c_gap, 0.5)
    return fig, ax, cax


def count_rgba(counts: npt.NDArray[Any], vmax: float) -> npt.NDArray[np.uint8]:
    """A count map as RGBA bytes on :data:`COUNT_CMAP`, 0 white to ``vmax`` and above black.

    Colouring here (one table look-up) spares matplotlib normalising a float copy of the
    map; :func:`count_colour_bar` draws the same scale.
    """
    from matplotlib import colormaps

    lut = np.asarray(colormaps[COUNT_CMAP](np.linspace(0.0, 1.0, 256)) * 255 + 0.5, np.uint8)
    level = np.minimum(np.asarray(counts, np.float32) * (256.0 / max(vmax, 1e-12)), 255.0)
    return lut[level.astype(np.uint8)]


def cells_rgba(cells: npt.NDArray[np.bool_], colour: str) -> npt.NDArray[np.uint8]:
    """A binary map as RGBA bytes: set cells in ``colour``, the rest white."""
    from matplotlib.colors import to_rgba_array

    lut = np.asarray(to_rgba_array(["white", colour]) * 255 + 0.5, np.uint8)
    return lut[np.asarray(cells, dtype=np.uint8)]


def count_colour_bar(fig: Figure, cax: Axes, vmax: float, label: str, *, clipped: bool) -> None:
    """The colour bar of :func:`count_rgba` in ``cax``, 0 to ``vmax``; ``clipped``:
    counts above ``vmax`` share its colour (drawn as a pointed end)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    scale = ScalarMappable(norm=Normalize(0.0, vmax), cmap=COUNT_CMAP)
    fig.colorbar(scale, cax=cax, label=label, extend="max" if clipped else "neither")


def legend_below(fig: Figure, handles: list[Any]) -> None:
    """The legend below the axes (never over the data), up to four entries a row."""
    if handles:
        ncols = min(len(handles), LEGEND_COLUMNS)
        at = (0.5, 0.06 / fig.get_figheight())
        fig.legend(handles=handles, loc="lower center", bbox_to_anchor=at, ncols=ncols)

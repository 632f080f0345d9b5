"""The run report's figures: arc map, processed map and fit, as matplotlib figures.

:func:`arcmap_figure`, :func:`processed_figure` and :func:`fit_figure` return a
:class:`matplotlib.figure.Figure` (object API, an Agg canvas, no ``pyplot``): restyle it,
save it as you like. :func:`render_figures` saves the three as PNG and/or SVG bytes for
the report. matplotlib is imported inside these functions only, so a run that writes no
figure never imports it. Every line drawn is first cut to the view
(:func:`~sonarproc.report.view.clip_polyline`); the style is
:mod:`sonarproc.report.style`'s.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.fit import FitFailure
from sonarproc.pipeline.result import RunResult
from sonarproc.report import style
from sonarproc.report.drawing import figure_bytes, figures_bytes
from sonarproc.report.units import length_cm, number
from sonarproc.report.view import (
    MAX_DISPLAY,
    block_max,
    broken_at_jumps,
    clip_polyline,
    fit_curve,
    view_box,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "FIGURES",
    "FIGURE_FORMATS",
    "MAX_DISPLAY",
    "ArcMapView",
    "ResultView",
    "alignment_figure",
    "arcmap_figure",
    "block_max",
    "broken_at_jumps",
    "figure_bytes",
    "fit_curve",
    "fit_figure",
    "fit_title",
    "map_label",
    "parse_figure_formats",
    "processed_figure",
    "render_figures",
    "render_views",
]

#: The figure files of a run report, by stem: ``NAME.png`` and/or ``NAME.svg``.
FIGURES = ("arcmap", "processed", "fit")
#: The file formats a figure can be written in.
FIGURE_FORMATS = ("png", "svg")


def parse_figure_formats(text: str) -> tuple[str, ...]:
    """``--figures``: ``png,svg``, ``png``, ``svg`` or ``none`` as a tuple of formats.

    Raises
    ------
    ParameterError
        Any other value (the message names the option and the allowed values).

    Examples
    --------
    >>> parse_figure_formats("svg, png"), parse_figure_formats("none")
    (('png', 'svg'), ())
    """
    from sonarproc.errors import ParameterError

    words = [w.strip().lower() for w in text.split(",") if w.strip()]
    if words == ["none"]:
        return ()
    if not words or any(w not in FIGURE_FORMATS for w in words):
        raise ParameterError("figures", f"must be png,svg, png, svg or none, got {text!r}")
    return tuple(f for f in FIGURE_FORMATS if f in words)


def map_label(ops: str, auto: Mapping[str, Any] | None = None) -> str:
    """What built the map: the operations ``ops`` or, with ``--auto``, the chosen method.

    ``auto`` is ``--auto``'s record (report.json's ``auto``): when it chose another
    method than the paper's morphology, the method is named, with its options.

    >>> map_label("thinning:3"), map_label("thinning:3", {"method": "arc-median"})
    ('thinning:3', 'arc-median')
    >>> map_label("thinning:3", {"method": "morphological", "options": {"ops": "closing"}})
    'closing'
    """
    method = (auto or {}).get("method")
    options = dict((auto or {}).get("options") or {})
    if method is None:
        return ops
    if method == "morphological":
        return str(options.get("ops", ops))
    opts = ", ".join(f"{k}={v}" for k, v in options.items())
    return f"{method} ({opts})" if opts else str(method)


def fit_title(result: RunResult) -> str:
    """The fit figure's title after the log's name: the fit (or surfaces) and its errors.

    A polynomial is named with its order, a spline is "spline fit" (its degree is no
    choice of the user's), a polar fit with its harmonics.
    """
    fit, m = result.fit, result.metrics
    if result.surfaces is not None:
        what = _surfaces_what(result.surfaces.surfaces)
        if result.surface_metrics is not None:
            sm = result.surface_metrics
            what += f", precision {length_cm(sm.get('precision_m'))}"
            what += f", completeness {number(sm.get('completeness'))}"
    elif isinstance(fit, FitFailure):
        what = f"{fit.kind} fit failed: {fit.reason}"
    elif fit.kind == "spline":
        what = "spline fit"
    else:
        what = f"{fit.kind} fit, order {fit.order}"
    if m.E1_m is not None and m.E2 is not None:
        what += f", E1 = {length_cm(m.E1_m)}, E2 = {number(m.E2)}"
    return what


def _surfaces_what(surfaces: Sequence[Any]) -> str:
    """``N surfaces, a line, arc or spline each``, then the point reflectors, if any."""
    points = [s for s in surfaces if s.model in style.POINT_MARKERS]
    what = f"{len(surfaces) - len(points)} surfaces, a line, arc or spline each"
    for kind in style.POINT_MARKERS:
        n = sum(1 for s in points if s.model == kind)
        if n:
            what += f", {n} {kind}{'s' if n > 1 else ''}"
    return what


def _title(result: RunResult, what: str) -> str:
    return f"{Path(result.source).name or result.source}: {what}"


def _shown(result: RunResult, cells: npt.NDArray[np.bool_] | None) -> npt.NDArray[np.bool_]:
    return cells if cells is not None else np.asarray(block_max(result.processed), dtype=bool)


def _line(ax: Axes, xy: npt.NDArray[np.float64], view: tuple[float, ...], **kw: Any) -> Any:
    """Plot ``xy`` cut to ``view``; the Line2D (with no points if none is inside)."""
    cut = clip_polyline(xy, view)  # type: ignore[arg-type]
    return ax.plot(cut[:, 0], cut[:, 1], **kw)[0]


def _point(
    ax: Axes, xy: npt.NDArray[np.float64], view: tuple[float, ...], kind: str, colour: str, k: int
) -> Any:
    """A point reflector as its kind's marker (no marker when it lies outside ``view``)."""
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)[:1]
    x0, x1, y0, y1 = view[:4]
    inside = (x0 <= p[:, 0]) & (p[:, 0] <= x1) & (y0 <= p[:, 1]) & (p[:, 1] <= y1)
    p = p[inside]
    return ax.plot(
        p[:, 0], p[:, 1], ls="none", marker=style.POINT_MARKERS[kind], ms=style.POINT_SIZE,
        mfc=colour, mec="black", mew=0.8, label=f"surface {k} ({kind})", zorder=3,
    )[0]  # fmt: skip


@dataclass(frozen=True, eq=False)
class ArcMapView:
    """What the arc map figure shows: all known as soon as the map is built, before its
    fit (so a child may draw it meanwhile, :mod:`sonarproc.report.ahead`).

    Attributes
    ----------
    source : str
        The log (its name titles the figure).
    counts_map : ndarray of unsigned int
        Arcs through each cell.
    robot_xy : ndarray (N, 2) or None
        The robot's positions.
    extent : tuple of float
        The grid's extent (m).
    arcs : int
        Readings drawn as arcs.
    """

    source: str
    counts_map: npt.NDArray[np.unsignedinteger[Any]]
    robot_xy: npt.NDArray[np.float64] | None
    extent: tuple[float, float, float, float]
    arcs: int

    @classmethod
    def of(cls, result: RunResult) -> ArcMapView:
        """The arc map figure's content in ``result``."""
        extent = tuple(float(v) for v in result.grid.extent)
        return cls(result.source, result.counts_map, result.robot_xy, extent,  # type: ignore[arg-type]
                   int(result.counts.get("readings_used", 0)))  # fmt: skip

    def same_as(self, other: ArcMapView) -> bool:
        """Whether ``other`` draws the same figure (equal content, array by array)."""
        a, b = self.robot_xy, other.robot_xy
        paths = (a is None) == (b is None) and (a is None or b is None or np.array_equal(a, b))
        return (
            self.source == other.source and self.extent == other.extent
            and self.arcs == other.arcs and paths
            and (self.counts_map is other.counts_map
                 or np.array_equal(self.counts_map, other.counts_map))
        )  # fmt: skip


def arcmap_figure(result: RunResult | ArcMapView) -> Figure:
    """The arc map: how many arcs cross each cell, with its colour bar and the robot path."""
    view = result if isinstance(result, ArcMapView) else ArcMapView.of(result)
    img = np.asarray(block_max(view.counts_map))
    pos = img[img > 0]
    vmax = float(np.ceil(max(float(np.percentile(pos, 99)) if pos.size else 1.0, 1.0)))
    clipped = pos.size > 0 and float(pos.max()) > vmax  # the top 1 % share the darkest grey
    extent = view.extent
    path = np.zeros((0, 2))
    if view.robot_xy is not None and view.robot_xy.size:
        xy = view.robot_xy[:: max(view.robot_xy.shape[0] // 5000, 1)]
        path = clip_polyline(xy, view_box(extent))
    with style.drawing():
        title = f"{Path(view.source).name or view.source}: arc map, {view.arcs} arcs"
        entries = 1 if path.size else 0  # no legend entry for a path outside the map
        fig, ax, cax = style.map_figure(extent, title, colour_bar=vmax, legend_entries=entries)
        ax.imshow(style.count_rgba(img, vmax), extent=extent, interpolation="none")
        assert cax is not None
        style.count_colour_bar(fig, cax, vmax, "arcs through the cell", clipped=clipped)
        handles = []
        if path.size:
            handles += ax.plot(
                path[:, 0], path[:, 1], color=style.PATH_COLOUR, lw=1.2, label="robot path"
            )
        style.legend_below(fig, handles)
    return fig


@dataclass(frozen=True, eq=False)
class ResultView:
    """What the processed, fit and alignment figures show of a result: text, numbers and
    arrays only, no fit or surface object. A child that draws it (:mod:`sonarproc.report.
    ahead`) needs matplotlib and this module, not the modules that fitted the result.

    Attributes
    ----------
    extent : tuple of float
        The grid's extent (m).
    cells : ndarray of bool
        The processed map, reduced by :func:`block_max`.
    cell_label : str
        The cell size, as the processed map's legend says it.
    processed_title, fit_title, alignment_title : str
        The figures' titles.
    truth : ndarray (N, 2) or None
        The true surface, broken at its jumps (:func:`broken_at_jumps`).
    surfaces : tuple of (str, ndarray)
        Each surface's model and polyline, numbered as in surfaces.csv.
    fit_curve : ndarray (N, 2) or None
        The single fit over the truth's span (:func:`fit_curve`); None: no such fit (the
        result's surfaces, or a failed fit).
    fit_label : str
        The single fit's legend entry.
    fit_entries : int
        The fit figure's legend entries.
    paths : tuple of ndarray or None
        The raw and corrected paths of the drift correction (None: no alignment ran).
    drift_corrected : bool
        The drift correction was applied (its figure is then drawn).
    """

    extent: tuple[float, float, float, float]
    cells: npt.NDArray[np.bool_]
    cell_label: str
    processed_title: str
    fit_title: str
    alignment_title: str
    truth: npt.NDArray[np.float64] | None
    surfaces: tuple[tuple[str, npt.NDArray[np.float64]], ...]
    fit_curve: npt.NDArray[np.float64] | None
    fit_label: str
    fit_entries: int
    paths: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None
    drift_corrected: bool

    @classmethod
    def of(
        cls,
        result: RunResult,
        cells: npt.NDArray[np.bool_] | None = None,
        *,
        auto: Mapping[str, Any] | None = None,
    ) -> ResultView:
        """What ``result``'s figures show (``cells``: its processed map reduced by
        :func:`block_max`, if at hand; ``auto``: ``--auto``'s record, when it chose the map)."""
        m = result.metrics
        extra = f", e = {number(m.e)}" if m.e is not None else ""
        built = map_label(str(result.params.ops), auto)
        found = result.surfaces
        lines = tuple((str(s.model), s.polyline) for s in found.surfaces) if found else ()
        curve, label = None, ""
        if not lines and not isinstance(result.fit, FitFailure):
            curve = fit_curve(result.fit, result.truth, result.grid.cell)
            label = f"{result.fit.kind} fit"
        truth = None
        if result.truth is not None and result.truth.size:
            truth = broken_at_jumps(result.truth)
        record = result.alignment
        paths = None
        if record is not None:
            paths = (np.asarray(record.raw_path), np.asarray(record.corrected_path))
        shift = 0.0 if record is None else record.max_shift_m
        return cls(
            extent=tuple(float(v) for v in result.grid.extent),  # type: ignore[arg-type]
            cells=_shown(result, cells),
            cell_label=length_cm(result.grid.cell),
            processed_title=_title(result, f"after {built}: f_c = {number(m.f_c)}{extra}"),
            fit_title=_title(result, fit_title(result)),
            alignment_title=_title(result, f"drift correction, up to {length_cm(shift)}"),
            truth=truth,
            surfaces=lines,
            fit_curve=curve,
            fit_label=label,
            fit_entries=1 + (result.truth is not None) + (len(lines) or 1),
            paths=paths,
            drift_corrected=record is not None and bool(record.applied),
        )


def _view(
    result: RunResult | ResultView,
    cells: npt.NDArray[np.bool_] | None = None,
    auto: Mapping[str, Any] | None = None,
) -> ResultView:
    return result if isinstance(result, ResultView) else ResultView.of(result, cells, auto=auto)


def processed_figure(
    result: RunResult | ResultView,
    cells: npt.NDArray[np.bool_] | None = None,
    *,
    auto: Mapping[str, Any] | None = None,
) -> Figure:
    """The processed (binary) map, titled with what built it (:func:`map_label`).

    ``cells`` is the processed map already reduced by :func:`block_max`, if at hand;
    ``auto`` is ``--auto``'s record, when it chose the map.
    """
    from matplotlib.patches import Patch

    view = _view(result, cells, auto)
    with style.drawing():
        fig, ax, _ = style.map_figure(view.extent, view.processed_title, legend_entries=1)
        shown = style.cells_rgba(view.cells, "black")
        ax.imshow(shown, extent=view.extent, interpolation="none")
        kept = Patch(color="black", label=f"kept cell ({view.cell_label})")
        style.legend_below(fig, [kept])
    return fig


def fit_figure(
    result: RunResult | ResultView, cells: npt.NDArray[np.bool_] | None = None
) -> Figure:
    """The processed cells (grey), the true surface (dashed) and the fit or surfaces.

    Surfaces are numbered 0..N-1, as in surfaces.csv, surfaces.geojson and report.json,
    each in its own colour (:func:`~sonarproc.report.style.surface_style`). A single fit
    is drawn over the whole truth span, cut to the view.
    """
    from matplotlib.patches import Patch

    v = _view(result, cells)
    with style.drawing():
        extent = v.extent
        box = view_box(extent)
        fig, ax, _ = style.map_figure(extent, v.fit_title, legend_entries=v.fit_entries)
        shown = style.cells_rgba(v.cells, style.CELL_GREY)
        ax.imshow(shown, extent=extent, interpolation="none")
        handles: list[Any] = [Patch(color=style.CELL_GREY, label="processed map")]
        if v.truth is not None:
            handles.append(_line(ax, v.truth, box, label="true surface", **style.TRUTH_STYLE))
        for k, (model, polyline) in enumerate(v.surfaces):
            colour, dash = style.surface_style(k)
            if model in style.POINT_MARKERS:
                handles.append(_point(ax, polyline, box, model, colour, k))
                continue
            handles.append(
                _line(
                    ax, polyline, box, color=colour, ls=dash, lw=style.FIT_WIDTH,
                    label=f"surface {k} ({model})",
                )
            )  # fmt: skip
        if v.fit_curve is not None:
            handles.append(
                _line(
                    ax, v.fit_curve, box, color=style.FIT_COLOUR, lw=style.FIT_WIDTH,
                    label=v.fit_label,
                )
            )  # fmt: skip
        style.legend_below(fig, handles)
    return fig


def alignment_figure(
    result: RunResult | ResultView, cells: npt.NDArray[np.bool_] | None = None
) -> Figure:
    """The robot's path at the correction nodes, raw (dashed) and as corrected for drift
    (solid), over the processed map (grey) of the corrected readings."""
    from matplotlib.patches import Patch

    v = _view(result, cells)
    raw, corrected = v.paths if v.paths is not None else (np.zeros((0, 2)), np.zeros((0, 2)))
    with style.drawing():
        extent = v.extent
        box = view_box(extent)
        fig, ax, _ = style.map_figure(extent, v.alignment_title, legend_entries=3)
        shown = style.cells_rgba(v.cells, style.CELL_GREY)
        ax.imshow(shown, extent=extent, interpolation="none")
        handles: list[Any] = [Patch(color=style.CELL_GREY, label="processed map")]
        handles.append(
            _line(ax, raw, box, color="black", ls="--", lw=1.2, label="raw odometry path")
        )
        handles.append(
            _line(ax, corrected, box, color=style.PATH_COLOUR, lw=1.5, label="corrected path")
        )
        style.legend_below(fig, handles)
    return fig


def render_figures(
    result: RunResult,
    formats: Sequence[str] = FIGURE_FORMATS,
    *,
    auto: Mapping[str, Any] | None = None,
    skip: Collection[str] = (),
) -> dict[str, bytes]:
    """Every figure of :data:`FIGURES` in ``formats``: ``{"arcmap.png": ..., ...}``; and
    ``alignment`` (:func:`alignment_figure`) when the run's poses were corrected for drift.
    The figures named in ``skip`` (``"arcmap"``: drawn already) are left out.

    No format: no figure, and matplotlib is not imported. The drawing is spread over two
    cores where it can be (:func:`~sonarproc.report.drawing.figures_bytes`); the bytes
    are those of :func:`figure_bytes`.
    """
    if not formats:
        return {}
    arc = None if "arcmap" in skip else ArcMapView.of(result)
    return render_views(arc, ResultView.of(result, auto=auto), formats)


def render_views(
    arc: ArcMapView | None, view: ResultView, formats: Sequence[str]
) -> dict[str, bytes]:
    """:func:`render_figures` from what the figures show: the arc map's files first
    (none when ``arc`` is None), then the processed map's, the fit's, and the drift
    correction's when one was applied."""
    # each figure made where it is drawn (this process or the drawing child)
    figures: list[tuple[str, Callable[[], Figure]]] = []
    if arc is not None:
        figures.append(("arcmap", lambda: arcmap_figure(arc)))
    figures += [("processed", lambda: processed_figure(view)), ("fit", lambda: fit_figure(view))]
    if view.drift_corrected:
        figures.append(("alignment", lambda: alignment_figure(view)))
    return figures_bytes(figures, formats)

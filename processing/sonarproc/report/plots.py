"""The report's figures as PNG bytes: arc map, processed map, fit (matplotlib, Agg).

Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas, never through
pyplot, so rendering needs no display and holds no global state. Large maps are reduced
by block maximum to at most :data:`MAX_DISPLAY` pixels a side before drawing, which keeps
a 4000 x 4000 map as cheap to draw as a small one and loses no set cell.
"""

from __future__ import annotations

import io

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from sonarproc.fit import FitFailure
from sonarproc.pipeline import RunResult

__all__ = ["MAX_DISPLAY", "block_max", "render_arcmap", "render_fit", "render_processed"]

MAX_DISPLAY = 1000
_DPI = 110


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


def _extent(result: RunResult) -> tuple[float, float, float, float]:
    return result.grid.extent


def _figure(result: RunResult) -> tuple[Figure, Axes]:
    g = result.grid
    aspect = (g.ny / g.nx) if g.nx else 1.0
    width = 7.5
    height = float(np.clip(width * aspect, 3.0, 9.0)) + 0.6
    fig = Figure(figsize=(width, height), dpi=_DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_aspect("equal")
    return fig, ax


def _limits(ax: Axes, result: RunResult) -> None:
    x0, x1, y0, y1 = _extent(result)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)


def _png(fig: Figure) -> bytes:
    buf = io.BytesIO()
    fig.tight_layout()
    fig.savefig(buf, format="png", dpi=_DPI)
    return buf.getvalue()


def _truth(ax: Axes, result: RunResult) -> None:
    if result.truth is not None:
        ax.plot(result.truth[:, 0], result.truth[:, 1], "k--", lw=1.2, label="true surface")


def render_arcmap(result: RunResult) -> bytes:
    """The arc map: how many arcs cross each cell (darker = more)."""
    fig, ax = _figure(result)
    img = np.asarray(block_max(result.counts_map), dtype=np.float64)
    vmax = max(float(np.percentile(img[img > 0], 99)) if np.any(img) else 1.0, 1.0)
    ax.imshow(
        img,
        origin="lower",
        extent=_extent(result),
        cmap="Greys",
        vmin=0,
        vmax=vmax,
        interpolation="nearest",
    )
    if result.robot_xy is not None and result.robot_xy.size:
        xy = result.robot_xy[:: max(result.robot_xy.shape[0] // 5000, 1)]
        ax.plot(xy[:, 0], xy[:, 1], ".", ms=2, color="tab:blue", label="robot path")
        ax.legend(loc="upper right", fontsize=8)
    _limits(ax, result)
    ax.set_title(f"arc map: {result.counts['readings_used']} arcs")
    return _png(fig)


def render_processed(result: RunResult) -> bytes:
    """The processed (binary) map after the morphological operations."""
    fig, ax = _figure(result)
    ax.imshow(
        block_max(result.processed),
        origin="lower",
        extent=_extent(result),
        cmap="Greys",
        vmin=0,
        vmax=1,
        interpolation="nearest",
    )
    m = result.metrics
    extra = f", e = {m.e:.3f}" if m.e is not None else ""
    ax.set_title(f"after {result.params.ops}: f_c = {m.f_c:.3f}{extra}")
    return _png(fig)


def render_fit(result: RunResult) -> bytes:
    """Processed points, the true surface (dashed) and the fitted curve (solid)."""
    fig, ax = _figure(result)
    n = result.points_x.size
    if n:
        step = max(n // 200_000, 1)
        ax.plot(
            result.points_x[::step],
            result.points_y[::step],
            ",",
            color="0.55",
            label="processed map",
        )
    _truth(ax, result)
    fit = result.fit
    if isinstance(fit, FitFailure):
        title = f"{fit.kind} fit failed: {fit.reason}"
    else:
        pts = fit.sample(result.grid.cell)
        ax.plot(pts[:, 0], pts[:, 1], "-", color="tab:red", lw=1.6, label=f"{fit.kind} fit")
        title = f"{fit.kind} fit, order {fit.order}"
    m = result.metrics
    if m.E1_m is not None and m.E2 is not None:
        title += f": E1 = {100 * m.E1_m:.2f} cm, E2 = {m.E2:.3f}"
    ax.set_title(title, fontsize=10)
    _limits(ax, result)
    ax.legend(loc="upper right", fontsize=8)
    return _png(fig)

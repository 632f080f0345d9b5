"""Figures to bytes: PNG and SVG, the drawing of several figures spread over two cores.

:func:`figure_bytes` saves one figure. :func:`figures_bytes` saves several in several
formats and spends the time of the slowest drawing, not of all of them, where it can:

- a PNG's pixels are drawn on the figure's Agg canvas and compressed on a worker thread
  (Pillow's deflate runs without Python's lock), while the next figure is drawn;
- the SVGs (or, in one format, every other figure) are drawn in a child process forked
  for them, while this process draws the others. A fork inherits the figures as they
  are (nothing is pickled but the bytes that come back), and only from a parent that
  runs no other thread (a lone thread holds no lock the child could inherit locked), on
  Linux, with two cores to use. Where it cannot fork, or the child fails, everything is
  drawn here: the bytes are the same.
"""

from __future__ import annotations

import io
import logging
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.forked import ForkedChild, fork_is_safe
from sonarproc.report import style

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["PNG_COMPRESSION", "DrawingChild", "figure_bytes", "figures_bytes", "fork_is_safe"]

log = logging.getLogger(__name__)

#: zlib level of the PNGs: level 3 (zlib's fast strategy) takes a third less time than
#: the default 6 for a PNG about a fifth larger; the deflate is a PNG's largest single cost.
PNG_COMPRESSION = 3


def figure_bytes(fig: Figure, fmt: str) -> bytes:
    """``fig`` saved as ``fmt`` (``png`` at :data:`~sonarproc.report.style.DPI`, ``svg``)."""
    if fmt == "png":
        return _encode_png(_agg_pixels(fig))
    buf = io.BytesIO()
    with style.drawing():
        fig.savefig(buf, format=fmt, dpi=style.DPI, metadata=_metadata(fmt))
    return buf.getvalue()


def figures_bytes(
    figures: Sequence[tuple[str, Figure | Callable[[], Figure]]], formats: Sequence[str]
) -> dict[str, bytes]:
    """``{"STEM.FMT": bytes}`` for every ``(STEM, figure)`` in every format of ``formats``,
    in that order; the same bytes as :func:`figure_bytes` of each.

    A figure may be given as the function that makes it: each process then makes only
    the figures it draws, after the fork (the child does not wait for this process to
    make the others, and neither writes to pages the other shares).
    """
    from concurrent.futures import Future, ThreadPoolExecutor

    jobs = [(f"{stem}.{fmt}", fig, fmt) for stem, fig in figures for fmt in formats]
    share = _childs_share(jobs, [stem for stem, _ in figures], formats)
    child = DrawingChild.start(share) if share else None
    theirs_names = {name for name, _, _ in share} if child is not None else set()
    mine = [job for job in jobs if job[0] not in theirs_names]
    made = _Made()
    drawn: dict[str, bytes | Future[bytes]] = {}
    try:  # the PNG encoder is this process's only other thread, started after the fork
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="png") as encoder:
            for name, fig, fmt in mine:
                if fmt == "png":
                    drawn[name] = encoder.submit(_encode_png, _agg_pixels(made(fig)))
                else:
                    drawn[name] = figure_bytes(made(fig), fmt)
    finally:
        theirs = child.collect() if child is not None else None
    if child is not None:
        if theirs is None:  # the child failed: draw its share here
            theirs = {name: figure_bytes(made(fig), fmt) for name, fig, fmt in share}
        drawn.update(theirs)
    return {name: _result(drawn[name]) for name, _, _ in jobs}


class _Made:
    """The figures of a process: one given, or made once by the function given."""

    def __init__(self) -> None:
        # keyed by the function itself (kept alive here, so no other takes its id)
        self._made: dict[Callable[[], Figure], Figure] = {}

    def __call__(self, fig: Figure | Callable[[], Figure]) -> Figure:
        if not callable(fig):
            return fig
        if fig not in self._made:
            self._made[fig] = fig()
        return self._made[fig]


def _result(value: Any) -> bytes:
    return value if isinstance(value, bytes) else bytes(value.result())


def _childs_share(jobs: list[Job], stems: Sequence[str], formats: Sequence[str]) -> list[Job]:
    """The jobs a forked child draws while this process draws the others (none: no child).

    With SVGs and another format, the SVGs: this process draws the PNGs, whose
    compression runs on its encoder thread. (Measured on the 90 000-reading room run:
    the two take about as long; a PNG more for the child makes it the slower of the two.)
    With one format and several figures, every other figure counted from the last but
    one: the last (a fit over its map, the costliest) stays here, so that the two halves
    take about as long. None where no child may be forked (:func:`fork_is_safe`).
    """
    if "svg" in formats and len(formats) >= 2:
        share = [job for job in jobs if job[2] == "svg"]
    elif len(stems) >= 2:
        theirs = set(list(reversed(stems))[1::2])
        share = [job for job in jobs if job[0].rsplit(".", 1)[0] in theirs]
    else:
        return []
    return share if fork_is_safe() else []


Job = tuple[str, "Figure | Callable[[], Figure]", str]


class DrawingChild(ForkedChild):
    """A forked child saving figures; :meth:`collect` reads its bytes."""

    @classmethod
    def start(cls, jobs: Sequence[Job]) -> DrawingChild | None:
        """Fork a child that sends back ``{name: figure_bytes(fig, fmt)}`` of ``jobs``
        (a figure given as the function that makes it is made in the child)."""

        def work() -> dict[str, bytes]:
            made = _Made()
            return {name: figure_bytes(made(fig), fmt) for name, fig, fmt in jobs}

        return cls.start_work(work)

    @classmethod
    def start_work(cls, work: Callable[[], Any]) -> DrawingChild | None:
        """Fork a child that sends back what ``work()`` returns (None: no child)."""
        child = ForkedChild.start_work(work)
        return None if child is None else cls(child.pid, child.fd)

    def collect(self) -> dict[str, bytes] | None:
        """The child's files, or None if it failed."""
        files = self.collect_any()
        if files is None:
            return None
        return {str(k): bytes(v) for k, v in files.items()}


def _agg_pixels(fig: Figure) -> npt.NDArray[np.uint8]:
    """``fig`` drawn on its Agg canvas at :data:`~sonarproc.report.style.DPI`: a copy of
    the RGBA pixels (rows top to bottom), what ``savefig(format="png")`` would encode."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    dpi = fig.dpi
    with style.drawing():
        try:
            fig.set_dpi(style.DPI)
            canvas.draw()
            return np.array(canvas.buffer_rgba(), dtype=np.uint8, copy=True)
        finally:
            fig.set_dpi(dpi)


def _encode_png(rgba: npt.NDArray[np.uint8]) -> bytes:
    """RGBA pixels as a PNG at :data:`~sonarproc.report.style.DPI`, level
    :data:`PNG_COMPRESSION` (Pillow releases Python's lock while it deflates)."""
    from matplotlib.image import imsave

    buf = io.BytesIO()
    imsave(buf, rgba.data, format="png", origin="upper", dpi=style.DPI,
           metadata=_metadata("png"), pil_kwargs={"compress_level": PNG_COMPRESSION})  # fmt: skip
    return buf.getvalue()


def _metadata(fmt: str) -> dict[str, Any]:
    # no date: the same run gives the same bytes
    return {"Software": "sonarmorph"} if fmt == "png" else {"Date": None}

"""Figures to bytes: PNG and SVG, the drawing of several figures spread over two cores.

:func:`figure_bytes` saves one figure. :func:`figures_bytes` saves several in several
formats and spends the time of the slowest drawing, not of all of them, where it can:

- a PNG's pixels are drawn on the figure's Agg canvas and compressed on a worker thread
  (Pillow's deflate runs without Python's lock), while the next figure is drawn;
- the SVGs are drawn in a child process forked for them, while this process draws the
  PNGs. A fork inherits the figures as they are (nothing is pickled but the SVG bytes
  that come back), and only from a parent that runs no other thread (a lone thread
  holds no lock the child could inherit locked), on Linux, with two cores to use. Where
  it cannot fork, or the child fails, the SVGs are drawn here: the bytes are the same.
"""

from __future__ import annotations

import io
import logging
import os
import pickle
import sys
import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from sonarproc.report import style

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["PNG_COMPRESSION", "figure_bytes", "figures_bytes"]

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
    figures: Sequence[tuple[str, Figure]], formats: Sequence[str]
) -> dict[str, bytes]:
    """``{"STEM.FMT": bytes}`` for every ``(STEM, figure)`` in every format of ``formats``,
    in that order; the same bytes as :func:`figure_bytes` of each."""
    from concurrent.futures import Future, ThreadPoolExecutor

    # fork before this process starts a thread of its own (the PNG encoder)
    svg_child = _SvgChild.start([f for _, f in figures]) if _can_fork(formats) else None
    drawn: dict[str, bytes | Future[bytes]] = {}
    try:
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="png") as encoder:
            for stem, fig in figures:
                for fmt in formats:
                    if fmt == "png":
                        drawn[f"{stem}.png"] = encoder.submit(_encode_png, _agg_pixels(fig))
                    elif fmt != "svg" or svg_child is None:
                        drawn[f"{stem}.{fmt}"] = figure_bytes(fig, fmt)
    finally:
        svgs = svg_child.collect() if svg_child is not None else None
    if svg_child is not None:
        if svgs is None:  # the child failed: draw them here
            svgs = [figure_bytes(fig, "svg") for _, fig in figures]
        drawn.update({f"{stem}.svg": data for (stem, _), data in zip(figures, svgs, strict=True)})
    return {
        f"{stem}.{fmt}": _result(drawn[f"{stem}.{fmt}"]) for stem, _ in figures for fmt in formats
    }


def _result(value: Any) -> bytes:
    return value if isinstance(value, bytes) else bytes(value.result())


def _can_fork(formats: Sequence[str]) -> bool:
    """Whether the SVGs may be drawn in a forked child: there are other formats to draw
    meanwhile, two cores to draw on, and a fork is safe (Linux, no other thread)."""
    if "svg" not in formats or len(formats) < 2 or sys.platform != "linux":
        return False
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else 1
    return cores >= 2 and threading.active_count() == 1 and hasattr(os, "fork")


class _SvgChild:
    """A forked child drawing figures as SVG; :meth:`collect` reads its bytes."""

    def __init__(self, pid: int, fd: int) -> None:
        self.pid, self.fd = pid, fd

    @classmethod
    def start(cls, figures: Sequence[Figure]) -> _SvgChild | None:
        """Fork a child that sends back ``[figure_bytes(f, "svg") for f in figures]``."""
        read_fd, write_fd = os.pipe()
        try:
            pid = os.fork()
        except OSError as err:  # no memory or process left: draw them here
            log.debug("figures: no child for the SVGs (%s)", err)
            os.close(read_fd)
            os.close(write_fd)
            return None
        if pid == 0:  # the child: draw, send, and leave without running any exit handler
            _child_main(figures, read_fd, write_fd)
        os.close(write_fd)
        return cls(pid, read_fd)

    def collect(self) -> list[bytes] | None:
        """The child's SVGs, or None if it failed."""
        with os.fdopen(self.fd, "rb") as pipe:
            payload = pipe.read()
        _, status = os.waitpid(self.pid, 0)
        if status != 0 or not payload:
            log.debug("figures: the SVG child failed (status %d)", status)
            return None
        svgs = pickle.loads(payload)  # our own child's list of bytes
        return [bytes(s) for s in svgs]


def _child_main(figures: Sequence[Figure], read_fd: int, write_fd: int) -> None:
    code = 1
    try:
        os.close(read_fd)
        payload = pickle.dumps([figure_bytes(f, "svg") for f in figures])
        with os.fdopen(write_fd, "wb") as pipe:
            pipe.write(payload)
        code = 0
    finally:
        os._exit(code)


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

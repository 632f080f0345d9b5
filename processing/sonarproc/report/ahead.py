"""A run's figures drawn ahead, in a forked child, while the run finishes.

Drawing a run's figures (:func:`sonarproc.report.plots.render_figures`) first costs
importing matplotlib, loading its font and the first figure's other first-use costs,
then the drawing itself. None of it needs the run's fit or quality. So ``sonarproc run``
forks a child as it starts (:meth:`AheadFigures.start`), before it loads the modules of
its stages: the child pays matplotlib's start-up on the second core (:func:`warm_up`)
while the run loads, reads and maps, then waits. As the arc map is built, before its fit,
the run hands the child the map (:meth:`AheadFigures.send_map`) and the child draws the
arc map figure while this process fits. As the quality stage starts, the run hands the
child what its other figures show (:meth:`AheadFigures.send`: a
:class:`~sonarproc.report.plots.ResultView`, text and arrays pickled into an in-memory
file, no pipe to block on), and the child draws them while this process measures. The
child never loads the modules that fitted the result: a view holds no fit or surface
object. The result sent says whether the map sent first is the result's (a default run's
one-curve map is handed on to ``--auto``, whose map is another: the child then draws it
again). The report collects the bytes (:meth:`AheadFigures.collect`); a result not sent
by then is sent there, which still spares the run the import. The bytes are those
:func:`~sonarproc.report.plots.render_figures` gives on the finished result: nothing a
figure shows changes after the result is sent (tested).

Nothing is forked where a fork is unsafe or gains nothing
(:func:`~sonarproc.report.drawing.fork_is_safe`: Linux, one thread, two cores, no pool);
the report then draws its figures itself, as it does when the child fails or when the
result it drew is not the one reported.
"""

from __future__ import annotations

import gc
import logging
import os
import pickle
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sonarproc.pipeline.mapping import MappedStage
from sonarproc.pipeline.result import RunResult
from sonarproc.report.drawing import DrawingChild, figures_bytes, fork_is_safe
from sonarproc.report.plots import ArcMapView, ResultView

__all__ = ["AheadFigures"]

log = logging.getLogger(__name__)


class AheadFigures:
    """A forked child that draws one result's figures in ``formats`` when it is sent;
    the arc map's as soon as the map is (:meth:`send_map`), if it is sent first."""

    def __init__(
        self,
        child: DrawingChild,
        go_fd: int,
        payload_fd: int,
        formats: tuple[str, ...],
        map_fd: int = -1,
    ) -> None:
        self._child: DrawingChild | None = child
        self._go_fd, self._payload_fd, self._map_fd = go_fd, payload_fd, map_fd
        self.formats = formats
        self._sent: tuple[RunResult, Mapping[str, Any] | None] | None = None
        self._map_sent: ArcMapView | None = None

    @classmethod
    def start(cls, formats: Sequence[str]) -> AheadFigures | None:
        """Fork the child, which imports matplotlib and waits for a map or a result.

        Returns None (no child) when there is nothing to draw or no child may be forked.
        """
        shown = tuple(formats)
        if not shown or not fork_is_safe() or not hasattr(os, "memfd_create"):
            return None
        try:
            payload_fd = os.memfd_create("sonarproc-figures", os.MFD_CLOEXEC)
        except OSError as err:  # a kernel without memfd: the report draws them
            log.debug("figures: not drawn ahead (%s)", err)
            return None
        try:
            map_fd = os.memfd_create("sonarproc-arcmap", os.MFD_CLOEXEC)
        except OSError as err:
            log.debug("figures: not drawn ahead (%s)", err)
            os.close(payload_fd)
            return None
        go_read, go_write = os.pipe()

        def draw() -> dict[str, bytes]:
            os.close(go_write)  # so that a parent gone without sending is an end of file
            return _draw_when_sent(go_read, payload_fd, map_fd, shown)

        child = DrawingChild.start_work(draw)
        os.close(go_read)
        if child is None:
            for fd in (go_write, payload_fd, map_fd):
                os.close(fd)
            return None
        log.debug("figures: drawn ahead in child %d", child.pid)
        return cls(child, go_write, payload_fd, shown, map_fd)

    def send_map(self, mapped: MappedStage) -> None:
        """Hand the child the arc map as it is built (before its fit): it draws the arc
        map figure meanwhile. Only before any result; a map that cannot be sent stops
        the child."""
        if self._child is None or self._sent is not None or self._map_sent is not None:
            return
        view = ArcMapView(
            mapped.source, mapped.mmap.evidence, mapped.beams.robot_xy,
            tuple(float(v) for v in mapped.grid.extent),  # type: ignore[arg-type]
            int(mapped.counts.get("readings_used", 0)),
        )  # fmt: skip
        self._map_sent = view
        try:
            with os.fdopen(os.dup(self._map_fd), "wb") as fh:
                pickle.dump(view, fh, protocol=5)
            os.write(self._go_fd, b"m")
        except (OSError, pickle.PicklingError, TypeError, AttributeError) as err:
            log.debug("figures: not drawn ahead (%s)", err)
            self.cancel()

    def send(self, result: RunResult, auto: Mapping[str, Any] | None = None) -> None:
        """Hand ``result`` (and ``--auto``'s record) to the child, which starts drawing.

        Only the first result is sent; a result that cannot be pickled stops the child.
        """
        if self._child is None or self._sent is not None:
            return
        self._sent = (result, auto)
        # the arc map figure drawn ahead is this result's, or the child draws it again
        # (a default run's one-curve map handed on to --auto: its map is another)
        arc = ArcMapView.of(result)
        drawn = self._map_sent is not None and self._map_sent.same_as(arc)
        try:
            with os.fdopen(os.dup(self._payload_fd), "wb") as fh:  # no copy in memory
                payload = (None if drawn else arc, ResultView.of(result, auto=auto))
                pickle.dump(payload, fh, protocol=5)
            os.write(self._go_fd, b"r")
        except (OSError, pickle.PicklingError, TypeError, AttributeError) as err:
            log.debug("figures: not drawn ahead (%s)", err)
            self.cancel()
            return
        self._close_fds()

    def collect(
        self,
        result: RunResult,
        formats: Sequence[str],
        auto: Mapping[str, Any] | None = None,
    ) -> dict[str, bytes] | None:
        """The figures' bytes, as :func:`~sonarproc.report.plots.render_figures` of
        ``result`` in ``formats`` with ``auto`` gives them; None when the child failed,
        was collected already, or was sent another result (it is then stopped)."""
        if self._child is None:
            return None
        if tuple(formats) != self.formats:
            self.cancel()
            return None
        self.send(result, auto)  # a result not sent yet (no quality stage): sent now
        if self._sent is None or self._sent[0] is not result or self._sent[1] != auto:
            self.cancel()
            return None
        child, self._child = self._child, None
        return child.collect() if child is not None else None

    def cancel(self) -> None:
        """Stop the child, if it still runs: its figures are not wanted."""
        child, self._child = self._child, None
        self._close_fds()
        if child is not None:
            child.cancel()

    def _close_fds(self) -> None:
        for fd in (self._go_fd, self._payload_fd, self._map_fd):
            if fd >= 0:
                os.close(fd)
        self._go_fd = self._payload_fd = self._map_fd = -1


def _draw_when_sent(
    go_fd: int, payload_fd: int, map_fd: int, formats: tuple[str, ...]
) -> dict[str, bytes]:
    """In the child: import what drawing needs, wait for the arc map or the result; draw
    the arc map's figure as soon as the map comes, the others when the result does."""
    from sonarproc.runtime import loading_modules

    with loading_modules():  # the console script's: no collection while matplotlib loads
        from sonarproc.report import plots

        warm_up(formats)
    gc.freeze()  # matplotlib's modules and font, loaded for good: no collection looks at them
    tag = os.read(go_fd, 1)
    early: dict[str, bytes] = {}
    if tag == b"m":  # the arc map, before the fit: its figure is drawn meanwhile
        with os.fdopen(os.dup(map_fd), "rb") as fh:
            fh.seek(0)
            view = pickle.load(fh)  # our own parent's map
        early = figures_bytes([("arcmap", plots.arcmap_figure(view))], formats)
        tag = os.read(go_fd, 1)
    if tag != b"r":  # the parent went on without figures
        os._exit(0)
    with os.fdopen(os.dup(payload_fd), "rb") as fh:
        fh.seek(0)
        arc, view = pickle.load(fh)  # our own parent's views of its result
    if arc is not None:  # the map sent first is not the result's: drawn again
        early = {}
    # in render_figures' order: the arc map's files first
    return {**early, **plots.render_views(arc, view, formats)}


def warm_up(formats: Sequence[str]) -> None:
    """Build a small map figure with every kind of artist the run's figures have (image,
    colour bar, line, legend, title) and throw it away, after importing what saving it in
    ``formats`` needs.

    A process's first figure costs about twice a later one: matplotlib imports its
    figure, axes and projection modules (most of it), those of the colour bar, the legend
    and the image encoder, and loads the font, on first use. Paid here, while the child
    waits for the map, the run's figures are drawn at the later cost. (Drawing the figure
    too would spare the first drawing less than it costs.) What is drawn later is not
    changed by it (the caches hold modules and fonts, not pixels; the tests compare the
    bytes with figures drawn in a process that drew nothing before).
    """
    from matplotlib import font_manager
    from matplotlib.backends import backend_agg  # noqa: F401  (imported ahead: the point)
    from matplotlib.patches import Patch

    from sonarproc.report import style

    if "png" in formats:
        from PIL import PngImagePlugin  # noqa: F401  (the PNG encoder, imported ahead)
    if "svg" in formats:
        from matplotlib.backends import backend_svg  # noqa: F401
    counts = np.arange(64, dtype=np.uint16).reshape(8, 8)
    extent = (0.0, 1.0, 0.0, 1.0)
    with style.drawing():
        font_manager.findfont(style.RC["font.family"])
        fig, ax, cax = style.map_figure(extent, "a", colour_bar=64.0, legend_entries=2)
        ax.imshow(style.count_rgba(counts, 64.0), extent=extent, interpolation="none")
        assert cax is not None
        style.count_colour_bar(fig, cax, 64.0, "b", clipped=True)
        line = ax.plot([0.0, 1.0], [0.2, 0.8], ls="--", lw=style.FIT_WIDTH, label="c")[0]
        style.legend_below(fig, [Patch(color="black", label="d"), line])

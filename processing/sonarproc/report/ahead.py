"""A run's figures drawn ahead, in a forked child, while the run finishes.

Drawing a run's figures (:func:`sonarproc.report.plots.render_figures`) first costs
importing matplotlib and loading its font, then the drawing itself. Neither needs the
run's truth-free quality, which is measured last and is one of the run's longest stages.
So ``sonarproc run`` forks a child as it starts (:meth:`AheadFigures.start`), which
imports matplotlib on the second core while the run computes, then waits. As the quality
stage starts, the run hands the child its result (:meth:`AheadFigures.send`: the result
pickled into an in-memory file, no pipe to block on, less the fields no figure reads),
and the child draws while this process measures. Earlier still, as the arc map is built
and before its fit, the run hands the child the map (:meth:`AheadFigures.send_map`), and
the child draws the arc map figure while this process fits; the result sent later says
whether that map is the result's (a default run's one-curve map is handed on to
``--auto``, whose map is another: the child then draws it again). The report collects the bytes
(:meth:`AheadFigures.collect`); a result not sent by then is sent there, which still
spares the run the import. The bytes are those
:func:`~sonarproc.report.plots.render_figures` gives on the finished result: nothing a
figure shows changes after the result is sent (tested).

Nothing is forked where a fork is unsafe or gains nothing
(:func:`~sonarproc.report.drawing.fork_is_safe`: Linux, one thread, two cores, no pool);
the report then draws its figures itself, as it does when the child fails or when the
result it drew is not the one reported.
"""

from __future__ import annotations

import logging
import os
import pickle
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from sonarproc.pipeline.mapping import MappedStage
from sonarproc.pipeline.result import RunResult
from sonarproc.report.drawing import DrawingChild, fork_is_safe
from sonarproc.report.plots import ArcMapView

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
        redraw = self._map_sent is None or not self._map_sent.same_as(ArcMapView.of(result))
        try:
            with os.fdopen(os.dup(self._payload_fd), "wb") as fh:  # no copy in memory
                payload = (_for_figures(result), self.formats, auto, redraw)
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


def _for_figures(result: RunResult) -> RunResult:
    """``result`` less the arrays no figure reads (the map's echo points), to pickle."""
    empty = np.zeros(0)
    return replace(result, points_x=empty, points_y=empty, quality=None)


def _draw_when_sent(
    go_fd: int, payload_fd: int, map_fd: int, formats: tuple[str, ...]
) -> dict[str, bytes]:
    """In the child: import what drawing needs, wait for the arc map or the result; draw
    the arc map's figure as soon as the map comes, the others when the result does."""
    from matplotlib import font_manager
    from matplotlib.backends import backend_agg  # noqa: F401  (imported ahead: the point)

    from sonarproc.report import plots, style
    from sonarproc.report.drawing import figures_bytes

    with style.drawing():
        font_manager.findfont(style.RC["font.family"])
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
        result, formats, auto, redraw = pickle.load(fh)  # our own parent's result
    if redraw:
        early = {}
    skip = () if redraw else ("arcmap",)
    # in render_figures' order: the arc map's files first
    return {**early, **plots.render_figures(result, formats, auto=auto, skip=skip)}

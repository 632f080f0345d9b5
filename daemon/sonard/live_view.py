"""``sonard --foxglove``: serve readings, pose and path live from the acquisition process.

The view never slows acquisition. It sees the rows on their way to the log: a
:class:`TeeWriter` around the log writer runs in the writer thread
(:class:`sonard.writer_thread.LogSink`), never in the serial loop, and only *offers* each
batch to a bounded queue (:data:`QUEUE_BATCHES`); when the queue is full the batch is
dropped from the view (the log keeps it) and counted. A thread of the view turns the
batches into Foxglove messages (:class:`sonarlog.foxglove_messages.RobotPublisher`), and
the SDK's server sends them from its own threads, dropping the oldest messages of a
client that falls :data:`BACKLOG_MESSAGES` behind (or disconnecting it): a stalled
viewer costs the daemon nothing but that memory.
"""

from __future__ import annotations

import contextlib
import logging
import queue
import threading
import time
from typing import Any

import numpy as np

from sonard.writer_thread import Writer
from sonarlog.foxglove_server import BACKLOG_MESSAGES, start_server

__all__ = ["BACKLOG_MESSAGES", "QUEUE_BATCHES", "LiveView", "TeeWriter"]

log = logging.getLogger(__name__)

#: Batches waiting for the view's thread: the writer thread hands over a batch per
#: sonar reply, so this is many seconds of readings at any firing rate.
QUEUE_BATCHES = 256
_STOP = object()


class LiveView:
    """A Foxglove WebSocket server fed from the log writer's thread.

    Parameters
    ----------
    host, port : str, int
        Where to listen (port 0: a free one, see :attr:`port`).
    sensors : numpy.ndarray
        The ring's ``/sensors`` table.
    speed_of_sound : float
        m/s.

    Raises
    ------
    ImportError
        ``foxglove-sdk`` is not installed.
    OSError
        The port cannot be bound.
    """

    def __init__(self, host: str, port: int, sensors: np.ndarray, speed_of_sound: float) -> None:
        import foxglove

        from sonarlog.foxglove_messages import RobotPublisher

        self.context = foxglove.Context()
        self.robot = RobotPublisher(sensors, speed_of_sound, context=self.context)
        self._queue: queue.Queue[Any] = queue.Queue(maxsize=QUEUE_BATCHES)
        self.dropped_batches = 0
        self._server = start_server("sonard", host, port, self.context, self._on_subscribe)
        self.host = host
        self._thread = threading.Thread(target=self._run, name="sonard-foxglove", daemon=True)
        self._thread.start()

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self._server.port)

    def tee(self, writer: Writer) -> TeeWriter:
        """``writer`` with this view listening to its readings and poses."""
        return TeeWriter(writer, self)

    def offer(self, kind: str, rows: np.ndarray) -> None:
        """Queue a batch for the view, or drop it at once when the queue is full."""
        try:
            self._queue.put_nowait((kind, rows))
        except queue.Full:
            self.dropped_batches += 1

    def _on_subscribe(self, topic: str) -> None:
        self.offer(topic, np.zeros(0))  # the view's thread resends that topic's state

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            kind, rows = item
            try:
                if kind == "r":
                    self.robot.readings(rows)
                elif kind == "p":
                    self.robot.poses(rows)
                else:
                    self.robot.resend(frozenset([kind]), time.time())
            except Exception as exc:  # a view problem must never reach acquisition
                log.warning("live view: %s: %s", type(exc).__name__, exc)

    def close(self) -> None:
        """Stop the thread and the server (clients are disconnected)."""
        with contextlib.suppress(queue.Full):  # a wedged thread: the server stops anyway
            self._queue.put(_STOP, timeout=1.0)
        self._thread.join(timeout=2.0)
        self._server.stop()
        if self.dropped_batches:
            log.info("live view: %d batch(es) not shown (view busy)", self.dropped_batches)


class TeeWriter:
    """A log writer that also offers its readings and poses to a :class:`LiveView`."""

    def __init__(self, writer: Writer, view: LiveView) -> None:
        self._writer = writer
        self._view = view

    def append(self, readings: np.ndarray) -> None:
        """Append to the log, then offer the rows to the view."""
        self._writer.append(readings)
        self._view.offer("r", readings)

    def append_poses(self, poses: np.ndarray) -> None:
        """Append to the log, then offer the poses to the view."""
        self._writer.append_poses(poses)
        self._view.offer("p", poses)

    def event(self, kind: str, detail: str = "", t: float | None = None) -> None:
        """Append an event to the log."""
        self._writer.event(kind, detail, t)

    def flush(self) -> None:
        """Flush the log."""
        self._writer.flush()

    def close(self) -> None:
        """Close the log."""
        self._writer.close()

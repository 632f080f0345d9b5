"""A thread that owns the log writer, so the serial loop never waits on the disk.

The acquisition loop calls :meth:`LogSink.readings`, :meth:`LogSink.poses` and
:meth:`LogSink.event`; each puts one item on an unbounded queue and returns at once. The
thread drains the queue into :class:`sonarlog.LogWriter`, whose own threads push its
buffer to the file every ``flush_interval`` and fsync after each push: so a reading is in
the file about ``flush_interval`` after it was queued (what bounds the loss on SIGKILL) and
on stable storage one fsync later (power failure).

At the end of a run :meth:`LogSink.close` waits for the queue to drain as long as the
thread keeps writing (a loaded machine drains slowly but loses nothing queued), and gives
up only on a writer that wrote nothing for :data:`WRITER_STUCK_S`.
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from sonard.logclock import LogClock

__all__ = ["WRITER_STUCK_S", "LogSink", "LogWriteError", "Writer"]

log = logging.getLogger(__name__)

_STOP = object()

#: a writer that takes no queued record for this long (s) is stuck, not slow. An append only
#: copies rows into the writer's buffer, or waits for its lock while the writer's own thread
#: pushes a batch to the file (an HDF5 write without fsync: well under a second on a busy
#: disk). No record in 3 s is a hung disk (a dead USB stick, a hung network mount); 3 s
#: also leaves the writer's own close inside systemd's 5 s stop timeout.
WRITER_STUCK_S = 3.0
#: how often close looks at the writer's progress (s)
_CLOSE_POLL_S = 0.05


class LogWriteError(RuntimeError):
    """The log cannot be written any more (disk full, I/O error): the run must stop.

    ``reason`` is the operating system's words (``No space left on device``).
    """

    def __init__(self, reason: str) -> None:
        super().__init__(f"cannot write the log: {reason}")
        self.reason = reason


class Writer(Protocol):
    """The part of :class:`sonarlog.LogWriter` the sink uses."""

    def append(self, readings: np.ndarray) -> None: ...
    def append_poses(self, poses: np.ndarray) -> None: ...
    def event(self, kind: str, detail: str = "", t: float | None = None) -> None: ...
    def flush(self) -> None: ...
    def close(self) -> None: ...


class LogSink:
    """Queue records for a writer running in a background thread.

    Parameters
    ----------
    writer : Writer
        Usually a :class:`sonarlog.LogWriter`; the sink closes it in :meth:`close`.
    clock : callable, optional
        The log's UNIX time (default a :class:`sonard.logclock.LogClock`: it never jumps
        when the system clock is stepped); events are stamped with it.
    """

    def __init__(self, writer: Writer, clock: Callable[[], float] | None = None) -> None:
        self._writer = writer
        self.clock: Callable[[], float] = clock or LogClock()
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._error: BaseException | None = None
        self.n_readings = 0
        #: records (readings, poses, events) the thread has handed to the writer so far
        self.n_written = 0
        self._thread = threading.Thread(target=self._run, name="sonard-writer", daemon=True)
        self._thread.start()

    def check(self) -> None:
        """Raise :class:`LogWriteError` once the writer failed."""
        err = self.error
        if err is not None:
            reason = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
            raise LogWriteError(reason) from err

    @property
    def error(self) -> BaseException | None:
        """The exception that stopped the writer, if any (its own or the writer's threads')."""
        return self._error or getattr(self._writer, "error", None)

    def readings(self, rows: np.ndarray) -> None:
        """Queue readings (READING_DTYPE); empty arrays are ignored."""
        if len(rows):
            self.n_readings += len(rows)
            self._queue.put(("r", rows))

    def poses(self, rows: np.ndarray) -> None:
        """Queue poses (POSE_DTYPE)."""
        if len(rows):
            self._queue.put(("p", rows))

    def event(self, kind: str, detail: str = "", t: float | None = None) -> None:
        """Queue an event, stamped now (the log's UNIX time) unless ``t`` is given."""
        self._queue.put(("e", (kind, detail, self.clock() if t is None else t)))

    def _run(self) -> None:
        w = self._writer
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            kind, payload = item
            if self._error is not None and kind != "e":
                continue  # keep draining so producers never block; events still explain
            try:
                if kind == "r":
                    w.append(payload)
                elif kind == "p":
                    w.append_poses(payload)
                else:
                    w.event(*payload)
                self.n_written += 1 if kind == "e" else len(payload)
            except Exception as exc:  # disk full, I/O error: report once, keep the loop alive
                if self._error is None:
                    log.debug("log writer failed: %s", exc)
                    self._error = exc

    def close(self, stuck_s: float = WRITER_STUCK_S) -> None:
        """Drain the queue, then flush and close the writer.

        The drain is waited for as long as the writer makes progress (:attr:`n_written`
        keeps increasing), however slowly a loaded machine drains it. A writer that writes
        nothing for ``stuck_s`` seconds is stuck: the records still queued are lost (logged
        as an error) and the writer is closed.

        Parameters
        ----------
        stuck_s : float
            How long the writer may make no progress before the drain is given up (s).
            Counted in waits of this thread, so a process stopped and continued (SIGSTOP)
            does not count its stop against the writer.

        Raises
        ------
        Exception
            Whatever the writer raised while appending or closing.
        """
        self._queue.put(_STOP)
        polls_left = stuck_polls = max(1, round(stuck_s / _CLOSE_POLL_S))
        written = self.n_written
        while True:
            self._thread.join(_CLOSE_POLL_S)
            if not self._thread.is_alive():
                break
            if self.n_written != written:
                written, polls_left = self.n_written, stuck_polls
                continue
            polls_left -= 1
            if polls_left <= 0:
                log.error(
                    "log writer stuck: nothing written for %.1f s, queued records lost", stuck_s
                )
                break
        try:
            self._writer.close()
        except Exception as exc:
            self._error = self._error or exc
        if self._error is not None:
            raise self._error

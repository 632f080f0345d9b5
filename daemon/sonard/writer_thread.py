"""A thread that owns the log writer, so the serial loop never waits on the disk.

The acquisition loop calls :meth:`LogSink.readings`, :meth:`LogSink.poses` and
:meth:`LogSink.event`; each puts one item on an unbounded queue and returns at once. The
thread drains the queue into :class:`sonarlog.LogWriter`, whose own threads push its
buffer to the file every ``flush_interval`` and fsync after each push: so a reading is in
the file about ``flush_interval`` after it was queued (what bounds the loss on SIGKILL) and
on stable storage one fsync later (power failure).
"""

from __future__ import annotations

import logging
import queue
import threading
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from sonard.logclock import LogClock

__all__ = ["LogSink", "LogWriteError", "Writer"]

log = logging.getLogger(__name__)

_STOP = object()


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
            except Exception as exc:  # disk full, I/O error: report once, keep the loop alive
                if self._error is None:
                    log.debug("log writer failed: %s", exc)
                    self._error = exc

    def close(self, timeout: float = 1.5) -> None:
        """Drain the queue, then flush and close the writer (waits at most ``timeout`` s).

        Raises
        ------
        Exception
            Whatever the writer raised while appending or closing.
        """
        self._queue.put(_STOP)
        self._thread.join(timeout)
        if self._thread.is_alive():
            log.error("log writer did not drain within %.1f s", timeout)
        try:
            self._writer.close()
        except Exception as exc:
            self._error = self._error or exc
        if self._error is not None:
            raise self._error

"""Serve an emulated Nomad 200 on a real pseudo-terminal.

The host opens the pty's slave side like any serial device. The server keeps its own
handle on the slave so hosts may come and go. An unplug closes the master (the host sees
EIO/hangup), removes the ``--link`` symlink and, after the outage, makes a new pty and
points the link at it: exactly what a USB serial adapter does when pulled and replugged.
"""

from __future__ import annotations

import contextlib
import logging
import os
import select
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass

from nomad200.emulator.link import Link

__all__ = ["PtyServer"]

logger = logging.getLogger(__name__)


@dataclass
class _Out:
    due: float  # monotonic time to write
    t: float  # link-clock time the bytes arrive (virtual in fast mode)
    data: bytes


class PtyServer:
    """A :class:`Link` served on a pseudo-terminal.

    Parameters
    ----------
    link : Link
        Model and line timing. Its model clock must be real monotonic time unless ``fast``.
    fast : bool
        Virtual time: write replies at once and advance the model clock to their arrival.
    link_path : str, optional
        Keep a symlink here pointing to the current pty.
    unplug_at, unplug_for : float, optional
        Seconds after the host's first bytes, vanish for ``unplug_for`` seconds (counted
        from the host's first bytes, not from start-up: a host slow to start, on a loaded
        machine, still meets the unplug in the middle of its run).
    on_replug : callable, optional
        Called with the new pty path after a replug.
    """

    def __init__(
        self,
        link: Link,
        *,
        fast: bool = False,
        link_path: str | None = None,
        unplug_at: float | None = None,
        unplug_for: float = 2.0,
        on_replug: Callable[[str], None] | None = None,
    ) -> None:
        self.link = link
        self.model = link.model
        self.fast = fast
        self.link_path = link_path
        self.unplug_at = unplug_at
        self.unplug_for = unplug_for
        self.on_replug = on_replug
        self.path: str | None = None
        self._master = -1
        self._slave = -1
        self._out: list[_Out] = []
        self._last_rx = -float("inf")  # monotonic time of the last bytes from the host
        self._first_rx = float("inf")  # ... and of the first

    @property
    def host_seen(self) -> bool:
        """Whether the host has sent anything yet (fault schedules start from there)."""
        return self._first_rx != float("inf")

    # ------------------------------------------------------------ pty lifecycle
    def open(self) -> str:
        """Create the pty (and link); return the slave's path."""
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self._master, self._slave = master, slave
        self.path = os.ttyname(slave)
        if self.link_path:
            tmp = f"{self.link_path}.{os.getpid()}.tmp"
            try:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(tmp)
                os.symlink(self.path, tmp)
                os.replace(tmp, self.link_path)
            except OSError as err:
                self.close()
                # OSError's own text names both paths of the symlink: say which one failed
                raise OSError(
                    err.errno, f"cannot create the link {self.link_path}: {err.strerror}"
                ) from err
        logger.info("serving on %s", self.path)
        return self.path

    def close(self) -> None:
        """Close the pty and remove the link."""
        for fd in (self._master, self._slave):
            if fd >= 0:
                with contextlib.suppress(OSError):
                    os.close(fd)
        self._master = self._slave = -1
        self._out.clear()
        if self.link_path:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.link_path)

    # ------------------------------------------------------------ loop
    def serve(self, stop: threading.Event) -> None:
        """Answer the host until ``stop`` is set."""
        unplug_done = self.unplug_at is None
        clock = self.model.clock
        last_tick = 0.0
        while not stop.is_set():
            now = time.monotonic()
            if not unplug_done and now - self._first_rx >= (self.unplug_at or 0.0):
                unplug_done = True
                self._outage(stop)
                continue
            timeout = 0.05
            if self._out:
                timeout = max(0.0, min(timeout, self._out[0].due - now))
            try:
                ready, _, _ = select.select([self._master], [], [], timeout)
            except (OSError, ValueError):  # pragma: no cover - fd closed under us
                return
            if ready:
                try:
                    data = os.read(self._master, 4096)
                except (BlockingIOError, InterruptedError):
                    data = b""
                except OSError as err:  # pragma: no cover - only without a slave handle
                    logger.warning("pty read: %s", err)
                    data = b""
                if data:
                    self._accept(data)
            self._flush()
            if not self.fast and time.monotonic() - last_tick > 0.05:
                last_tick = time.monotonic()
                self.model.advance(clock())

    def _accept(self, data: bytes) -> None:
        clock = self.model.clock
        now_real = time.monotonic()
        # the line's real silence: in fast mode the link clock does not see the host wait
        quiet = now_real - self._last_rx
        self._last_rx = now_real
        self._first_rx = min(self._first_rx, now_real)
        for d in self.link.receive(data, clock(), quiet=quiet):
            if self.fast:
                extra = self.link.faults.stall_s if d.stalled else 0.0
                self._out.append(_Out(now_real + extra, d.t, d.data))
            else:
                self._out.append(_Out(d.t, d.t, d.data))
        self._out.sort(key=lambda o: o.due)

    def _flush(self) -> None:
        now = time.monotonic()
        while self._out and self._out[0].due <= now:
            o = self._out[0]
            if self.fast:
                adv = getattr(self.model.clock, "advance_to", None)
                if adv is not None:
                    adv(o.t)
            try:
                n = os.write(self._master, o.data)
            except BlockingIOError:
                return
            except OSError as err:  # pragma: no cover
                logger.warning("pty write: %s", err)
                self._out.pop(0)
                continue
            if n < len(o.data):
                o.data = o.data[n:]
                return
            self._out.pop(0)

    def _outage(self, stop: threading.Event) -> None:
        logger.warning("unplug: port gone for %.3g s", self.unplug_for)
        self.model.emit({"type": "unplug", "t": self.model.clock_ms() / 1000.0})
        self.close()
        if stop.wait(self.unplug_for):
            return
        path = self.open()
        if not self.fast:
            self.model.advance()
        self.model.emit({"type": "replug", "t": self.model.clock_ms() / 1000.0, "path": path})
        logger.warning("replug: serving on %s", path)
        if self.on_replug is not None:
            self.on_replug(path)

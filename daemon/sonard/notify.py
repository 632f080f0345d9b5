"""systemd notification protocol (sd_notify) with the standard library only.

systemd passes ``$NOTIFY_SOCKET``: a path to a unix datagram socket, or an abstract socket
name starting with ``@`` (sent as a leading NUL byte). Each message is a newline-separated
list of ``KEY=VALUE`` assignments: ``READY=1``, ``WATCHDOG=1``, ``STOPPING=1``,
``STATUS=...``. Without the variable every call is a no-op, so the daemon runs the same way
from a shell. ``$WATCHDOG_USEC`` (and ``$WATCHDOG_PID``) say how often systemd expects
``WATCHDOG=1``; :meth:`Notifier.watchdog` rate-limits itself to half of that.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
from collections.abc import Callable, Mapping

__all__ = ["Notifier"]

log = logging.getLogger(__name__)


class Notifier:
    """Send sd_notify messages to the socket named in the environment.

    Parameters
    ----------
    env : Mapping[str, str], optional
        Where to read ``NOTIFY_SOCKET``, ``WATCHDOG_USEC`` and ``WATCHDOG_PID``
        (default ``os.environ``).
    clock : callable, optional
        Monotonic clock for the watchdog rate limit.

    Examples
    --------
    >>> Notifier(env={}).ready()   # no socket: does nothing
    False
    """

    def __init__(
        self,
        env: Mapping[str, str] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        env = os.environ if env is None else env
        addr = env.get("NOTIFY_SOCKET", "")
        self._address: str | bytes | None = None
        if addr.startswith("@"):
            self._address = b"\0" + addr[1:].encode()
        elif addr.startswith("/"):
            self._address = addr
        elif addr:
            log.warning("ignoring NOTIFY_SOCKET %r: neither a path nor an abstract name", addr)
        self._clock = clock
        usec = env.get("WATCHDOG_USEC", "")
        pid = env.get("WATCHDOG_PID", "")
        wd = int(usec) if usec.isdigit() else 0
        if pid and pid.isdigit() and int(pid) != os.getpid():
            wd = 0
        #: seconds between WATCHDOG=1 pings (half the configured WatchdogSec), 0 = no watchdog
        self.watchdog_period = wd / 2e6
        self._last_ping = -float("inf")
        self._sock: socket.socket | None = None
        self._ready = False
        self._stopping = False
        # The poll loop pings from its own thread; STOPPING=1 must be the last word.
        self._lock = threading.Lock()

    @property
    def enabled(self) -> bool:
        """Whether a notify socket was given."""
        return self._address is not None

    def send(self, *assignments: str) -> bool:
        """Send ``KEY=VALUE`` assignments in one datagram; return whether one was sent.

        Errors are logged and swallowed: notification must never stop acquisition.
        """
        if self._address is None:
            return False
        try:
            if self._sock is None:
                self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            # never wait: a notify socket nobody drains (a hung manager) must not stall the
            # poll loop; a full queue drops this datagram (the next ping comes soon)
            self._sock.sendto("\n".join(assignments).encode(), socket.MSG_DONTWAIT, self._address)
        except OSError as exc:
            log.warning("sd_notify failed: %s", exc)
            return False
        return True

    def ready(self, status: str = "") -> bool:
        """Tell systemd start-up finished (``READY=1``)."""
        self._ready = True
        return self.send("READY=1", *((f"STATUS={status}",) if status else ()))

    def status(self, text: str) -> bool:
        """Set the free-text status shown by ``systemctl status``."""
        return self.send(f"STATUS={text}")

    def watchdog(self, *, force: bool = False) -> bool:
        """Ping the watchdog (``WATCHDOG=1``) at most every half ``WatchdogSec``.

        Nothing is sent before :meth:`ready` (start-up is bounded by TimeoutStartSec), nor
        after :meth:`stopping`.
        """
        with self._lock:
            if self._stopping or ((self.watchdog_period <= 0 or not self._ready) and not force):
                return False
            now = self._clock()
            if not force and now - self._last_ping < self.watchdog_period:
                return False
            self._last_ping = now
            return self.send("WATCHDOG=1")

    def stopping(self, status: str = "") -> bool:
        """Tell systemd the service is shutting down (``STOPPING=1``); no ping follows it."""
        with self._lock:
            self._stopping = True
            return self.send("STOPPING=1", *((f"STATUS={status}",) if status else ()))

    def close(self) -> None:
        """Close the socket (sends nothing)."""
        if self._sock is not None:
            self._sock.close()
            self._sock = None

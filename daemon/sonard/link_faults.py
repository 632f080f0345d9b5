"""Link faults: what counts as a lost port, and reconnecting to the robot with backoff.

A garbled or missing reply is one exchange failing; the link is *lost* when no good reply
arrived for :data:`LINK_LOST_S` or the port itself went away (:func:`is_link_error`).
:func:`reconnect` then closes and reopens the port with exponential backoff (0.1 s
doubling to 2 s) until the robot answers again or the fault timeout has passed. The
outcomes are exceptions the plan's steps see: :class:`Resume` (restart the current step
from its recorded progress), :class:`FaultAbort` (the link stayed down) and
:class:`Stopped` (SIGTERM/SIGINT meanwhile).
"""

from __future__ import annotations

import logging
import termios
import threading
import time
from collections.abc import Callable
from typing import Any

from serial import SerialException

from nomad200 import NomadDisconnected, NomadError

__all__ = [
    "LINK_ERRORS",
    "LINK_LOST_S",
    "FaultAbort",
    "Resume",
    "Stopped",
    "is_link_error",
    "reconnect",
]

log = logging.getLogger(__name__)

#: no good reply for this long (s) means the link is lost
LINK_LOST_S = 1.0
#: errors that mean the port went away (the driver may let a raw termios/OS error through)
LINK_ERRORS = (NomadDisconnected, OSError, termios.error, SerialException)


def is_link_error(exc: BaseException) -> bool:
    """Whether ``exc`` means the port went away, rather than one exchange failing.

    ``NomadTimeout`` is a ``TimeoutError`` and so an ``OSError``, but a missing reply is the
    line's fault, not the port's: it is retried, and only a link silent for longer than
    :data:`LINK_LOST_S` is treated as lost.
    """
    if isinstance(exc, NomadError):
        return isinstance(exc, NomadDisconnected)
    return isinstance(exc, LINK_ERRORS)


class Resume(Exception):
    """The link came back after a fault: restart the current step from its progress."""


class Stopped(Exception):
    """A stop was requested (SIGTERM/SIGINT)."""


class FaultAbort(RuntimeError):
    """The link stayed down longer than the fault timeout."""


def reconnect(
    client: Any,
    *,
    restart: Callable[[], bool],
    stop: threading.Event,
    timeout_s: float,
    ping: Callable[[], object],
    cause: BaseException,
) -> bool:
    """Close and reopen the port with backoff until ``restart()`` succeeds.

    Parameters
    ----------
    client : Any
        The :class:`nomad200.Client` (``open`` and ``close``).
    restart : callable
        Called after each successful open: stop the robot and configure it again; returns
        whether the robot answered.
    stop : threading.Event
        Set by the signal handlers; the waits between attempts return early when it is set.
    timeout_s : float
        How long to keep trying (s).
    ping : callable
        Called once per attempt (the systemd watchdog).
    cause : BaseException
        The fault being recovered from (the ``__cause__`` of :class:`Stopped`).

    Returns
    -------
    bool
        True once the robot answers again, False when ``timeout_s`` passed without it.

    Raises
    ------
    Stopped
        When a stop was requested meanwhile.
    """
    deadline = time.monotonic() + timeout_s
    delay = 0.1
    while True:
        ping()
        if stop.is_set():
            raise Stopped
        try:
            client.close()
        except Exception as close_exc:
            log.debug("close failed: %s", close_exc)
        try:
            client.open()
        except Exception as open_exc:
            log.info("reconnect failed: %s", open_exc)
        else:
            if restart():
                return True
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return False
        if stop.wait(min(delay, remaining)):
            raise Stopped from cause
        delay = min(delay * 2, 2.0)

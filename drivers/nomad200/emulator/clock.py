"""Clocks that drive the emulator's simulated time (seconds, monotonic)."""

from __future__ import annotations

import time
from typing import Protocol

__all__ = ["Clock", "MonotonicClock", "VirtualClock"]


class Clock(Protocol):
    """Anything callable that returns monotonic seconds."""

    def __call__(self) -> float: ...


class MonotonicClock:
    """Real time: :func:`time.monotonic`."""

    virtual = False

    def __call__(self) -> float:
        return time.monotonic()


class VirtualClock:
    """Simulated time that only moves when told to (fast mode and tests).

    Examples
    --------
    >>> c = VirtualClock(10.0)
    >>> c.advance(0.5); c.advance_to(10.2); c()
    10.5
    """

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def __call__(self) -> float:
        return self._t

    def advance(self, dt: float) -> None:
        """Move forward by ``dt`` seconds (negative values are ignored)."""
        if dt > 0:
            self._t += dt

    def advance_to(self, t: float) -> None:
        """Move forward to ``t`` (never backwards)."""
        if t > self._t:
            self._t = t

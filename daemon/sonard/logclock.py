"""The log's time base: UNIX time read once, carried on by the monotonic clock.

Every time sonard writes (a reading's ``t``, a pose, an event) is UNIX time, but read from
the system clock only once, at start-up; from there it advances with the monotonic clock.
So an operator or NTP stepping the system clock back or forward during a run moves no
``t`` in the log: readings stay in firing order and events keep their place among them.
:meth:`LogClock.step` tells how far the system clock has been stepped since start-up;
the acquisition loop records each step as a ``clock_step`` event.
"""

from __future__ import annotations

import time
from collections.abc import Callable

__all__ = ["CLOCK_STEP_S", "LogClock"]

#: a change of (system clock - log clock) this large between two checks is a step, not a
#: slew: NTP slews at most 0.5 ms/s and ntpd/chrony step only offsets over 0.128 s/1 s
CLOCK_STEP_S = 0.25


class LogClock:
    """UNIX time that never jumps: the wall clock at start plus monotonic time since.

    Parameters
    ----------
    wall, mono : callable, optional
        The system (UNIX) clock and the monotonic clock, injectable for tests.

    Examples
    --------
    >>> wall = iter([1000.0, 1000.0 - 3600.0]).__next__
    >>> ticks = iter([5.0, 6.0, 6.0]).__next__
    >>> c = LogClock(wall=wall, mono=ticks)
    >>> c()
    1001.0
    >>> c.step()  # the system clock went back an hour
    -3601.0
    """

    def __init__(
        self,
        wall: Callable[[], float] = time.time,
        mono: Callable[[], float] = time.monotonic,
    ) -> None:
        self._wall, self._mono = wall, mono
        self._base = wall() - mono()

    def __call__(self) -> float:
        """The log's UNIX time now (s)."""
        return self._base + self._mono()

    def step(self) -> float:
        """System clock minus log clock (s): the net step of the system clock since start."""
        return self._wall() - self()

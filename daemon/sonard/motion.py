"""Closed-loop motion primitives on top of :class:`sonard.acquisition.Acquisition`.

Every primitive drives towards an **absolute** target (a point along a line, a steering or
turret heading in the odometry frame) and re-issues a relative move (PR) from the pose it
polls whenever the robot is standing still short of the target. So a move command whose
reply was garbled, a move interrupted by ST during a fault, or a resumed step all end at
the same place. Tolerances sit just above the protocol resolution (0.1 in, 0.1 deg).

Time is the robot's: every wait here is measured on the clock in the robot's replies (the
emulator's virtual clock in fast mode), never on the host's. A host slowed by other work
polls less often, but the robot's clock and motion go on at their own pace, so a motion is
waited for as long as the robot keeps reporting progress; one that makes none for
``NO_PROGRESS_S`` of robot time fails with :class:`MotionError`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

from sonard.acquisition import FROZEN_CLOCK_REPLIES, Acquisition

__all__ = [
    "ANGLE_TOL",
    "TRANS_TOL",
    "MotionError",
    "settle",
    "translate_to",
    "turn_to",
    "wrap",
]

TRANS_TOL = 0.003
ANGLE_TOL = math.radians(0.15)
#: after a move command, how long a robot may stand still before the move is re-issued
#: (s, robot time)
GRACE_S = 0.3
#: a motion fails when its remaining error has not shrunk by one tolerance for this long
#: (robot time, s). The slowest move a plan may ask for (0.01 m/s, 1 deg/s) covers a
#: tolerance (3 mm, 0.15 deg) in 0.3 s once under way, and the Nomad accelerates to it in
#: well under a second; 5 s without progress is a robot that is blocked, not a slow one.
NO_PROGRESS_S = 5.0


class MotionError(RuntimeError):
    """The robot stopped making progress towards a target (or its clock stood still)."""


def wrap(a: float) -> float:
    """Wrap an angle to [-pi, pi).

    Examples
    --------
    >>> round(wrap(3 * math.pi / 2), 4)
    -1.5708
    """
    return (a + math.pi) % (2 * math.pi) - math.pi


def settle(
    acq: Acquisition,
    errors: Callable[[Any], Sequence[float]],
    *,
    tol: Sequence[float],
    no_progress_s: float = NO_PROGRESS_S,
) -> None:
    """Move until every axis error is within ``tol`` and the robot stands still.

    Every wait is in robot time (the clock in the replies), so a host slowed by other
    work never fails a motion the robot is still carrying out.

    Parameters
    ----------
    acq : Acquisition
        The running acquisition.
    errors : callable
        State -> (translation m, steering rad, turret rad) still to go.
    tol : sequence of float
        Per-axis tolerance.
    no_progress_s : float
        Robot seconds without progress (no axis error shrinking by its tolerance below
        the best seen) after which the motion fails.

    Raises
    ------
    MotionError
        When the robot made no progress for ``no_progress_s`` of robot time, or its clock
        stood still for ``FROZEN_CLOCK_REPLIES`` replies.
    """
    last_cmd = -math.inf
    best: list[float] | None = None
    progress_at: float | None = None
    last_clock, frozen = -math.inf, 0
    while True:
        st = acq.poll()
        now = float(st.clock)
        err = list(errors(st))
        done = all(abs(e) <= t for e, t in zip(err, tol, strict=True))
        if best is None or progress_at is None:
            best, progress_at = [abs(e) for e in err], now
        elif any(abs(e) < b - t for e, b, t in zip(err, best, tol, strict=True)):
            best = [min(b, abs(e)) for e, b in zip(err, best, strict=True)]
            progress_at = now
        if not acq.moving():
            if done:
                return
            if now - last_cmd > GRACE_S or now < last_cmd:
                cmd = [e if abs(e) > t else 0.0 for e, t in zip(err, tol, strict=True)]
                acq.move_relative(*cmd)
                last_cmd = float(acq.state.clock) if acq.state is not None else now
        frozen = frozen + 1 if now <= last_clock else 0
        if now < last_clock:  # a robot that restarted its clock: measure from here
            progress_at = now
        last_clock = now
        if frozen >= FROZEN_CLOCK_REPLIES:
            raise MotionError(f"robot clock stands still at {now:.3f} s (still {_fmt(err)})")
        if now - progress_at > no_progress_s:
            raise MotionError(
                f"no progress for {no_progress_s:g} s of robot time (still {_fmt(err)} to go)"
            )


def _fmt(err: Sequence[float]) -> str:
    """Remaining (translation, steering, turret) error in m and degrees."""
    return f"{err[0]:.3f} m, {math.degrees(err[1]):.1f} deg, {math.degrees(err[2]):.1f} deg"


def translate_to(
    acq: Acquisition, origin: tuple[float, float], heading: float, along: float, speed: float
) -> None:
    """Drive along ``heading`` until ``along`` metres past ``origin`` (signed)."""
    c, s = math.cos(heading), math.sin(heading)

    def errors(st: Any) -> tuple[float, float, float]:
        done = (st.x - origin[0]) * c + (st.y - origin[1]) * s
        return (along - done, 0.0, 0.0)

    settle(acq, errors, tol=(TRANS_TOL, 1.0, 1.0))


def turn_to(
    acq: Acquisition,
    steer: float | None,
    turret: float | None,
    speed: float,
) -> None:
    """Turn steering and/or turret to absolute headings (rad; None = leave that axis)."""

    def errors(st: Any) -> tuple[float, float, float]:
        es = 0.0 if steer is None else wrap(steer - st.steer)
        et = 0.0 if turret is None else wrap(turret - st.turret)
        return (0.0, es, et)

    settle(acq, errors, tol=(1.0, ANGLE_TOL, ANGLE_TOL))

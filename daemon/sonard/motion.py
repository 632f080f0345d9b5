"""Closed-loop motion primitives on top of :class:`sonard.acquisition.Acquisition`.

Every primitive drives towards an **absolute** target (a point along a line, a steering or
turret heading in the odometry frame) and re-issues a relative move (PR) from the pose it
polls whenever the robot is standing still short of the target. So a move command whose
reply was garbled, a move interrupted by ST during a fault, or a resumed step all end at
the same place. Tolerances sit just above the protocol resolution (0.1 in, 0.1 deg).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from sonard.acquisition import Acquisition

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
#: after a move command, how long a robot may stand still before the move is re-issued (s)
GRACE_S = 0.3


class MotionError(RuntimeError):
    """The robot did not reach a target in time."""


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
    timeout_s: float,
) -> None:
    """Move until every axis error is within ``tol`` and the robot stands still.

    Parameters
    ----------
    acq : Acquisition
        The running acquisition.
    errors : callable
        State -> (translation m, steering rad, turret rad) still to go.
    tol : sequence of float
        Per-axis tolerance.
    timeout_s : float
        Wall-clock limit.

    Raises
    ------
    MotionError
        When the target is not reached in ``timeout_s``.
    """
    last_cmd = -math.inf
    deadline = time.monotonic() + timeout_s
    while True:
        st = acq.poll()
        err = list(errors(st))
        done = all(abs(e) <= t for e, t in zip(err, tol, strict=True))
        if not acq.moving():
            if done:
                return
            if time.monotonic() - last_cmd > GRACE_S:
                cmd = [e if abs(e) > t else 0.0 for e, t in zip(err, tol, strict=True)]
                acq.move_relative(*cmd)
                last_cmd = time.monotonic()
        if time.monotonic() > deadline:
            raise MotionError(f"target not reached in {timeout_s:.0f} s (still {err})")


def translate_to(
    acq: Acquisition, origin: tuple[float, float], heading: float, along: float, speed: float
) -> None:
    """Drive along ``heading`` until ``along`` metres past ``origin`` (signed)."""
    c, s = math.cos(heading), math.sin(heading)

    def errors(st: Any) -> tuple[float, float, float]:
        done = (st.x - origin[0]) * c + (st.y - origin[1]) * s
        return (along - done, 0.0, 0.0)

    dist = abs(errors(acq.state)[0]) if acq.state is not None else abs(along)
    settle(acq, errors, tol=(TRANS_TOL, 1.0, 1.0), timeout_s=3 * dist / speed + 10.0)


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

    e = errors(acq.state) if acq.state is not None else (0.0, math.pi, math.pi)
    span = max(abs(e[1]), abs(e[2]))
    settle(acq, errors, tol=(1.0, ANGLE_TOL, ANGLE_TOL), timeout_s=3 * span / speed + 10.0)

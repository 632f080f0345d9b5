"""Motion waits run on the robot's clock: a slow host never fails a motion in progress."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace
from typing import Any

import pytest

from sonard import motion
from sonard.motion import NO_PROGRESS_S, MotionError, translate_to, turn_to


class RobotOnItsClock:
    """A robot that drives towards PR targets at ``speed`` m/s of its own clock.

    Each poll advances the robot clock by ``dt``; the host's time never enters. ``blocked``
    makes it refuse to move (a bumper against a wall).
    """

    def __init__(self, speed: float, dt: float = 0.04, blocked: bool = False) -> None:
        self.speed, self.dt, self.blocked = speed, dt, blocked
        self.target = 0.0
        self.state = SimpleNamespace(clock=0.0, x=0.0, y=0.0, steer=0.0, turret=0.0, motor=0)
        self.moves = 0

    def poll(self) -> Any:
        s = self.state
        s.clock += self.dt
        step = 0.0 if self.blocked else self.speed * self.dt
        left = self.target - s.x
        s.x += math.copysign(min(step, abs(left)), left)
        s.motor = 1 if abs(self.target - s.x) > 1e-9 and not self.blocked else 0
        return s

    def moving(self) -> bool:
        return bool(self.state.motor)

    def move_relative(self, trans: float, steer: float, turret: float) -> Any:
        self.moves += 1
        self.target = self.state.x + trans
        return self.state


def test_a_slow_robot_is_waited_for_while_it_makes_progress(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # 1 m at the slowest plan speed (0.01 m/s) takes 100 s of robot time; the host's clock
    # jumps a minute at every call (a host starved by other work) and must not matter
    fake = iter(range(0, 10**9, 60))
    monkeypatch.setattr(time, "monotonic", lambda: float(next(fake)))
    robot = RobotOnItsClock(speed=0.01)
    translate_to(robot, (0.0, 0.0), 0.0, 1.0, 0.01)  # type: ignore[arg-type]
    assert robot.state.x == pytest.approx(1.0, abs=motion.TRANS_TOL)
    assert robot.state.clock > 100.0


def test_a_blocked_robot_fails_after_the_stated_robot_time() -> None:
    robot = RobotOnItsClock(speed=0.2, blocked=True)
    with pytest.raises(MotionError, match=r"no progress for 5 s of robot time") as err:
        translate_to(robot, (0.0, 0.0), 0.0, 0.5, 0.2)  # type: ignore[arg-type]
    assert "0.500 m" in str(err.value)  # the message says how far it still had to go
    # it failed after NO_PROGRESS_S of robot time (+ one poll), re-issuing the move meanwhile
    assert robot.state.clock == pytest.approx(NO_PROGRESS_S, abs=2 * robot.dt)
    assert robot.moves >= 5


def test_a_frozen_robot_clock_fails_instead_of_hanging() -> None:
    robot = RobotOnItsClock(speed=0.2, dt=0.0, blocked=True)
    with pytest.raises(MotionError, match="robot clock stands still"):
        turn_to(robot, None, 1.0, speed=math.radians(30))  # type: ignore[arg-type]

"""Plan steps as resumable runs.

Each plan step becomes a small object that records its own progress (the absolute targets
it computed when it first ran and how many it reached). :func:`run_plan` calls
:meth:`StepRun.run` again after a link fault (:class:`sonard.acquisition.Resume`) and the
step carries on from where it was: stop-and-fire translations and turret sweeps skip the
stops already fired at, dwells count the robot time already spent, wall-follows keep the
path length already driven.
"""

from __future__ import annotations

import contextlib
import logging
import math
from dataclasses import dataclass, field
from typing import Any

from sonard.acquisition import Acquisition, Resume
from sonard.motion import MotionError, translate_to, turn_to, wrap
from sonard.plan import (
    DefinePose,
    Dwell,
    Goto,
    Plan,
    Rotate,
    Translate,
    TurretSweep,
    WallFollow,
    Zero,
)
from sonard.wallfollow import WallFollower

__all__ = ["StepRun", "make_run", "run_plan"]

log = logging.getLogger(__name__)

#: turn rate used when a step has none of its own (rad/s)
DEFAULT_TURN = math.radians(30.0)
#: systemd watchdog while ZR runs (the robot may take 120 s to zero)
ZR_WATCHDOG_S = 130.0


@dataclass
class StepRun:
    """Base class: a step plus its progress."""

    step: Any
    plan: Plan
    started: bool = False

    def run(self, acq: Acquisition) -> None:
        """Run (or resume) the step until it is done."""
        raise NotImplementedError

    def fire_at_stop(self, acq: Acquisition, cycles: int) -> None:
        """Stand still for ``cycles`` firing cycles plus one interval (robot time)."""
        p = self.plan
        acq.wait_robot_time(cycles * len(p.sonars) * p.interval + p.interval)


@dataclass
class ZeroRun(StepRun):
    """ZR (not repeated once acknowledged)."""

    def run(self, acq: Acquisition) -> None:
        if not self.started:
            n = acq.notifier
            if n.watchdog_period:  # ZR blocks up to 120 s: widen the systemd watchdog meanwhile
                n.send(f"WATCHDOG_USEC={int(ZR_WATCHDOG_S * 1e6)}")
            try:
                reply = acq.zero()
            finally:
                if n.watchdog_period:
                    n.send(f"WATCHDOG_USEC={int(n.watchdog_period * 2e6)}")
            if reply is None:
                # No acknowledgement: the frame of every later reading would be unknown.
                # Zeroing again is harmless (it re-zeros where the robot stands).
                raise MotionError("ZR was not acknowledged by the robot")
            self.started = True
        acq.poll()


@dataclass
class DefinePoseRun(StepRun):
    """DP and DA (absolute, so safe to repeat)."""

    def run(self, acq: Acquisition) -> None:
        s: DefinePose = self.step
        turret = s.theta if s.turret is None else s.turret
        acq.define_position(s.x, s.y)
        acq.define_angles(s.theta, turret)
        acq.poll()


@dataclass
class TranslateRun(StepRun):
    """Stop-and-fire every ``step`` metres, or one continuous move, along the heading."""

    origin: tuple[float, float] = (0.0, 0.0)
    heading: float = 0.0
    targets: list[float] = field(default_factory=list)
    reached: int = 0

    def run(self, acq: Acquisition) -> None:
        s: Translate = self.step
        if not self.started:
            st = acq.poll()
            self.origin, self.heading = (st.x, st.y), st.steer
            if s.mode == "continuous" or s.step is None:
                self.targets = [s.distance]
            else:
                n = math.ceil(abs(s.distance) / s.step - 1e-9)
                sign = math.copysign(1.0, s.distance)
                self.targets = [0.0] + [
                    sign * min(k * s.step, abs(s.distance)) for k in range(1, n + 1)
                ]
            self.started = True
        acq.set_speed(s.speed, DEFAULT_TURN, DEFAULT_TURN)
        while self.reached < len(self.targets):
            translate_to(acq, self.origin, self.heading, self.targets[self.reached], s.speed)
            if s.mode == "stop-and-fire":
                self.fire_at_stop(acq, s.cycles)
            self.reached += 1


@dataclass
class RotateRun(StepRun):
    """Rotate the base (and the turret with it unless ``turret: hold``) in <= 90 deg legs."""

    legs: list[tuple[float, float | None]] = field(default_factory=list)
    reached: int = 0

    def run(self, acq: Acquisition) -> None:
        s: Rotate = self.step
        if not self.started:
            st = acq.poll()
            n = max(1, math.ceil(abs(s.angle) / (math.pi / 2) - 1e-9))
            for k in range(1, n + 1):
                a = s.angle * k / n
                turret = wrap(st.turret + a) if s.turret == "follow" else st.turret
                self.legs.append((wrap(st.steer + a), turret))
            self.started = True
        acq.set_speed(0.1, s.speed, s.speed)
        while self.reached < len(self.legs):
            turn_to(acq, *self.legs[self.reached], speed=s.speed)
            self.reached += 1


@dataclass
class TurretSweepRun(StepRun):
    """Turret to each angle from ``from`` to ``to`` by ``step``, firing at each."""

    targets: list[float] = field(default_factory=list)
    reached: int = 0

    def run(self, acq: Acquisition) -> None:
        s: TurretSweep = self.step
        if not self.started:
            base = acq.poll().turret if s.relative else 0.0
            span = s.to - s.from_
            n = math.floor(abs(span) / s.step + 1e-9)
            sign = math.copysign(1.0, span) if span else 1.0
            self.targets = [wrap(base + s.from_ + sign * k * s.step) for k in range(n + 1)]
            self.started = True
        acq.set_speed(0.1, s.speed, s.speed)
        while self.reached < len(self.targets):
            turn_to(acq, None, self.targets[self.reached], speed=s.speed)
            self.fire_at_stop(acq, s.cycles)
            self.reached += 1


@dataclass
class GotoRun(StepRun):
    """Turn towards the goal, drive to it, then turn to ``theta`` (turret follows)."""

    phase: int = 0

    def run(self, acq: Acquisition) -> None:
        s: Goto = self.step
        acq.set_speed(s.speed, s.turn_speed, s.turn_speed)
        st = acq.poll()
        offset = wrap(st.turret - st.steer)
        while self.phase < 3:
            st = acq.poll()
            dx, dy = s.x - st.x, s.y - st.y
            dist = math.hypot(dx, dy)
            if self.phase == 0 and dist > 0.01:
                bearing = math.atan2(dy, dx)
                turn_to(acq, bearing, wrap(bearing + offset), s.turn_speed)
            elif self.phase == 1 and dist > 0.01:
                translate_to(acq, (st.x, st.y), st.steer, dist, s.speed)
            elif self.phase == 2 and s.theta is not None:
                turn_to(acq, s.theta, wrap(s.theta + offset), s.turn_speed)
            self.phase += 1


@dataclass
class DwellRun(StepRun):
    """Stand still while firing for ``seconds`` of robot time."""

    spent: float = 0.0

    def run(self, acq: Acquisition) -> None:
        s: Dwell = self.step
        start = acq.poll().clock
        try:
            acq.wait_robot_time(s.seconds - self.spent)
        finally:
            if acq.state is not None:
                self.spent += max(0.0, acq.state.clock - start)


@dataclass
class WallFollowRun(StepRun):
    """Follow a wall for a path length (see :mod:`sonard.wallfollow`)."""

    follower: WallFollower | None = None

    def run(self, acq: Acquisition) -> None:
        if self.follower is None:
            self.follower = WallFollower(self.step, self.plan)
        self.follower.run(acq)


_RUNS: dict[type, type[StepRun]] = {
    Zero: ZeroRun,
    DefinePose: DefinePoseRun,
    Translate: TranslateRun,
    Rotate: RotateRun,
    TurretSweep: TurretSweepRun,
    Goto: GotoRun,
    Dwell: DwellRun,
    WallFollow: WallFollowRun,
}


def make_run(step: Any, plan: Plan) -> StepRun:
    """Wrap a plan step in its resumable run object."""
    return _RUNS[type(step)](step=step, plan=plan)


def run_plan(acq: Acquisition, plan: Plan) -> None:
    """Run every step of ``plan``, resuming a step after each link fault.

    The caller sends ST afterwards, however this returns or raises.
    """
    for i, step in enumerate(plan.steps):
        run = make_run(step, plan)
        if not isinstance(step, Zero | DefinePose) and not acq.recording:
            acq.recording = True  # no frame step first: the robot's own frame it is
        acq.sink.event("step", f"{i} {step.type}")
        log.info("step %d: %s", i, step.type)
        while True:
            try:
                run.run(acq)
                break
            except Resume:
                log.info("resuming step %d (%s)", i, step.type)
        # A link drop during this ST raises Resume from recover(), which has already
        # stopped the robot on reconnecting: the step is done either way.
        with contextlib.suppress(Resume):
            acq.stop()

"""The emulated synchro-drive: three motion axes and the robot's odometry.

Axes work in robot units (translation 1/10 in, steering and turret 1/10 deg). Translation
moves the robot along the steering heading; the steering angle is the base heading; the
turret is a separate absolute axis. Odometry is exact (no slip), so the pose the robot
reports maps to the TRUE world pose through a rigid offset that DP/DA/ZR redefine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from nomad200.state_types import DEG10, IN10

__all__ = ["Axis", "Drive"]

IDLE, VELOCITY, POSITION = 0, 1, 2
_SNAP = 0.02  # robot units: a position move ends when this close


@dataclass
class Axis:
    """One motor axis with speed and acceleration limits (robot units)."""

    max_speed: float
    max_acc: float
    speed: float
    acc: float
    pos: float = 0.0
    vel: float = 0.0
    mode: int = IDLE
    target: float = 0.0

    @property
    def moving(self) -> bool:
        """Whether the axis is under a motion command that has not finished."""
        return self.mode != IDLE

    def set_velocity(self, v: float) -> None:
        """VM: ramp to ``v`` at the acceleration limit and keep it."""
        self.mode = VELOCITY
        self.target = max(-self.max_speed, min(self.max_speed, v))

    def set_position(self, target: float) -> None:
        """PR/PA: trapezoidal move to ``target``."""
        self.mode = POSITION
        self.target = target

    def stop(self) -> None:
        """ST: decelerate to zero."""
        self.set_velocity(0.0)

    def limp(self) -> None:
        """LP: motor off (the emulated axis stops at once)."""
        self.mode = IDLE
        self.vel = 0.0

    def step(self, dt: float) -> float:
        """Advance ``dt`` seconds; return the distance moved."""
        if self.mode == IDLE or dt <= 0:
            return 0.0
        a = max(self.acc, 1e-9)
        if self.mode == VELOCITY:
            dv = self.target - self.vel
            t1 = min(dt, abs(dv) / a)
            acc = math.copysign(a, dv) if dv else 0.0
            d = self.vel * t1 + 0.5 * acc * t1 * t1 + self.target * (dt - t1)
            self.vel = self.vel + acc * t1 if t1 < dt else self.target
            self.pos += d
            if self.target == 0.0 and self.vel == 0.0:
                self.mode = IDLE
            return d
        # position mode: accelerate towards the target, brake to arrive with zero speed
        rem = self.target - self.pos
        if abs(rem) <= _SNAP and abs(self.vel) <= math.sqrt(2 * a * _SNAP) + 1e-9:
            return self._arrive(rem)
        want = math.copysign(min(self.speed, math.sqrt(2 * a * abs(rem))), rem)
        dv = max(-a * dt, min(a * dt, want - self.vel))
        v1 = self.vel + dv
        d = 0.5 * (self.vel + v1) * dt
        if (rem > 0 and d >= rem) or (rem < 0 and d <= rem):
            return self._arrive(rem)
        self.vel = v1
        self.pos += d
        return d

    def _arrive(self, rem: float) -> float:
        self.pos = self.target
        self.vel = 0.0
        self.mode = IDLE
        return rem


def _axes() -> tuple[Axis, Axis, Axis]:
    return (
        Axis(max_speed=240.0, max_acc=600.0, speed=200.0, acc=300.0),
        Axis(max_speed=600.0, max_acc=1200.0, speed=450.0, acc=600.0),
        Axis(max_speed=600.0, max_acc=1200.0, speed=450.0, acc=600.0),
    )


@dataclass
class Drive:
    """Three axes plus odometry (robot units) and the odometry-to-world offset (SI).

    Parameters
    ----------
    start : tuple of float
        World pose (x m, y m, theta rad) where the robot stands at power-on; odometry is zero
        there and steering points along theta.
    start_turret : float, optional
        World heading of the turret at power-on (rad); default theta. The turret encoder
        then reads the angle from theta, as if the robot had been zeroed facing theta.
    """

    start: tuple[float, float, float] = (0.0, 0.0, 0.0)
    start_turret: float | None = None
    trans: Axis = field(init=False)
    steer: Axis = field(init=False)
    turret: Axis = field(init=False)
    x: float = 0.0
    y: float = 0.0

    def __post_init__(self) -> None:
        self.trans, self.steer, self.turret = _axes()
        self.ox, self.oy, self.oth = self.start  # world pose of the odometry origin
        self.oth_turret = self.start[2]
        if self.start_turret is not None:
            self.turret.pos = self.turret.target = (self.start_turret - self.start[2]) / DEG10

    @property
    def axes(self) -> tuple[Axis, Axis, Axis]:
        """Translation, steering and turret axis."""
        return self.trans, self.steer, self.turret

    @property
    def moving(self) -> bool:
        """Whether any axis moves."""
        return self.trans.moving or self.steer.moving or self.turret.moving

    def motor_status(self) -> int:
        """Bit 0 translating, bit 1 steering, bit 2 turret."""
        return int(self.trans.moving) | int(self.steer.moving) << 1 | int(self.turret.moving) << 2

    def step(self, dt: float, max_step: float = 0.005) -> None:
        """Advance ``dt`` seconds in sub-steps of at most ``max_step``."""
        if not self.moving or dt <= 0:
            return
        n = max(1, math.ceil(dt / max_step))
        h = dt / n
        for _ in range(n):
            s0 = self.steer.pos
            ds = self.trans.step(h)
            self.steer.step(h)
            self.turret.step(h)
            if ds:
                hm = 0.5 * (s0 + self.steer.pos) * DEG10
                self.x += ds * math.cos(hm)
                self.y += ds * math.sin(hm)
            if not self.moving:
                break

    # ------------------------------------------------------------ frames
    def world_pose(self) -> tuple[float, float, float, float]:
        """TRUE pose in the world: x, y (m), heading and turret heading (rad)."""
        c, s = math.cos(self.oth), math.sin(self.oth)
        px, py = self.x * IN10, self.y * IN10
        return (
            self.ox + c * px - s * py,
            self.oy + s * px + c * py,
            self.oth + self.steer.pos * DEG10,
            self.oth_turret + self.turret.pos * DEG10,
        )

    def define_position(self, x: float, y: float) -> None:
        """DP: the current place becomes (x, y) in odometry (robot units)."""
        wx, wy, _, _ = self.world_pose()
        self.x, self.y = x, y
        self._refit(wx, wy)

    def define_angles(self, steer: float, turret: float) -> None:
        """DA: the current angles become ``steer`` and ``turret`` (robot units)."""
        wx, wy, wh, wt = self.world_pose()
        self.steer.pos, self.turret.pos = steer, turret
        self.steer.target, self.turret.target = steer, turret
        self.oth = wh - steer * DEG10
        self.oth_turret = wt - turret * DEG10
        self._refit(wx, wy)

    def zero(self) -> float:
        """ZR: turn steering and turret back to the base's zero, zero everything.

        Returns the time (s) the homing takes.
        """
        _, _, wh, wt = self.world_pose()
        base = self.start[2]

        def wrap(a: float) -> float:
            return (a + math.pi) % (2 * math.pi) - math.pi

        dur = 0.5 + max(
            abs(wrap(wh - base)) / (self.steer.max_speed * DEG10),
            abs(wrap(wt - base)) / (self.turret.max_speed * DEG10),
        )
        wx, wy, _, _ = self.world_pose()
        for ax in self.axes:
            ax.limp()
            ax.pos = ax.target = 0.0
        self.x = self.y = 0.0
        self.oth = self.oth_turret = base
        self.ox, self.oy = wx, wy
        return dur

    def _refit(self, wx: float, wy: float) -> None:
        c, s = math.cos(self.oth), math.sin(self.oth)
        px, py = self.x * IN10, self.y * IN10
        self.ox = wx - (c * px - s * py)
        self.oy = wy - (s * px + c * py)

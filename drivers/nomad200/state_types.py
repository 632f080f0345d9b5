"""The values of a state reply: the robot's units, the raw reply and the decoded one.

:class:`RawState` is a state reply in robot units (distance 1/10 inch, angles 1/10 degree,
sonar ranges whole inches, clock ms), :class:`State` the same reply decoded into SI units
(m, rad, s), and :class:`PoseAttachment` the pose and clock the robot attaches to a sensor
reading (36 bytes on the wire, :func:`decode_attachment` and :func:`encode_attachment`).
How a reply is laid out in bytes for a given mask is :mod:`nomad200.state`.

Examples
--------
>>> round(100 * IN10, 5), round(900 * DEG10, 6)
(0.254, 1.570796)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Final, NamedTuple

from nomad200.codec import to_sm32

__all__ = [
    "ATTACHMENT_SIZE",
    "DEG10",
    "IN10",
    "INCH",
    "NO_ECHO",
    "PoseAttachment",
    "RawAttachment",
    "RawState",
    "State",
    "attachment_values",
    "decode_attachment",
    "encode_attachment",
]

#: metres per 1/10 inch
IN10: Final = 0.00254
#: metres per inch
INCH: Final = 0.0254
#: radians per 1/10 degree
DEG10: Final = math.pi / 1800.0
#: sonar byte meaning "no echo"
NO_ECHO: Final = 255
#: bytes of one pose attachment (9 x 4-byte values)
ATTACHMENT_SIZE: Final = 36

#: a pose attachment in robot units: x, y, steer, turret, 3 velocities, 2 times (9 values)
RawAttachment = tuple[int, ...]


class PoseAttachment(NamedTuple):
    """Robot pose and clock attached to one sensor reading (SI units, robot odometry frame)."""

    x: float
    y: float
    steer: float
    turret: float
    velocities: tuple[float, float, float]
    pose_time: float
    reading_time: float


class RawState(NamedTuple):
    """A state reply in robot units; sequences hold the masked sensors in id order.

    ``pose`` and ``vel`` hold every axis; the layout writes the ones its mask asks for.
    ``laser`` holds the raw 16-bit words after the laser point count, which is
    ``laser_count`` (default: one word per point).
    """

    ir: tuple[int, ...] = ()
    ir_att: tuple[RawAttachment, ...] = ()
    sonar: tuple[int, ...] = ()
    sonar_att: tuple[RawAttachment, ...] = ()
    bumper: int = 0
    bumper_att: RawAttachment | None = None
    pose: tuple[int, int, int, int] = (0, 0, 0, 0)
    vel: tuple[int, int, int] = (0, 0, 0)
    compass: int = 0
    compass_att: RawAttachment | None = None
    laser: tuple[int, ...] = ()
    laser_count: int | None = None
    laser_att: RawAttachment | None = None
    motor_status: int = 0
    clock_ms: int = 0
    cpu_voltage: int = 0
    motor_voltage: int = 0


@dataclass(slots=True)
class State:
    """A decoded state reply in SI units (m, rad, s); ``None`` where the mask omits a value.

    ``sonar`` maps sonar id to range from the transducer face in metres (``None`` = 255,
    no echo); ``sonar_raw`` keeps the inches. ``clock`` is the robot's sensor-board clock.
    ``laser_count`` is the laser's point count (``None``: not in the mask) and ``laser``
    the raw 16-bit words that follow it (one per point, or four per line segment).
    """

    x: float | None = None
    y: float | None = None
    steer: float | None = None
    turret: float | None = None
    trans_vel: float | None = None
    steer_vel: float | None = None
    turret_vel: float | None = None
    sonar: dict[int, float | None] = field(default_factory=dict)
    sonar_raw: dict[int, int] = field(default_factory=dict)
    sonar_attachments: dict[int, PoseAttachment] = field(default_factory=dict)
    ir: dict[int, int] = field(default_factory=dict)
    ir_attachments: dict[int, PoseAttachment] = field(default_factory=dict)
    bumper: int | None = None
    bumper_attachment: PoseAttachment | None = None
    compass: int | None = None
    compass_attachment: PoseAttachment | None = None
    laser_count: int | None = None
    laser: tuple[int, ...] = ()
    laser_attachment: PoseAttachment | None = None
    motor_status: int = 0
    clock: float = 0.0
    cpu_voltage_raw: int = 0
    motor_voltage_raw: int = 0


def decode_attachment(v: tuple[int, ...]) -> PoseAttachment:
    """A :class:`PoseAttachment` in SI units from its nine unpacked 32-bit wire words."""

    def s(u: int) -> int:
        return -(u & 0x7FFFFFFF) if u & 0x80000000 else u

    return PoseAttachment(
        s(v[0]) * IN10,
        s(v[1]) * IN10,
        s(v[2]) * DEG10,
        s(v[3]) * DEG10,
        (s(v[4]) * IN10, s(v[5]) * DEG10, s(v[6]) * DEG10),
        v[7] / 1000.0,
        v[8] / 1000.0,
    )


def encode_attachment(a: tuple[int, ...]) -> list[int]:
    """The nine 32-bit wire words of an attachment given in robot units."""
    return [to_sm32(a[i]) for i in range(7)] + [a[7] & 0xFFFFFFFF, a[8] & 0xFFFFFFFF]


def attachment_values(a: PoseAttachment) -> RawAttachment:
    """The nine values of ``a`` in robot units (before :func:`encode_attachment`)."""
    return (
        round(a.x / IN10),
        round(a.y / IN10),
        round(a.steer / DEG10),
        round(a.turret / DEG10),
        round(a.velocities[0] / IN10),
        round(a.velocities[1] / DEG10),
        round(a.velocities[2] / DEG10),
        round(a.pose_time * 1000),
        round(a.reading_time * 1000),
    )

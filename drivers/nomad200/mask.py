"""The sensor mask of the CT command: which fields every state reply carries.

CT carries seven mask bytes, bit 0 first:

====  ==============================================================================
b0    infrared 0-7
b1    infrared 8-15
b2    sonar 0-7
b3    sonar 8-15
b4    bumper, x, y, steering angle, turret angle, translation, steering and turret
      velocity (bits 0 to 7)
b5    bit 0: laser
b6    bit 0: compass; bits 1-5: pose attachment for infrared, sonar, bumper, laser,
      compass
====  ==============================================================================

Every one of the 2**56 byte patterns is a valid mask: pose and velocity fields are
independent bits (Nomadic's host library sets them one by one), and the bits no sensor uses
(b5 bits 1-7, b6 bits 6-7) are ignored.

Examples
--------
>>> m = StateMask.from_ct_args((0, 0, 0b11, 0, 0b110, 0, 0))
>>> sorted(m.sonars), m.pose, sorted(m.pose_fields)
([0, 1], False, ['x', 'y'])
>>> StateMask(pose=True).ct_args()
(0, 0, 0, 0, 30, 0, 0)
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Final, Literal, get_args

__all__ = [
    "POSE_FIELDS",
    "VELOCITY_FIELDS",
    "PoseField",
    "StateMask",
    "VelocityField",
]

#: A pose field of a state reply (the name of the :class:`~nomad200.state.State` attribute).
PoseField = Literal["x", "y", "steer", "turret"]
#: A velocity field of a state reply (the name of the ``State`` attribute).
VelocityField = Literal["trans_vel", "steer_vel", "turret_vel"]
#: Pose fields in wire order (CT byte 4, bits 1 to 4).
POSE_FIELDS: Final[tuple[PoseField, ...]] = get_args(PoseField)
#: Velocity fields in wire order (CT byte 4, bits 5 to 7).
VELOCITY_FIELDS: Final[tuple[VelocityField, ...]] = get_args(VelocityField)


def _ids(v: Iterable[int], what: str) -> frozenset[int]:
    s = frozenset(int(i) for i in v)
    bad = sorted(i for i in s if not 0 <= i <= 15)
    if bad:
        raise ValueError(f"{what} ids must be 0..15, got {bad}")
    return s


def _names(v: Iterable[str], allowed: tuple[str, ...], what: str) -> frozenset[str]:
    s = frozenset(v)
    bad = sorted(s - set(allowed))
    if bad:
        raise ValueError(f"unknown {what} fields {bad}; allowed: {', '.join(allowed)}")
    return s


def _bits(ids: Iterable[int]) -> int:
    return sum(1 << i for i in ids)


def _set(word: int, n: int = 16) -> frozenset[int]:
    return frozenset(i for i in range(n) if word >> i & 1)


@dataclass(frozen=True)
class StateMask:
    """What the robot includes in each state reply.

    Parameters
    ----------
    sonars : frozenset of int
        Sonar ids 0..15 whose readings are reported.
    pose : bool
        Shorthand for all four pose fields. After construction it is True exactly when
        all four are reported.
    velocities : bool
        Shorthand for all three velocity fields (True exactly when all three are reported).
    sonar_pose_attachment : bool
        Attach the pose and clock at the moment each reported sonar reading was taken.
    irs, ir_pose_attachment, bumper, bumper_pose_attachment, compass, compass_pose_attachment
        The other sensors (the emulator reports them as idle).
    laser, laser_pose_attachment : bool
        The structured-light laser (the emulated robot has none: its field holds no points).
    pose_fields : frozenset of str
        Pose fields reported one by one (:data:`POSE_FIELDS`); united with ``pose``.
    velocity_fields : frozenset of str
        Velocity fields reported one by one (:data:`VELOCITY_FIELDS`); united with
        ``velocities``.

    Examples
    --------
    >>> StateMask(pose_fields=frozenset(POSE_FIELDS)) == StateMask(pose=True)
    True
    """

    sonars: frozenset[int] = frozenset()
    pose: bool = False
    velocities: bool = False
    sonar_pose_attachment: bool = False
    irs: frozenset[int] = frozenset()
    ir_pose_attachment: bool = False
    bumper: bool = False
    bumper_pose_attachment: bool = False
    compass: bool = False
    compass_pose_attachment: bool = False
    laser: bool = False
    laser_pose_attachment: bool = False
    pose_fields: frozenset[PoseField] = frozenset()
    velocity_fields: frozenset[VelocityField] = frozenset()

    def __post_init__(self) -> None:
        put = object.__setattr__
        put(self, "sonars", _ids(self.sonars, "sonar"))
        put(self, "irs", _ids(self.irs, "infrared"))
        pose = _names(self.pose_fields, POSE_FIELDS, "pose")
        vel = _names(self.velocity_fields, VELOCITY_FIELDS, "velocity")
        if self.pose:
            pose = frozenset(POSE_FIELDS)
        if self.velocities:
            vel = frozenset(VELOCITY_FIELDS)
        put(self, "pose_fields", pose)
        put(self, "velocity_fields", vel)
        put(self, "pose", len(pose) == len(POSE_FIELDS))
        put(self, "velocities", len(vel) == len(VELOCITY_FIELDS))

    @property
    def pose_order(self) -> tuple[PoseField, ...]:
        """The reported pose fields in wire order."""
        return tuple(f for f in POSE_FIELDS if f in self.pose_fields)

    @property
    def velocity_order(self) -> tuple[VelocityField, ...]:
        """The reported velocity fields in wire order."""
        return tuple(f for f in VELOCITY_FIELDS if f in self.velocity_fields)

    def ct_args(self) -> tuple[int, ...]:
        """The seven CT mask bytes."""
        ir, so = _bits(self.irs), _bits(self.sonars)
        b4 = (
            int(self.bumper)
            | (_bits(POSE_FIELDS.index(f) for f in self.pose_fields) << 1)
            | (_bits(VELOCITY_FIELDS.index(f) for f in self.velocity_fields) << 5)
        )
        b6 = (
            int(self.compass)
            | (int(self.ir_pose_attachment) << 1)
            | (int(self.sonar_pose_attachment) << 2)
            | (int(self.bumper_pose_attachment) << 3)
            | (int(self.laser_pose_attachment) << 4)
            | (int(self.compass_pose_attachment) << 5)
        )
        return (ir & 0xFF, ir >> 8, so & 0xFF, so >> 8, b4, int(self.laser), b6)

    @classmethod
    def from_ct_args(cls, args: tuple[int, ...]) -> StateMask:
        """Parse seven CT mask bytes; every byte pattern is a mask.

        Raises
        ------
        ValueError
            Not seven values, or a value outside 0..255.
        """
        if len(args) != 7:
            raise ValueError(f"CT needs 7 mask bytes, got {len(args)}")
        if any(not 0 <= b <= 255 for b in args):
            raise ValueError(f"CT mask bytes must be 0..255, got {list(args)}")
        b0, b1, b2, b3, b4, b5, b6 = args
        return cls(
            sonars=_set(b2 | (b3 << 8)),
            sonar_pose_attachment=bool(b6 & 0b100),
            irs=_set(b0 | (b1 << 8)),
            ir_pose_attachment=bool(b6 & 0b10),
            bumper=bool(b4 & 1),
            bumper_pose_attachment=bool(b6 & 0b1000),
            compass=bool(b6 & 1),
            compass_pose_attachment=bool(b6 & 0b100000),
            laser=bool(b5 & 1),
            laser_pose_attachment=bool(b6 & 0b10000),
            pose_fields=frozenset(POSE_FIELDS[i] for i in _set(b4 >> 1, 4)),
            velocity_fields=frozenset(VELOCITY_FIELDS[i] for i in _set(b4 >> 5, 3)),
        )

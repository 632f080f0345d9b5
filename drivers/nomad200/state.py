"""Sensor masks and the state replies they shape, in robot units and in SI.

A :class:`StateMask` says what the robot puts in every state reply (CT command). For each
mask a :class:`StateLayout` precomputes one :class:`struct.Struct` so encoding and decoding
a reply is a single ``pack``/``unpack`` plus unit conversion.

Robot units: distance 1/10 inch, angles 1/10 degree, sonar ranges whole inches, clock ms.

Examples
--------
>>> mask = StateMask(sonars=frozenset({0, 1}), pose=True)
>>> lay = layout_for(mask)
>>> raw = RawState(sonar=(40, 255), pose=(100, -100, 900, 0), clock_ms=1500)
>>> st = lay.decode(lay.encode_payload(raw))
>>> round(st.x, 5), st.sonar[1], round(st.sonar[0], 4), st.clock
(0.254, None, 1.016, 1.5)
"""

from __future__ import annotations

import math
import struct
from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Final, NamedTuple

from nomad200.codec import encode_frame, from_sm16, to_sm16, to_sm32
from nomad200.errors import PayloadError

__all__ = [
    "ATTACHMENT_SIZE",
    "DEG10",
    "IN10",
    "INCH",
    "NO_ECHO",
    "Configuration",
    "PoseAttachment",
    "RawState",
    "SonarScan",
    "State",
    "StateLayout",
    "StateMask",
    "decode_get_rc",
    "decode_get_rv",
    "decode_get_sn",
    "encode_get_rc",
    "encode_get_rv",
    "encode_get_sn",
    "layout_for",
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

_RawAtt = tuple[int, ...]  # 9 values: x, y, steer, turret, 3 velocities, 2 times


def _ids(v: Iterable[int], what: str) -> frozenset[int]:
    s = frozenset(int(i) for i in v)
    bad = sorted(i for i in s if not 0 <= i <= 15)
    if bad:
        raise ValueError(f"{what} ids must be 0..15, got {bad}")
    return s


@dataclass(frozen=True)
class StateMask:
    """What the robot includes in each state reply.

    Parameters
    ----------
    sonars : frozenset of int
        Sonar ids 0..15 whose readings are reported.
    pose : bool
        Report x, y, steering and turret angle.
    velocities : bool
        Report translation, steering and turret velocity.
    sonar_pose_attachment : bool
        Attach the pose and clock at the moment each reported sonar reading was taken.
    irs, ir_pose_attachment, bumper, bumper_pose_attachment, compass, compass_pose_attachment
        The other sensors (the emulator reports them as idle).
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

    def __post_init__(self) -> None:
        object.__setattr__(self, "sonars", _ids(self.sonars, "sonar"))
        object.__setattr__(self, "irs", _ids(self.irs, "infrared"))

    def ct_args(self) -> tuple[int, ...]:
        """The seven CT mask bytes."""
        ir = sum(1 << i for i in self.irs)
        so = sum(1 << i for i in self.sonars)
        b4 = (
            int(self.bumper)
            | (0b11110 if self.pose else 0)
            | (0b11100000 if self.velocities else 0)
        )
        b6 = (
            int(self.compass)
            | (int(self.ir_pose_attachment) << 1)
            | (int(self.sonar_pose_attachment) << 2)
            | (int(self.bumper_pose_attachment) << 3)
            | (int(self.compass_pose_attachment) << 5)
        )
        return (ir & 0xFF, ir >> 8, so & 0xFF, so >> 8, b4, 0, b6)

    @classmethod
    def from_ct_args(cls, args: tuple[int, ...]) -> StateMask:
        """Parse seven CT mask bytes.

        Raises
        ------
        ValueError
            A laser request, or pose/velocity bits that are only partly set (this driver
            reports the pose and the velocities as whole groups).
        """
        if len(args) != 7:
            raise ValueError(f"CT needs 7 mask bytes, got {len(args)}")
        b0, b1, b2, b3, b4, b5, b6 = args
        if b5 & 1 or b6 & 0b10000:
            raise ValueError("no laser on this robot")
        pose_bits, vel_bits = b4 & 0b11110, b4 & 0b11100000
        if pose_bits not in (0, 0b11110) or vel_bits not in (0, 0b11100000):
            raise ValueError("pose and velocity mask bits must be set as groups")
        ir = b0 | (b1 << 8)
        so = b2 | (b3 << 8)
        return cls(
            sonars=frozenset(i for i in range(16) if so >> i & 1),
            pose=bool(pose_bits),
            velocities=bool(vel_bits),
            sonar_pose_attachment=bool(b6 & 4),
            irs=frozenset(i for i in range(16) if ir >> i & 1),
            ir_pose_attachment=bool(b6 & 2),
            bumper=bool(b4 & 1),
            bumper_pose_attachment=bool(b6 & 8),
            compass=bool(b6 & 1),
            compass_pose_attachment=bool(b6 & 32),
        )


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
    """A state reply in robot units; sequences hold the masked sensors in id order."""

    ir: tuple[int, ...] = ()
    ir_att: tuple[_RawAtt, ...] = ()
    sonar: tuple[int, ...] = ()
    sonar_att: tuple[_RawAtt, ...] = ()
    bumper: int = 0
    bumper_att: _RawAtt | None = None
    pose: tuple[int, int, int, int] = (0, 0, 0, 0)
    vel: tuple[int, int, int] = (0, 0, 0)
    compass: int = 0
    compass_att: _RawAtt | None = None
    motor_status: int = 0
    clock_ms: int = 0
    cpu_voltage: int = 0
    motor_voltage: int = 0


@dataclass(slots=True)
class State:
    """A decoded state reply in SI units (m, rad, s); ``None`` where the mask omits a value.

    ``sonar`` maps sonar id to range from the transducer face in metres (``None`` = 255,
    no echo); ``sonar_raw`` keeps the inches. ``clock`` is the robot's sensor-board clock.
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
    motor_status: int = 0
    clock: float = 0.0
    cpu_voltage_raw: int = 0
    motor_voltage_raw: int = 0


def _att_si(v: tuple[int, ...]) -> PoseAttachment:
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


def _att_wire(a: _RawAtt) -> list[int]:
    return [to_sm32(a[i]) for i in range(7)] + [a[7] & 0xFFFFFFFF, a[8] & 0xFFFFFFFF]


def _att_raw(a: PoseAttachment) -> _RawAtt:
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


def _sonar_si(v: int) -> float | None:
    return None if v == NO_ECHO else v * INCH


class StateLayout:
    """Precomputed byte layout of state replies for one :class:`StateMask`."""

    def __init__(self, mask: StateMask) -> None:
        self.mask = mask
        self.ir_ids = tuple(sorted(mask.irs))
        self.sonar_ids = tuple(sorted(mask.sonars))
        n_ir, n_so = len(self.ir_ids), len(self.sonar_ids)
        fmt = ["<"]
        pos = 0

        def add(code: str, count: int) -> tuple[int, int]:
            nonlocal pos
            fmt.append(f"{count}{code}")
            start = pos
            pos += count
            return start, pos

        self._ir = add("B", (n_ir + 1) // 2)
        self._ir_att = add("I", 9 * n_ir if mask.ir_pose_attachment else 0)
        self._so = add("B", n_so)
        self._so_att = add("I", 9 * n_so if mask.sonar_pose_attachment else 0)
        self._bump = add("B", 3 if mask.bumper else 0)
        self._bump_att = add("I", 9 if mask.bumper and mask.bumper_pose_attachment else 0)
        self._pose = add("H", 4 if mask.pose else 0)
        self._vel = add("H", 3 if mask.velocities else 0)
        self._comp = add("H", 1 if mask.compass else 0)
        self._comp_att = add("I", 9 if mask.compass and mask.compass_pose_attachment else 0)
        self._tail = add("B", 1)[0]  # motor status
        add("I", 1)
        add("B", 2)
        self.struct = struct.Struct("".join(fmt))
        #: payload bytes after the type byte
        self.size = self.struct.size
        #: ``len`` field of a state reply frame
        self.frame_len = self.size + 2
        self.frame_size = self.size + 6

    # ------------------------------------------------------------ encode
    def encode_payload(self, raw: RawState) -> bytes:
        """Pack ``raw`` (robot units) into the payload bytes of a state reply."""
        vals: list[int] = []
        m = self.mask
        irs = raw.ir
        for i in range(0, len(self.ir_ids), 2):
            lo = irs[i] & 0xF
            hi = irs[i + 1] & 0xF if i + 1 < len(irs) else 0
            vals.append(lo | (hi << 4))
        if m.ir_pose_attachment:
            for a in raw.ir_att:
                vals.extend(_att_wire(a))
        vals.extend(raw.sonar)
        if m.sonar_pose_attachment:
            for a in raw.sonar_att:
                vals.extend(_att_wire(a))
        if m.bumper:
            b = raw.bumper
            vals.extend(((b >> 16) & 0xFF, (b >> 8) & 0xFF, b & 0xFF))  # N200: high byte first
            if m.bumper_pose_attachment:
                vals.extend(_att_wire(raw.bumper_att or (0,) * 9))
        if m.pose:
            x, y, s, t = raw.pose
            vals.extend((to_sm16(x), to_sm16(y), to_sm16(s), to_sm16(t)))
        if m.velocities:
            vt, vs, vr = raw.vel
            vals.extend((to_sm16(vt), to_sm16(vs), to_sm16(vr)))
        if m.compass:
            vals.append(to_sm16(raw.compass))
            if m.compass_pose_attachment:
                vals.extend(_att_wire(raw.compass_att or (0,) * 9))
        vals.extend(
            (raw.motor_status, raw.clock_ms & 0xFFFFFFFF, raw.cpu_voltage, raw.motor_voltage)
        )
        try:
            return self.struct.pack(*vals)
        except struct.error as err:
            raise ValueError(f"state does not fit the mask: {err}") from err

    def encode_frame(self, ptype: int, raw: RawState) -> bytes:
        """A complete state reply frame of type ``ptype``."""
        return encode_frame(ptype, self.encode_payload(raw))

    # ------------------------------------------------------------ decode
    def decode(self, payload: bytes) -> State:
        """Decode a state reply payload (the bytes after the type byte) into SI units.

        Raises
        ------
        PayloadError
            If the payload length does not match this layout.
        """
        if len(payload) != self.size:
            raise PayloadError(
                f"state reply has {len(payload)} payload bytes, the mask implies {self.size}"
            )
        v = self.struct.unpack(payload)
        m = self.mask
        st = State()
        if self.ir_ids:
            a, _ = self._ir
            st.ir = {i: (v[a + k // 2] >> (4 * (k & 1))) & 0xF for k, i in enumerate(self.ir_ids)}
            if m.ir_pose_attachment:
                b = self._ir_att[0]
                st.ir_attachments = {
                    i: _att_si(v[b + 9 * k : b + 9 * k + 9]) for k, i in enumerate(self.ir_ids)
                }
        if self.sonar_ids:
            a, b = self._so
            raw = v[a:b]
            st.sonar_raw = dict(zip(self.sonar_ids, raw, strict=True))
            st.sonar = {
                i: (None if r == 255 else r * INCH)
                for i, r in zip(self.sonar_ids, raw, strict=True)
            }
            if m.sonar_pose_attachment:
                c = self._so_att[0]
                st.sonar_attachments = {
                    i: _att_si(v[c + 9 * k : c + 9 * k + 9]) for k, i in enumerate(self.sonar_ids)
                }
        if m.bumper:
            a = self._bump[0]
            st.bumper = (v[a] << 16) | (v[a + 1] << 8) | v[a + 2]
            if m.bumper_pose_attachment:
                b = self._bump_att[0]
                st.bumper_attachment = _att_si(v[b : b + 9])
        if m.pose:
            a = self._pose[0]
            x, y, s, t = v[a : a + 4]
            st.x = (-(x & 0x7FFF) if x & 0x8000 else x) * IN10
            st.y = (-(y & 0x7FFF) if y & 0x8000 else y) * IN10
            st.steer = (-(s & 0x7FFF) if s & 0x8000 else s) * DEG10
            st.turret = (-(t & 0x7FFF) if t & 0x8000 else t) * DEG10
        if m.velocities:
            a = self._vel[0]
            st.trans_vel = from_sm16(v[a]) * IN10
            st.steer_vel = from_sm16(v[a + 1]) * DEG10
            st.turret_vel = from_sm16(v[a + 2]) * DEG10
        if m.compass:
            a = self._comp[0]
            st.compass = from_sm16(v[a])
            if m.compass_pose_attachment:
                b = self._comp_att[0]
                st.compass_attachment = _att_si(v[b : b + 9])
        k = self._tail
        st.motor_status = v[k]
        st.clock = v[k + 1] / 1000.0
        st.cpu_voltage_raw = v[k + 2]
        st.motor_voltage_raw = v[k + 3]
        return st

    def raw_from_state(self, st: State) -> RawState:
        """Convert a decoded :class:`State` back to robot units (rounding to the resolution)."""
        m = self.mask

        def r16(val: float | None, unit: float) -> int:
            return round((val or 0.0) / unit)

        return RawState(
            ir=tuple(st.ir[i] for i in self.ir_ids),
            ir_att=tuple(_att_raw(st.ir_attachments[i]) for i in self.ir_ids)
            if m.ir_pose_attachment
            else (),
            sonar=tuple(st.sonar_raw[i] for i in self.sonar_ids),
            sonar_att=tuple(_att_raw(st.sonar_attachments[i]) for i in self.sonar_ids)
            if m.sonar_pose_attachment
            else (),
            bumper=st.bumper or 0,
            bumper_att=_att_raw(st.bumper_attachment) if st.bumper_attachment else None,
            pose=(r16(st.x, IN10), r16(st.y, IN10), r16(st.steer, DEG10), r16(st.turret, DEG10)),
            vel=(r16(st.trans_vel, IN10), r16(st.steer_vel, DEG10), r16(st.turret_vel, DEG10)),
            compass=st.compass or 0,
            compass_att=_att_raw(st.compass_attachment) if st.compass_attachment else None,
            motor_status=st.motor_status,
            clock_ms=round(st.clock * 1000),
            cpu_voltage=st.cpu_voltage_raw,
            motor_voltage=st.motor_voltage_raw,
        )


@lru_cache(maxsize=256)
def layout_for(mask: StateMask) -> StateLayout:
    """The (cached) :class:`StateLayout` of ``mask``."""
    return StateLayout(mask)


# ---------------------------------------------------------------- other replies


@dataclass(slots=True)
class SonarScan:
    """A GET_SN reply: all 16 sonars (m from the transducer face, ``None`` = no echo)."""

    sonar: dict[int, float | None]
    sonar_raw: dict[int, int]
    sonar_attachments: dict[int, PoseAttachment]
    clock: float


class Configuration(NamedTuple):
    """A GET_RC reply: x, y (m), steering and turret angle (rad)."""

    x: float
    y: float
    steer: float
    turret: float


_SN = struct.Struct("<16B")
_SN_ATT = struct.Struct("<144I")
_U32 = struct.Struct("<I")
_RC = struct.Struct("<4H")
_RV = struct.Struct("<3H")


def encode_get_sn(
    sonar: tuple[int, ...], attachments: tuple[_RawAtt, ...] | None, clock_ms: int
) -> bytes:
    """A GET_SN reply frame (16 sonar bytes, optional 16 attachments, clock)."""
    body = _SN.pack(*sonar)
    if attachments is not None:
        body += _SN_ATT.pack(*[w for a in attachments for w in _att_wire(a)])
    return encode_frame(20, body + _U32.pack(clock_ms & 0xFFFFFFFF))


def decode_get_sn(payload: bytes, *, attachments: bool) -> SonarScan:
    """Decode a GET_SN payload; ``attachments`` as in the current mask."""
    want = 16 + (576 if attachments else 0) + 4
    if len(payload) != want:
        raise PayloadError(f"GET_SN reply has {len(payload)} payload bytes, expected {want}")
    raw = _SN.unpack_from(payload)
    atts: dict[int, PoseAttachment] = {}
    if attachments:
        w = _SN_ATT.unpack_from(payload, 16)
        atts = {i: _att_si(w[9 * i : 9 * i + 9]) for i in range(16)}
    (clock,) = _U32.unpack_from(payload, want - 4)
    return SonarScan(
        sonar={i: _sonar_si(r) for i, r in enumerate(raw)},
        sonar_raw=dict(enumerate(raw)),
        sonar_attachments=atts,
        clock=clock / 1000.0,
    )


def encode_get_rc(x: int, y: int, steer: int, turret: int) -> bytes:
    """A GET_RC reply frame."""
    return encode_frame(21, _RC.pack(to_sm16(x), to_sm16(y), to_sm16(steer), to_sm16(turret)))


def decode_get_rc(payload: bytes) -> Configuration:
    """Decode a GET_RC payload into SI units."""
    if len(payload) != 8:
        raise PayloadError(f"GET_RC reply has {len(payload)} payload bytes, expected 8")
    x, y, s, t = (from_sm16(u) for u in _RC.unpack(payload))
    return Configuration(x * IN10, y * IN10, s * DEG10, t * DEG10)


def encode_get_rv(trans: int, steer: int, turret: int) -> bytes:
    """A GET_RV reply frame."""
    return encode_frame(22, _RV.pack(to_sm16(trans), to_sm16(steer), to_sm16(turret)))


def decode_get_rv(payload: bytes) -> tuple[float, float, float]:
    """Decode a GET_RV payload: translation (m/s), steering and turret rate (rad/s)."""
    if len(payload) != 6:
        raise PayloadError(f"GET_RV reply has {len(payload)} payload bytes, expected 6")
    a, b, c = (from_sm16(u) for u in _RV.unpack(payload))
    return a * IN10, b * DEG10, c * DEG10

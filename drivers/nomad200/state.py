"""State replies (the answer to almost every command), in robot units and in SI.

A :class:`~nomad200.mask.StateMask` says what the robot puts in every state reply (CT
command). For each mask a :class:`StateLayout` precomputes one :class:`struct.Struct` so
encoding and decoding a reply is a single ``pack``/``unpack`` plus unit conversion. The
fields come in the order of Nomadic's host library: infrared (with attachments), sonar
(with attachments), bumper, x, y, steering, turret, the three velocities, compass, laser
(point count, points, attachment), then motor status, clock and the two voltages. The
values themselves (:class:`RawState`, :class:`State`, pose attachments, the robot's units)
are in :mod:`nomad200.state_types`; the replies that do not depend on the mask (GET_SN,
GET_RC, GET_RV) are in :mod:`nomad200.replies`.

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

import struct
from functools import lru_cache
from typing import Final

from nomad200.codec import encode_frame, from_sm16, to_sm16
from nomad200.errors import PayloadError
from nomad200.mask import POSE_FIELDS, VELOCITY_FIELDS, StateMask
from nomad200.state_types import (
    ATTACHMENT_SIZE,
    DEG10,
    IN10,
    INCH,
    NO_ECHO,
    PoseAttachment,
    RawAttachment,
    RawState,
    State,
    attachment_values,
    decode_attachment,
    encode_attachment,
)

__all__ = [
    "ATTACHMENT_SIZE",
    "DEG10",
    "IN10",
    "INCH",
    "NO_ECHO",
    "PoseAttachment",
    "RawState",
    "State",
    "StateLayout",
    "StateMask",
    "decode_attachment",
    "encode_attachment",
    "layout_for",
]

_NO_ATT: Final = (0,) * 9
# unit of each pose and velocity field, in wire order
_POSE_UNITS: Final = (IN10, IN10, DEG10, DEG10)
_VEL_UNITS: Final = (IN10, DEG10, DEG10)


class StateLayout:
    """Precomputed byte layout of state replies for one :class:`StateMask`.

    Parameters
    ----------
    mask : StateMask
        What the replies carry.
    laser_words : int
        16-bit words after the laser point count (0: the empty laser field of a robot
        without a laser). :meth:`decode` switches to the layout with the right count when a
        reply carries laser data.
    """

    def __init__(self, mask: StateMask, laser_words: int = 0) -> None:
        self.mask = mask
        self.laser_words = laser_words if mask.laser else 0
        self.ir_ids = tuple(sorted(mask.irs))
        self.sonar_ids = tuple(sorted(mask.sonars))
        #: index (0..3) of each reported pose field and (0..2) of each velocity, wire order
        self.pose_idx = tuple(POSE_FIELDS.index(f) for f in mask.pose_order)
        self.vel_idx = tuple(VELOCITY_FIELDS.index(f) for f in mask.velocity_order)
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
        self._pose = add("H", len(self.pose_idx))
        self._vel = add("H", len(self.vel_idx))
        self._comp = add("H", 1 if mask.compass else 0)
        self._comp_att = add("I", 9 if mask.compass and mask.compass_pose_attachment else 0)
        self._laser = add("H", 1 + self.laser_words if mask.laser else 0)
        self._laser_att = add("I", 9 if mask.laser and mask.laser_pose_attachment else 0)
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
        m = self.mask
        if m.laser and len(raw.laser) != self.laser_words:
            return layout_for(m, len(raw.laser)).encode_payload(raw)
        vals: list[int] = []
        irs = raw.ir
        for i in range(0, len(self.ir_ids), 2):
            lo = irs[i] & 0xF
            hi = irs[i + 1] & 0xF if i + 1 < len(irs) else 0
            vals.append(lo | (hi << 4))
        if m.ir_pose_attachment:
            for a in raw.ir_att:
                vals.extend(encode_attachment(a))
        vals.extend(raw.sonar)
        if m.sonar_pose_attachment:
            for a in raw.sonar_att:
                vals.extend(encode_attachment(a))
        if m.bumper:
            b = raw.bumper
            vals.extend(((b >> 16) & 0xFF, (b >> 8) & 0xFF, b & 0xFF))  # N200: high byte first
            if m.bumper_pose_attachment:
                vals.extend(encode_attachment(raw.bumper_att or _NO_ATT))
        vals.extend(to_sm16(raw.pose[i]) for i in self.pose_idx)
        vals.extend(to_sm16(raw.vel[i]) for i in self.vel_idx)
        if m.compass:
            vals.append(to_sm16(raw.compass))
            if m.compass_pose_attachment:
                vals.extend(encode_attachment(raw.compass_att or _NO_ATT))
        if m.laser:
            vals.append(len(raw.laser) if raw.laser_count is None else raw.laser_count)
            vals.extend(raw.laser)
            if m.laser_pose_attachment:
                vals.extend(encode_attachment(raw.laser_att or _NO_ATT))
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
            If the payload length does not match this layout (or, with the laser in the
            mask, the laser point count).
        """
        n = len(payload)
        if n != self.size:
            extra = n - self.size
            if self.mask.laser and self.laser_words == 0 and extra > 0 and extra % 2 == 0:
                return layout_for(self.mask, extra // 2).decode(payload)
            raise PayloadError(
                f"state reply has {n} payload bytes, the mask implies {self.size}"
                + (" plus the laser points" if self.mask.laser else "")
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
                    i: decode_attachment(v[b + 9 * k : b + 9 * k + 9])
                    for k, i in enumerate(self.ir_ids)
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
                    i: decode_attachment(v[c + 9 * k : c + 9 * k + 9])
                    for k, i in enumerate(self.sonar_ids)
                }
        if m.bumper:
            a = self._bump[0]
            st.bumper = (v[a] << 16) | (v[a + 1] << 8) | v[a + 2]
            if m.bumper_pose_attachment:
                b = self._bump_att[0]
                st.bumper_attachment = decode_attachment(v[b : b + 9])
        if self.pose_idx:
            pose: list[float | None] = [None] * 4
            a = self._pose[0]
            for k, i in enumerate(self.pose_idx):
                pose[i] = from_sm16(v[a + k]) * _POSE_UNITS[i]
            st.x, st.y, st.steer, st.turret = pose
        if self.vel_idx:
            vel: list[float | None] = [None] * 3
            a = self._vel[0]
            for k, i in enumerate(self.vel_idx):
                vel[i] = from_sm16(v[a + k]) * _VEL_UNITS[i]
            st.trans_vel, st.steer_vel, st.turret_vel = vel
        if m.compass:
            a = self._comp[0]
            st.compass = from_sm16(v[a])
            if m.compass_pose_attachment:
                b = self._comp_att[0]
                st.compass_attachment = decode_attachment(v[b : b + 9])
        if m.laser:
            a, b = self._laser
            count, words = v[a], v[a + 1 : b]
            if len(words) not in (count, 4 * count):
                raise PayloadError(
                    f"state reply has {len(words)} laser words for {count} laser points"
                )
            st.laser_count, st.laser = count, tuple(words)
            if m.laser_pose_attachment:
                c = self._laser_att[0]
                st.laser_attachment = decode_attachment(v[c : c + 9])
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

        def att(a: PoseAttachment | None) -> RawAttachment | None:
            return None if a is None else attachment_values(a)

        return RawState(
            ir=tuple(st.ir[i] for i in self.ir_ids),
            ir_att=tuple(attachment_values(st.ir_attachments[i]) for i in self.ir_ids)
            if m.ir_pose_attachment
            else (),
            sonar=tuple(st.sonar_raw[i] for i in self.sonar_ids),
            sonar_att=tuple(attachment_values(st.sonar_attachments[i]) for i in self.sonar_ids)
            if m.sonar_pose_attachment
            else (),
            bumper=st.bumper or 0,
            bumper_att=att(st.bumper_attachment),
            pose=(r16(st.x, IN10), r16(st.y, IN10), r16(st.steer, DEG10), r16(st.turret, DEG10)),
            vel=(r16(st.trans_vel, IN10), r16(st.steer_vel, DEG10), r16(st.turret_vel, DEG10)),
            compass=st.compass or 0,
            compass_att=att(st.compass_attachment),
            laser=st.laser,
            laser_count=st.laser_count,
            laser_att=att(st.laser_attachment),
            motor_status=st.motor_status,
            clock_ms=round(st.clock * 1000),
            cpu_voltage=st.cpu_voltage_raw,
            motor_voltage=st.motor_voltage_raw,
        )


@lru_cache(maxsize=256)
def layout_for(mask: StateMask, laser_words: int = 0) -> StateLayout:
    """The (cached) :class:`StateLayout` of ``mask`` (and of its laser words, if any)."""
    return StateLayout(mask, laser_words)

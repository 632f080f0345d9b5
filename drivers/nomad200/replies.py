"""Replies that do not depend on the mask: GET_SN (all sonars), GET_RC (pose), GET_RV
(velocities). Robot units on the wire, SI units out.

Examples
--------
>>> from nomad200.codec import decode_frame
>>> decode_get_rc(decode_frame(encode_get_rc(100, -100, 900, 0)).payload).x
0.254
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import NamedTuple

from nomad200.codec import encode_frame, from_sm16, to_sm16
from nomad200.errors import PayloadError
from nomad200.state_types import (
    DEG10,
    IN10,
    INCH,
    NO_ECHO,
    PoseAttachment,
    decode_attachment,
    encode_attachment,
)

__all__ = [
    "Configuration",
    "SonarScan",
    "decode_get_rc",
    "decode_get_rv",
    "decode_get_sn",
    "encode_get_rc",
    "encode_get_rv",
    "encode_get_sn",
]


def _sonar_si(v: int) -> float | None:
    return None if v == NO_ECHO else v * INCH


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
    sonar: tuple[int, ...], attachments: tuple[tuple[int, ...], ...] | None, clock_ms: int
) -> bytes:
    """A GET_SN reply frame (16 sonar bytes, optional 16 attachments, clock)."""
    body = _SN.pack(*sonar)
    if attachments is not None:
        body += _SN_ATT.pack(*[w for a in attachments for w in encode_attachment(a)])
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
        atts = {i: decode_attachment(w[9 * i : 9 * i + 9]) for i in range(16)}
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

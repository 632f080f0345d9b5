"""Codec: byte-exact encodings worked out by hand from the protocol notes, and round trips."""

from __future__ import annotations

import math
from typing import cast

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nomad200.codec import (
    Cmd,
    Command,
    Packet,
    decode_command,
    decode_frame,
    encode_command,
    encode_frame,
    from_sm16,
    from_sm32,
    to_sm16,
    to_sm32,
)
from nomad200.errors import (
    ChecksumError,
    EndByteError,
    GarbageError,
    LengthError,
    NomadProtocolError,
    PayloadError,
    TruncatedPacketError,
)
from nomad200.mask import POSE_FIELDS, VELOCITY_FIELDS, StateMask
from nomad200.replies import (
    decode_get_rc,
    decode_get_rv,
    decode_get_sn,
    encode_get_rc,
    encode_get_rv,
    encode_get_sn,
)
from nomad200.state import RawState, layout_for


def h(s: str) -> bytes:
    return bytes.fromhex(s)


# ---------------------------------------------------------------- by hand


def test_sign_magnitude_by_hand() -> None:
    assert to_sm16(-450) == 0x81C2  # |n| = 0x01C2, sign bit 0x8000
    assert to_sm16(300) == 0x012C
    assert from_sm16(0x8001) == -1
    assert from_sm16(0x8000) == 0  # "negative zero"
    assert to_sm32(-5) == 0x80000005
    assert from_sm32(0x80000005) == -5
    with pytest.raises(ValueError, match="32767"):
        to_sm16(32768)


@pytest.mark.parametrize(
    ("frame", "expected"),
    [
        # 01 + 02 + 00 + 07 = 0x0a
        (encode_command(Cmd.GS), "01 02 00 07 0a 5c"),
        (encode_command(Cmd.ST), "01 02 00 09 0c 5c"),
        (encode_command(Cmd.ZR), "01 02 00 0d 10 5c"),
        # PR 100, -450, 0: 64 00 | c2 81 | 00 00; sum 1+8+3+100+194+129 = 435 -> 0xb3
        (encode_command(Cmd.PR, 100, -450, 0), "01 08 00 03 64 00 c2 81 00 00 b3 5c"),
        # SP 200, 450, 450 unsigned: c8 00 c2 01 c2 01; sum 1+8+2+200+194+1+194+1 = 601 -> 0x59
        (encode_command(Cmd.SP, 200, 450, 450), "01 08 00 02 c8 00 c2 01 c2 01 59 5c"),
        # DP -1, 1 -> 01 80 01 00; sum 1+6+12+1+128+1 = 149 -> 0x95
        (encode_command(Cmd.DP, -1, 1), "01 06 00 0c 01 80 01 00 95 5c"),
        # CONF_TM 2: sum 1+3+18+2 = 24
        (encode_command(Cmd.CONF_TM, 2), "01 03 00 12 02 18 5c"),
        # WS 1 1 1 10: sum 1+6+31+1+1+1+10 = 51 -> 0x33
        (encode_command(Cmd.WS, 1, 1, 1, 10), "01 06 00 1f 01 01 01 0a 33 5c"),
        # CT: all 16 sonars + pose: 00 00 ff ff 1e 00 00; sum 1+9+6+255+255+30 = 556 -> 0x2c
        (
            encode_command(Cmd.CT, 0, 0, 255, 255, 0x1E, 0, 0),
            "01 09 00 06 00 00 ff ff 1e 00 00 2c 5c",
        ),
        # MV (VM 100) (IGNORE 0) (PR -10): 01 00 64 00 | 00 00 00 00 | 02 00 0a 80
        # sum 1+14+43+1+100+2+10+128 = 299 -> 0x2b
        (
            encode_command(Cmd.MV, 1, 100, 0, 0, 2, -10),
            "01 0e 00 2b 01 00 64 00 00 00 00 00 02 00 0a 80 2b 5c",
        ),
    ],
)
def test_command_bytes_by_hand(frame: bytes, expected: str) -> None:
    assert frame == h(expected)


def test_conf_sn_has_length_19_and_terminator() -> None:
    f = encode_command(Cmd.CONF_SN, 10, 0, 1, 15, *([255] * 13))
    assert f[1:3] == b"\x13\x00"  # len 19
    assert f[4:9] == h("0a 00 01 0f ff")
    assert len(f) == 23
    assert f[-2] == sum(f[:-2]) % 256 and f[-1] == 0x5C


def test_ct_mask_bytes() -> None:
    m = StateMask(
        sonars=frozenset({0, 1, 15}), pose=True, velocities=True, sonar_pose_attachment=True
    )
    assert m.ct_args() == (0, 0, 0b11, 0x80, 0b11111110, 0, 0b100)
    assert StateMask.from_ct_args(m.ct_args()) == m


def test_ct_mask_takes_laser_and_partial_groups() -> None:
    laser = StateMask.from_ct_args((0, 0, 0, 0, 0, 1, 0b10000))
    assert laser.laser and laser.laser_pose_attachment and not laser.compass
    xy = StateMask.from_ct_args((0, 0, 0, 0, 0b110, 0, 0))
    assert xy.pose_order == ("x", "y") and not xy.pose and not xy.velocity_fields
    tv_sv = StateMask.from_ct_args((0, 0, 0, 0, 0b01100000, 0, 0))
    assert tv_sv.velocity_order == ("trans_vel", "steer_vel") and not tv_sv.velocities
    assert tv_sv.ct_args() == (0, 0, 0, 0, 0b01100000, 0, 0)
    # unused bits are ignored
    assert StateMask.from_ct_args((0, 0, 0, 0, 0, 0xFE, 0xC0)) == StateMask()
    with pytest.raises(ValueError, match="7 mask bytes"):
        StateMask.from_ct_args((0,) * 6)
    with pytest.raises(ValueError, match="unknown pose fields"):
        StateMask(pose_fields=frozenset({"z"}))  # type: ignore[arg-type]


def test_state_reply_by_hand() -> None:
    # mask: sonar 0 + pose. type GS, sonar 40, x 100, y -100, steer 900, turret 0,
    # status 0, clock 1500 ms, voltages 230 230: checksum 1214 % 256 = 0xbe
    wire = h("01 12 00 07 28 64 00 64 80 84 03 00 00 00 dc 05 00 00 e6 e6 be 5c")
    lay = layout_for(StateMask(sonars=frozenset({0}), pose=True))
    raw = RawState(
        sonar=(40,), pose=(100, -100, 900, 0), clock_ms=1500, cpu_voltage=230, motor_voltage=230
    )
    assert lay.encode_frame(Cmd.GS, raw) == wire
    pkt = decode_frame(wire)
    s = lay.decode(pkt.payload)
    assert s.sonar == {0: pytest.approx(40 * 0.0254)}
    assert s.x == pytest.approx(0.254) and s.y == pytest.approx(-0.254)
    assert s.steer == pytest.approx(math.pi / 2) and s.turret == 0.0
    assert s.clock == 1.5 and s.cpu_voltage_raw == 230 and s.motor_status == 0
    assert s.trans_vel is None


def test_state_reply_with_attachment_by_hand() -> None:
    lay = layout_for(StateMask(sonars=frozenset({3}), sonar_pose_attachment=True))
    att = (-5, 10, 900, 1800, 0, -20, 0, 1000, 1040)
    raw = RawState(sonar=(255,), sonar_att=(att,), clock_ms=2000)
    payload = lay.encode_payload(raw)
    assert payload[0] == 255
    assert payload[1:5] == h("05 00 00 80")  # x = -5, sign-magnitude 32 bit
    assert payload[21:25] == h("14 00 00 80")  # steer velocity -20
    s = lay.decode(payload)
    assert s.sonar == {3: None} and s.sonar_raw == {3: 255}
    a = s.sonar_attachments[3]
    assert a.x == pytest.approx(-0.0127) and a.steer == pytest.approx(math.pi / 2)
    assert a.velocities[1] == pytest.approx(-math.radians(2))
    assert (a.pose_time, a.reading_time) == (1.0, 1.04)


def test_other_replies() -> None:
    f = encode_get_rc(10, -10, 3599, 0)
    assert decode_get_rc(decode_frame(f).payload) == pytest.approx(
        (0.0254, -0.0254, math.radians(359.9), 0.0)
    )
    f = encode_get_rv(-200, 450, 0)
    assert decode_get_rv(decode_frame(f).payload) == pytest.approx((-0.508, math.radians(45), 0))
    sn = tuple(range(16))
    scan = decode_get_sn(decode_frame(encode_get_sn(sn, None, 77)).payload, attachments=False)
    assert scan.sonar_raw == dict(enumerate(sn)) and scan.clock == 0.077
    with pytest.raises(PayloadError):
        decode_get_rc(b"\x00")


# ---------------------------------------------------------------- errors


@pytest.mark.parametrize(
    ("wire", "exc"),
    [
        ("00 02 00 07 0a 5c", GarbageError),
        ("01 02 00 07 0b 5c", ChecksumError),
        ("01 02 00 07 0a 5d", EndByteError),
        ("01 02 00 07 0a", TruncatedPacketError),
        ("01 01 00 07 0a 5c", LengthError),
    ],
)
def test_decode_frame_errors(wire: str, exc: type[Exception]) -> None:
    with pytest.raises(exc):
        decode_frame(h(wire))
    assert issubclass(exc, NomadProtocolError)


def test_decode_command_rejects_bad_payloads() -> None:
    with pytest.raises(PayloadError, match="expected 6"):
        decode_command(Packet(Cmd.PR, b"\x00"))
    with pytest.raises(PayloadError, match="unsupported"):
        decode_command(Packet(99, b""))


# ---------------------------------------------------------------- round trips

u16 = st.integers(0, 0xFFFF)
s16 = st.integers(-32767, 32767)
u8 = st.integers(0, 255)
ARGS = {
    Cmd.AC: st.tuples(u16, u16, u16),
    Cmd.SP: st.tuples(u16, u16, u16),
    Cmd.PR: st.tuples(s16, s16, s16),
    Cmd.PA: st.tuples(s16, s16, s16),
    Cmd.VM: st.tuples(s16, s16, s16),
    Cmd.MV: st.tuples(u16, s16, u16, s16, u16, s16),
    Cmd.CT: st.tuples(*[u8] * 7),
    Cmd.DP: st.tuples(s16, s16),
    Cmd.DA: st.tuples(s16, s16),
    Cmd.WS: st.tuples(u8, u8, u8, u8),
    Cmd.CONF_SN: st.tuples(*[u8] * 17),
    Cmd.CONF_TM: st.tuples(u8),
    **{
        c: st.just(()) for c in (Cmd.GS, Cmd.ST, Cmd.LP, Cmd.ZR, Cmd.GET_SN, Cmd.GET_RC, Cmd.GET_RV)
    },
}


@settings(max_examples=150, deadline=None)
@given(st.sampled_from(sorted(ARGS)).flatmap(lambda c: st.tuples(st.just(c), ARGS[c])))
def test_command_round_trip(case: tuple[Cmd, tuple[int, ...]]) -> None:
    code, args = case
    frame = encode_command(code, *args)
    assert frame[0] == 1 and frame[-1] == 0x5C
    assert frame[1] | frame[2] << 8 == len(frame) - 4
    assert decode_command(decode_frame(frame)) == Command(code, args)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 255), st.binary(max_size=300))
def test_frame_round_trip(ptype: int, payload: bytes) -> None:
    assert decode_frame(encode_frame(ptype, payload)) == (ptype, payload)


ids = st.frozensets(st.integers(0, 15))
att = st.tuples(*[st.integers(-(2**31) + 1, 2**31 - 1)] * 7, *[st.integers(0, 2**32 - 1)] * 2)


P4 = tuple[int, int, int, int]
V3 = tuple[int, int, int]


def keep(vals: tuple[int, ...], names: tuple[str, ...], chosen: frozenset[str]) -> tuple[int, ...]:
    """The values of the chosen fields; 0 for the others (as a decoded reply gives back)."""
    return tuple(v if f in chosen else 0 for v, f in zip(vals, names, strict=True))


@st.composite
def mask_and_raw(draw: st.DrawFn) -> tuple[StateMask, RawState]:
    m = StateMask.from_ct_args(draw(st.tuples(*[u8] * 7)))
    n_ir, n_so = len(m.irs), len(m.sonars)
    pose, vel = draw(st.tuples(s16, s16, s16, s16)), draw(st.tuples(s16, s16, s16))
    n_laser = draw(st.integers(0, 5)) if m.laser else 0
    n_words = n_laser * (4 if draw(st.booleans()) else 1)  # line or point mode
    return m, RawState(
        ir=tuple(draw(st.lists(st.integers(0, 15), min_size=n_ir, max_size=n_ir))),
        ir_att=tuple(draw(st.lists(att, min_size=n_ir, max_size=n_ir)))
        if m.ir_pose_attachment
        else (),
        sonar=tuple(draw(st.lists(u8, min_size=n_so, max_size=n_so))),
        sonar_att=tuple(draw(st.lists(att, min_size=n_so, max_size=n_so)))
        if m.sonar_pose_attachment
        else (),
        bumper=draw(st.integers(0, 2**24 - 1)) if m.bumper else 0,
        bumper_att=draw(att) if m.bumper and m.bumper_pose_attachment else None,
        pose=cast(P4, keep(pose, POSE_FIELDS, m.pose_fields)),
        vel=cast(V3, keep(vel, VELOCITY_FIELDS, m.velocity_fields)),
        compass=draw(s16) if m.compass else 0,
        compass_att=draw(att) if m.compass and m.compass_pose_attachment else None,
        laser=tuple(draw(st.lists(u16, min_size=n_words, max_size=n_words))),
        laser_count=n_laser if m.laser else None,
        laser_att=draw(att) if m.laser and m.laser_pose_attachment else None,
        motor_status=draw(st.integers(0, 7)),
        clock_ms=draw(st.integers(0, 2**32 - 1)),
        cpu_voltage=draw(u8),
        motor_voltage=draw(u8),
    )


@settings(max_examples=150, deadline=None)
@given(mask_and_raw())
def test_state_round_trip(case: tuple[StateMask, RawState]) -> None:
    mask, raw = case
    assert StateMask.from_ct_args(mask.ct_args()) == mask
    lay = layout_for(mask)
    frame = lay.encode_frame(Cmd.GS, raw)
    assert len(frame) == lay.frame_size + 2 * len(raw.laser)
    pkt = decode_frame(frame)
    st_ = lay.decode(pkt.payload)
    assert set(st_.sonar) == mask.sonars
    assert (st_.x is None) == ("x" not in mask.pose_fields)
    assert (st_.turret_vel is None) == ("turret_vel" not in mask.velocity_fields)
    assert (st_.laser_count is None) == (not mask.laser)
    assert lay.raw_from_state(st_) == raw

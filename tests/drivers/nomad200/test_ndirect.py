"""The emulator answers the masks Nomadic's host library (Ndirect.c) sends, byte for byte.

Replies are checked three ways: their length against a formula, their fields by a walk
over the bytes in the host library's order (written here independently of
:class:`nomad200.state.StateLayout`), and through :mod:`nomad200`'s own decoder, both
against the model's true state.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import serial
from hypothesis import given, settings
from hypothesis import strategies as st
from procs import stop_process

from nomad200 import Client
from nomad200.codec import Cmd, decode_frame, encode_command
from nomad200.emulator import NomadModel, VirtualClock
from nomad200.mask import StateMask
from nomad200.state import DEG10, IN10, INCH, State, layout_for

from .conftest import nomad_url, start_emulator

H = bytes.fromhex
#: connect_robot -> init_sensors -> ct(): every mask entry set, no pose attachments
CONNECT_CT = H("01 09 00 06 ff ff ff ff ff 01 01 0d 5c")
GS = H("01 02 00 07 0a 5c")
CONF_TM_5 = H("01 03 00 12 05 1b 5c")
CONF_SN_ALL = H("01 13 00 0f 0a 00 02 0f 01 0e 03 0d 04 0c 05 0b 06 0a 07 09 08 a5 5c")
#: the library's connect sequence: CT, GS, CONF_TM, CONF_SN (interleaved order), GS
CONNECT_SEQUENCE = (CONNECT_CT, GS, CONF_TM_5, CONF_SN_ALL, GS)
NAK = H("01 02 00 08 0b 5c")
#: length of the state reply frame to the connect mask: 8 IR + 16 sonar + 3 bumper
#: + 8 pose + 6 velocity + 2 compass + 2 laser count + 7 tail, plus type and framing
CONNECT_REPLY_LEN = 58

POSE_AND_VEL = ("x", "y", "steer", "turret", "trans_vel", "steer_vel", "turret_vel")
UNITS = (IN10, IN10, DEG10, DEG10, IN10, DEG10, DEG10)


def test_the_sequence_bytes_are_the_library_s() -> None:
    assert encode_command(Cmd.CT, 255, 255, 255, 255, 255, 1, 1) == CONNECT_CT
    assert encode_command(Cmd.CONF_TM, 5) == CONF_TM_5
    order = (0, 2, 15, 1, 14, 3, 13, 4, 12, 5, 11, 6, 10, 7, 9, 8)
    assert encode_command(Cmd.CONF_SN, 10, *order) == CONF_SN_ALL
    assert encode_command(Cmd.GS) == GS


# ---------------------------------------------------------------- oracles


def reply_len(mask: bytes) -> int:
    """Frame length of the state reply to CT ``mask`` (zero laser points)."""
    b0, b1, b2, b3, b4, b5, b6 = mask
    n_ir, n_so = bin(b0 | b1 << 8).count("1"), bin(b2 | b3 << 8).count("1")
    n = (n_ir + 1) // 2 + (36 * n_ir if b6 & 2 else 0) + n_so + (36 * n_so if b6 & 4 else 0)
    n += (3 + (36 if b6 & 8 else 0)) if b4 & 1 else 0
    n += 2 * bin(b4 >> 1).count("1")
    n += (2 + (36 if b6 & 32 else 0)) if b6 & 1 else 0
    n += (2 + (36 if b6 & 16 else 0)) if b5 & 1 else 0
    return 1 + n + 7 + 5  # type, fields, motor/clock/voltages, framing


def walk(payload: bytes, mask: bytes) -> dict[str, Any]:
    """Read a state payload field by field in the host library's order."""
    b0, b1, b2, b3, b4, b5, b6 = mask
    irs = [i for i in range(16) if (b0 | b1 << 8) >> i & 1]
    sonars = [i for i in range(16) if (b2 | b3 << 8) >> i & 1]
    at, out = 0, {}

    def u16() -> int:
        nonlocal at
        at += 2
        return payload[at - 2] | payload[at - 1] << 8

    out["ir"] = [payload[at + k // 2] >> 4 * (k & 1) & 15 for k in range(len(irs))]
    at += (len(irs) + 1) // 2 + (36 * len(irs) if b6 & 2 else 0)
    out["sonar"] = dict(zip(sonars, payload[at : at + len(sonars)], strict=True))
    at += len(sonars) + (36 * len(sonars) if b6 & 4 else 0)
    if b4 & 1:
        out["bumper"] = payload[at : at + 3]
        at += 3 + (36 if b6 & 8 else 0)
    for bit, name in enumerate(POSE_AND_VEL, start=1):
        if b4 >> bit & 1:
            u = u16()
            out[name] = -(u & 0x7FFF) if u & 0x8000 else u
    if b6 & 1:
        out["compass"] = u16()
        at += 36 if b6 & 32 else 0
    if b5 & 1:
        out["laser_count"] = u16()
        at += 2 * out["laser_count"] + (36 if b6 & 16 else 0)
    out["motor_status"] = payload[at]
    out["clock"] = int.from_bytes(payload[at + 1 : at + 5], "little")
    out["end"] = at + 7
    return out


def truth(m: NomadModel) -> dict[str, int]:
    """The model's true odometry, velocities and clock in robot units."""
    d = m.drive
    vals = (d.x, d.y, d.steer.pos % 3600, d.turret.pos % 3600, d.trans.vel, d.steer.vel)
    return {
        **dict(zip(POSE_AND_VEL, [round(v) for v in (*vals, d.turret.vel)], strict=True)),
        "clock": m.clock_ms(),
        "motor_status": d.motor_status(),
    }


def check_reply(reply: bytes, mask: bytes, ptype: int, m: NomadModel | None) -> State:
    """Assert ``reply`` is the state packet ``mask`` implies and holds ``m``'s true state."""
    assert reply != NAK
    assert len(reply) == reply_len(mask)
    pkt = decode_frame(reply)
    assert pkt.type == ptype
    fields = walk(pkt.payload, mask)
    assert fields["end"] == len(pkt.payload)
    state = layout_for(StateMask.from_ct_args(tuple(mask))).decode(pkt.payload)
    assert state.laser_count == (0 if mask[5] & 1 else None) == fields.get("laser_count")
    assert all(v == 15 for v in fields["ir"]) and set(state.ir.values()) <= {15}
    assert {i: r for i, r in state.sonar_raw.items()} == fields["sonar"]
    for name, unit in zip(POSE_AND_VEL, UNITS, strict=True):
        got = getattr(state, name)
        assert (got is None) == (name not in fields)
        if got is not None:
            assert got == pytest.approx(fields[name] * unit)
    if m is not None:
        true = truth(m)
        for name in POSE_AND_VEL:
            assert fields.get(name, true[name]) == true[name]
        assert fields["sonar"] == {i: m.sonar_raw[i] for i in fields["sonar"]}
        assert fields["clock"] == true["clock"] and state.clock == true["clock"] / 1000
        assert fields["motor_status"] == true["motor_status"] == state.motor_status
    return state


def const_path(path: float):  # type: ignore[no-untyped-def]
    def fn(tx, txh, rx, rxh):  # type: ignore[no-untyped-def]
        return np.full(len(txh), path)

    return fn


def moving_model() -> NomadModel:
    """A robot in mid-motion with every sonar reading 2 m paths (39 in)."""
    clock = VirtualClock(100.0)
    m = NomadModel(echo=const_path(2.0), clock=clock)
    for cmd in (
        encode_command(Cmd.DP, 1234, -567),
        encode_command(Cmd.DA, 900, 450),
        CONF_SN_ALL,
        encode_command(Cmd.VM, 100, -50, 30),
    ):
        m.feed(cmd)
    clock.advance(0.7)
    m.advance()
    return m


def ask(m: NomadModel, frame: bytes) -> bytes:
    ((_, reply),) = m.feed(frame)
    return reply


# ---------------------------------------------------------------- masks


def test_connect_ct_gets_a_state_reply_with_an_empty_laser_field() -> None:
    m = moving_model()
    reply = ask(m, CONNECT_CT)
    assert len(reply) == CONNECT_REPLY_LEN and reply[1:3] == bytes((54, 0))
    st = check_reply(reply, CONNECT_CT[4:11], Cmd.CT, m)
    # the laser count sits just before the 7-byte tail and its checksum and end byte
    assert reply[-11:-9] == b"\x00\x00"
    assert st.laser == () and st.compass == 0 and st.bumper == 0 and len(st.sonar) == 16
    assert st.sonar[0] == pytest.approx(39 * INCH) and st.trans_vel == pytest.approx(100 * IN10)
    assert m.naks == 0


@pytest.mark.parametrize(
    ("mask", "length"),
    [
        ((0, 0, 0, 0, 0b0000110, 0, 0), 17),  # x and y only
        ((0, 0, 0, 0, 0b1100000, 0, 0), 17),  # translation and steering velocity only
        ((0, 0, 0, 0, 0b0100010, 0, 0), 17),  # x and translation velocity
        # ct() with sonar 13 off: the turret-velocity bit goes with it
        ((0xFF, 0xFF, 0xFF, 0xDF, 0x7F, 1, 1), 55),
        ((0, 0, 0, 0, 0, 1, 0b10000), 51),  # laser with its (empty) pose attachment
    ],
)
def test_partial_groups_and_laser(mask: tuple[int, ...], length: int) -> None:
    m = moving_model()
    reply = ask(m, encode_command(Cmd.CT, *mask))
    assert len(reply) == length
    check_reply(reply, bytes(mask), Cmd.CT, m)
    check_reply(ask(m, GS), bytes(mask), Cmd.GS, m)


def test_partial_replies_byte_for_byte() -> None:
    m = NomadModel(clock=VirtualClock(100.0))
    ask(m, encode_command(Cmd.DP, 1234, -567))
    # x = 1234 (d2 04), y = -567 (37 82), motor status 0, clock 0 ms, voltages 230 230
    assert ask(m, encode_command(Cmd.CT, 0, 0, 0, 0, 0b110, 0, 0)) == H(
        "01 0d 00 06 d2 04 37 82 00 00 00 00 00 e6 e6 6f 5c"
    )
    # translation and steering velocity (both 0), no turret velocity
    assert ask(m, encode_command(Cmd.CT, 0, 0, 0, 0, 0b1100000, 0, 0)) == H(
        "01 0d 00 06 00 00 00 00 00 00 00 00 00 e6 e6 e0 5c"
    )


@settings(max_examples=200, deadline=None)
@given(st.binary(min_size=7, max_size=7))
def test_any_ct_mask(mask: bytes) -> None:
    m = moving_model()
    check_reply(ask(m, encode_command(Cmd.CT, *mask)), mask, Cmd.CT, m)


# ---------------------------------------------------------------- the connect sequence


def test_connect_sequence_on_the_model() -> None:
    m = moving_model()
    for frame in CONNECT_SEQUENCE:
        reply = ask(m, frame)
        assert len(reply) == CONNECT_REPLY_LEN
        check_reply(reply, CONNECT_CT[4:11], frame[3], m)
    assert m.order == [0, 2, 15, 1, 14, 3, 13, 4, 12, 5, 11, 6, 10, 7, 9, 8]
    assert m.watchdog_s == 5 and m.naks == 0


def read_frame(port: serial.Serial) -> bytes:
    head = port.read(3)
    assert len(head) == 3, f"no reply (got {head.hex(' ')})"
    n = head[1] | head[2] << 8
    return head + port.read(n + 1)


def test_connect_sequence_over_a_pty(tmp_path: Path, box_world: Path) -> None:
    link, proc = start_emulator(tmp_path, world=box_world, fast=True, baud=38400)
    try:
        with serial.Serial(link, 38400, timeout=2.0) as port:
            replies = []
            for frame in CONNECT_SEQUENCE:
                port.write(frame)
                replies.append(read_frame(port))
    finally:
        stop_process(proc)
    for frame, reply in zip(CONNECT_SEQUENCE, replies, strict=True):
        assert len(reply) == CONNECT_REPLY_LEN
        st = check_reply(reply, CONNECT_CT[4:11], frame[3], None)
        assert (st.x, st.y, st.steer, st.turret, st.trans_vel) == (0, 0, 0, 0, 0)
    clocks = [decode_frame(r).payload[-6:-2] for r in replies]
    assert clocks == sorted(clocks, key=lambda c: int.from_bytes(c, "little"))


def test_client_with_a_partial_mask() -> None:
    mask = StateMask(sonars=frozenset({0}), pose_fields=frozenset({"x", "y"}), laser=True)
    with Client(nomad_url(fast=True, baud=38400), baud=38400) as c:
        c.define_position(1.0, -0.5)
        st = c.configure_mask(mask)
        assert st.x == pytest.approx(1.0, abs=IN10) and st.y == pytest.approx(-0.5, abs=IN10)
        assert st.steer is None and st.trans_vel is None and st.laser_count == 0

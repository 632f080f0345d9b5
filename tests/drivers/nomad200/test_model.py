"""The device model alone, on a virtual clock: sonar timing, crosstalk, watchdog, NAK."""

from __future__ import annotations

import io
import json
import math

import numpy as np
import pytest

from nomad200.codec import Cmd, decode_frame, encode_command
from nomad200.emulator import Faults, Link, NomadModel, VirtualClock
from nomad200.emulator.sonar import SPEED_OF_SOUND
from nomad200.state import StateMask, layout_for


def const_path(path: float):  # type: ignore[no-untyped-def]
    def fn(tx, txh, rx, rxh):  # type: ignore[no-untyped-def]
        return np.full(len(txh), path)

    return fn


def send(m: NomadModel, code: Cmd, *args: int) -> bytes:
    out = m.feed(encode_command(code, *args))
    assert len(out) == 1
    return out[0][1]


def new_model(**kw):  # type: ignore[no-untyped-def]
    clock = VirtualClock(100.0)
    trace = io.StringIO()
    m = NomadModel(clock=clock, trace=trace, **kw)
    return m, clock, trace


def records(trace: io.StringIO, kind: str) -> list[dict]:  # type: ignore[type-arg]
    return [r for r in map(json.loads, trace.getvalue().splitlines()) if r["type"] == kind]


def test_firing_order_and_rate() -> None:
    m, clock, trace = new_model(echo=const_path(2.0))
    send(m, Cmd.CONF_SN, 10, 0, 1, 15, *([255] * 13))  # 40 ms, front three
    clock.advance(0.5)
    m.advance()
    fires = records(trace, "firing")
    assert [f["sonar"] for f in fires[:6]] == [0, 1, 15, 0, 1, 15]
    assert np.allclose(np.diff([f["t"] for f in fires]), 0.04)
    assert len(fires) == 12  # 0.5 s / 40 ms
    assert all(f["raw"] == round(1.0 / 0.0254) and not f["crosstalk"] for f in fires)


def test_crosstalk_when_fired_faster_than_echoes_die() -> None:
    # an echo path of 10 m returns after 29 ms
    slow, clock, trace = new_model(echo=const_path(10.0))
    send(slow, Cmd.CONF_SN, 10, 0, *([255] * 15))  # 40 ms: own echo heard
    clock.advance(0.2)
    slow.advance()
    assert {f["raw"] for f in records(trace, "firing")} == {round(5.0 / 0.0254)}
    fast, clock, trace = new_model(echo=const_path(10.0))
    send(fast, Cmd.CONF_SN, 5, 0, *([255] * 15))  # 20 ms: the last echo lands 9 ms in
    clock.advance(0.2)
    fast.advance()
    f = records(trace, "firing")
    assert f[0]["raw"] == 255 and not f[0]["crosstalk"]  # nothing heard in the first window
    late = (10.0 / SPEED_OF_SOUND - 0.02) * SPEED_OF_SOUND / 2
    assert all(r["crosstalk"] and r["raw"] == round(late / 0.0254) for r in f[1:])


def test_reading_appears_when_its_echo_is_in() -> None:
    m, clock, _ = new_model(echo=const_path(6.0))  # 17.5 ms round trip
    send(m, Cmd.CT, *StateMask(sonars=frozenset({0})).ct_args())
    send(m, Cmd.CONF_SN, 25, 0, *([255] * 15))  # fires at +100 ms
    lay = layout_for(StateMask(sonars=frozenset({0})))
    clock.advance(0.110)
    assert lay.decode(decode_frame(send(m, Cmd.GS)).payload).sonar_raw == {0: 255}
    clock.advance(0.010)
    assert lay.decode(decode_frame(send(m, Cmd.GS)).payload).sonar_raw == {0: round(3 / 0.0254)}


def test_watchdog_stops_motion() -> None:
    m, clock, trace = new_model()
    send(m, Cmd.CONF_TM, 1)
    send(m, Cmd.VM, 100, 0, 0)
    clock.advance(0.9)
    m.advance()
    assert m.drive.trans.vel == 100
    clock.advance(1.0)
    m.advance()
    assert not m.drive.moving and m.drive.trans.vel == 0
    assert len(records(trace, "watchdog")) == 1
    x = m.drive.x
    clock.advance(5.0)
    m.advance()
    assert m.drive.x == x


def test_nak_for_damaged_or_refused_packets() -> None:
    m, _, trace = new_model()
    bad = bytearray(encode_command(Cmd.GS))
    bad[-2] ^= 1
    nak = encode_command(Cmd.GS)[:0] + bytes.fromhex("01 02 00 08 0b 5c")
    assert [r for _, r in m.feed(bytes(bad))] == [nak]
    assert [r for _, r in m.feed(b"\x01\x03\x00\x07\x00\x0b\x5c")] == [nak]  # GS with a payload
    refused = encode_command(Cmd.CONF_SN, 10, 16, *([255] * 15))  # there is no sonar 16
    assert [r for _, r in m.feed(refused)] == [nak]
    assert [r for _, r in m.feed(b"\xff\xfe")] == []  # stray bytes are ignored
    assert m.naks == 3 and len(records(trace, "nak")) == 3
    assert decode_frame(m.feed(encode_command(Cmd.GS))[0][1]).type == Cmd.GS


def test_trace_has_true_world_pose() -> None:
    m, clock, trace = new_model(echo=const_path(2.0), start_pose=(1.0, 2.0, math.pi / 2))
    send(m, Cmd.DP, 1000, 0)  # odometry says x = 100 in; the world does not move
    send(m, Cmd.CONF_SN, 10, 4, *([255] * 15))
    clock.advance(0.05)
    m.advance()
    (f,) = records(trace, "firing")
    assert f["world"] == pytest.approx(
        {"x": 1.0, "y": 2.0, "theta": math.pi / 2, "turret": math.pi / 2}
    )
    assert f["odom"]["x"] == pytest.approx(2.54)
    assert records(trace, "command")[0]["cmd"] == "DP"


def test_wait_stopped_and_zero_take_robot_time() -> None:
    m, _, _ = new_model()
    send(m, Cmd.PR, 100, 900, 0)
    t0 = m.t
    send(m, Cmd.WS, 1, 1, 1, 30)
    assert not m.drive.moving and 1.0 < m.t - t0 < 5.0
    t1 = m.t
    send(m, Cmd.ZR)
    assert m.t - t1 > 0.5 and (m.drive.x, m.drive.steer.pos) == (0.0, 0.0)


def test_link_timing_and_faults() -> None:
    clock = VirtualClock()
    link = Link(NomadModel(clock=clock), baud=9600)
    (d,) = link.receive(encode_command(Cmd.GS), 0.0)
    # 6 bytes in, 13 back (empty mask: type, status, clock 4, volts 2 + framing 5)
    assert d.t == pytest.approx((6 + 13) * 10 / 9600)
    f = Faults(garble=1.0, seed=0)
    out, delay = f.apply(b"\x01\x02\x03")
    assert delay == 0 and all(a != b for a, b in zip(out, b"\x01\x02\x03", strict=True))
    assert Faults(drop=1.0).apply(b"abc")[0] == b""
    assert Faults(stall=1.0, stall_s=3).apply(b"abc") == (b"abc", 3)
    with pytest.raises(ValueError, match=r"0\.\.1"):
        Faults(drop=2)

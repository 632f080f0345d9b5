"""Nomad 200 benchmarks: codec throughput and polls per second against the link budget.

Run with ``./scripts/bench`` (``pytest -m benchmark -s tests/benchmarks``).
"""

from __future__ import annotations

import struct
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from procs import stop_process

from nomad200 import Client, StateMask
from nomad200.codec import Cmd, decode_frame
from nomad200.state import RawState, layout_for

pytestmark = pytest.mark.benchmark

FULL = StateMask(
    sonars=frozenset(range(16)),
    irs=frozenset(range(16)),
    pose=True,
    velocities=True,
    bumper=True,
    compass=True,
)
RAW = RawState(
    ir=tuple(range(16)),
    sonar=tuple(range(40, 56)),
    bumper=0x010203,
    pose=(1234, -567, 900, 2700),
    vel=(200, -45, 0),
    compass=1800,
    motor_status=3,
    clock_ms=123456,
    cpu_voltage=230,
    motor_voltage=231,
)
BOX = """\
name: box
start_pose: {x: 0.0, y: 0.0, theta_deg: 0.0}
surfaces:
  - {type: room, x_min: -2.0, x_max: 2.0, y_min: -2.0, y_max: 3.0}
"""


def _rate(fn: object, seconds: float = 1.0) -> float:
    f = fn  # type: ignore[assignment]
    n = 0
    t0 = time.perf_counter()
    while True:
        for _ in range(500):
            f()  # type: ignore[operator]
        n += 500
        dt = time.perf_counter() - t0
        if dt >= seconds:
            return n / dt


def test_bench_state_codec() -> None:
    lay = layout_for(FULL)
    frame = lay.encode_frame(Cmd.GS, RAW)

    def ours() -> None:
        wire = lay.encode_frame(Cmd.GS, RAW)
        lay.decode(decode_frame(wire).payload)

    # floor: one plain struct.pack + unpack of the same bytes, no framing or units
    plain = struct.Struct(f"<{len(frame)}B")
    vals = tuple(frame)

    def floor() -> None:
        plain.unpack(plain.pack(*vals))

    r = _rate(ours)
    base = _rate(floor)
    print(
        f"\nnomad200 state codec: {len(frame)}-byte full state packet, encode+decode "
        f"{r:,.0f}/s (target >= 50,000/s); plain struct.pack+unpack of the same bytes "
        f"{base:,.0f}/s; ratio {r / base:.2f}"
    )


@pytest.fixture
def pty_port(tmp_path: Path) -> Iterator[str]:
    world = tmp_path / "box.yaml"
    world.write_text(BOX)
    link = tmp_path / "nomad"
    p = subprocess.Popen(
        [sys.executable, "-m", "nomad200.emulator_cli", "--world", str(world),
         "--baud", "38400", "--link", str(link)],
        stdout=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    try:
        assert p.stdout is not None and p.stdout.readline().startswith("/dev/")
        yield str(link)
    finally:
        stop_process(p)


@pytest.mark.parametrize("transport", ["pty", "url"])
def test_bench_polls_per_second(transport: str, request: pytest.FixtureRequest) -> None:
    baud = 38400
    if transport == "pty":
        port = request.getfixturevalue("pty_port")
    else:
        port = f"nomad://bench?baud={baud}"
    mask = StateMask(sonars=frozenset(range(16)), pose=True)
    with Client(port, baud=baud) as c:
        c.configure_mask(mask)
        c.configure_sonars(range(16), 0.04)
        for _ in range(10):
            c.get_state()
        n = 0
        t0 = time.perf_counter()
        while (dt := time.perf_counter() - t0) < 2.0:
            c.get_state()
            n += 1
        counters = c.counters()
    per_poll = 6 + layout_for(mask).frame_size  # GS request + state reply
    allowed = baud / 10 / per_poll
    got = n / dt
    print(
        f"\nnomad200 polls over {transport} at {baud} baud: {got:.1f} polls/s; the link allows "
        f"{allowed:.1f} polls/s ({per_poll} bytes per poll); ratio {got / allowed:.3f} "
        f"(target >= 0.90); counters {counters}"
    )
    if transport == "url":
        from nomad200.protocol_nomad import reset_devices

        reset_devices()

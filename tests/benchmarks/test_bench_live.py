"""Benchmarks of the Foxglove live view: what it costs ``watch``, and what it costs ``sonard``.

* ``sonarproc watch --foxglove`` following a log that grows at 25 readings/s (a simulated
  room replayed by a writer process, so surfaces appear and change) with one client
  connected: its CPU time over a window, as a share of one core (target <= 20 %), beside
  an idle Python process (the floor).
* ``sonard`` with and without ``--foxglove`` (one client connected), side by side over the
  same window, each against its own real-timing emulator: polls (GS commands, from the
  emulator's trace) per second, and their ratio (target: the viewer costs < 2 %).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path
from typing import Any

import pytest
import yaml
from procs import stop_process

pytest.importorskip("foxglove")

ROOT = Path(__file__).resolve().parents[2]
SUPPORT = ROOT / "tests" / "support"
WORLD = ROOT / "configs" / "worlds" / "lab.yaml"
SCENARIO = ROOT / "configs" / "scenarios" / "room-box.yaml"
EMULATOR = [
    sys.executable,
    "-c",
    "import sys; from nomad200.emulator_cli import main; sys.exit(main())",
]
SONARPROC = [sys.executable, "-c", "import sys; from sonarproc.cli import main; sys.exit(main())"]
RATE = 25.0  # readings per second, sonard's rate with five sonars every 40 ms
WARMUP_S = 6.0
WINDOW_S = 20.0
CPU_TARGET = 0.20
POLL_LOSS_TARGET = 0.02

# Appends a finished log's readings to a new log at RATE readings/s, in 0.2 s batches.
WRITER = textwrap.dedent(
    """
    import sys, time
    from sonarlog import LogWriter, read_log
    src, dst, rate = sys.argv[1], sys.argv[2], float(sys.argv[3])
    lg = read_log(src)
    w = LogWriter(dst, lg.sensors, speed_of_sound=lg.speed_of_sound, flush_interval=0.25)
    w.flush()
    step = max(1, round(rate * 0.2))
    t0 = time.monotonic()
    for i in range(0, len(lg.readings), step):
        w.append(lg.readings[i:i + step])
        time.sleep(max(0.0, t0 + (i + step) / rate - time.monotonic()))
    w.close()
    """
)


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process (s)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("NOTIFY_SOCKET", "JOURNAL_STREAM")}
    env["PYTHONPATH"] = os.pathsep.join([str(SUPPORT), env.get("PYTHONPATH", "")])
    return env


@contextmanager
def process(cmd: list[str], **kw: Any) -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen(cmd, text=True, env=_env(), **kw)
    try:
        yield proc
    finally:
        stop_process(proc)


def _port(stream: Any) -> int:
    """The port a process prints; the rest of its output is drained in the background."""
    for line in stream:
        m = re.search(r"Foxglove live view on ws://[^ ]*:(\d+)", line)
        if m:
            threading.Thread(target=stream.read, daemon=True).start()
            return int(m.group(1))
    raise AssertionError("no port printed")


@pytest.mark.benchmark
@pytest.mark.timeout(300)
def test_watch_cpu_at_25_readings_per_s(tmp_path: Path) -> None:
    from sonarproc.simulate import simulate_to_log

    src = tmp_path / "room.h5"
    simulate_to_log(SCENARIO, src)
    log = tmp_path / "growing.h5"
    with ExitStack() as stack:
        stack.enter_context(process([sys.executable, "-c", WRITER, str(src), str(log), str(RATE)]))
        end = time.monotonic() + 30
        while not log.exists() and time.monotonic() < end:
            time.sleep(0.05)
        watch = stack.enter_context(
            process(
                [
                    *SONARPROC,
                    "watch",
                    str(log),
                    "--foxglove",
                    "127.0.0.1:0",
                    "--out",
                    str(tmp_path / "report"),
                ],
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
            )
        )
        port = _port(watch.stdout)
        stack.enter_context(
            process(
                [
                    sys.executable,
                    str(SUPPORT / "foxglove_client.py"),
                    f"ws://127.0.0.1:{port}",
                    str(WARMUP_S + WINDOW_S + 10),
                ],
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
            )
        )
        idle = stack.enter_context(
            process([sys.executable, "-c", f"import time; time.sleep({WARMUP_S + WINDOW_S + 5})"])
        )
        time.sleep(WARMUP_S)
        assert watch.poll() is None
        c0, i0, t0 = cpu_seconds(watch.pid), cpu_seconds(idle.pid), time.monotonic()
        time.sleep(WINDOW_S)
        c1, i1 = cpu_seconds(watch.pid), cpu_seconds(idle.pid)
        wall = time.monotonic() - t0
        assert watch.poll() is None, "watch stopped before the end of the window"
    share = (c1 - c0) / wall
    print(
        f"\nwatch --foxglove at {RATE:g} readings/s (room-box replayed, one client): "
        f"{100 * share:.1f} % of one core over {wall:.1f} s (target <= {100 * CPU_TARGET:g} %)"
        f"\n  idle python process (floor): {100 * (i1 - i0) / wall:.2f} %"
    )
    assert share <= CPU_TARGET


def _dwell_plan(tmp: Path, seconds: float) -> Path:
    plan = tmp / "dwell.yaml"
    plan.write_text(
        yaml.safe_dump(
            {
                "name": "bench",
                "sonars": [0, 2, 14, 1, 15],
                "interval": 0.040,
                "baud": 38400,
                "pose_attachments": True,
                "steps": [
                    {"define_pose": {"x": -0.75, "y": 0.0, "theta": 0, "turret": 90}},
                    {"dwell": {"seconds": seconds}},
                ],
            }
        )
    )
    return plan


@contextmanager
def emulator(tmp: Path, name: str) -> Iterator[tuple[str, Path]]:
    trace = tmp / f"{name}.jsonl"
    with process(
        [*EMULATOR, "--world", str(WORLD), "--baud", "38400", "--trace", str(trace)],
        stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=tmp,
    ) as proc:  # fmt: skip
        assert proc.stdout is not None
        yield proc.stdout.readline().strip(), trace


def _polls_per_s(trace: Path) -> tuple[float, int]:
    """GS commands per second of robot time over the middle of the run (and how many)."""
    times = []
    for line in trace.read_text().splitlines():
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            continue
        if rec.get("type") == "command" and rec.get("cmd") == "GS":
            times.append(rec["t"])
    times = times[len(times) // 5 : len(times) - len(times) // 10]  # drop start-up and end
    assert len(times) > 50, f"only {len(times)} polls traced"
    return (len(times) - 1) / (times[-1] - times[0]), len(times)


def _side_by_side(tmp: Path, plan: Path, rep: int) -> tuple[Path, Path]:
    """One sonard without and one with a viewer (and a client), at the same time."""
    with ExitStack() as stack:
        pty_a, trace_a = stack.enter_context(emulator(tmp, f"plain{rep}"))
        pty_b, trace_b = stack.enter_context(emulator(tmp, f"viewed{rep}"))
        plain = stack.enter_context(
            process(
                [sys.executable, "-m", "sonard", "--port", pty_a, "--plan", str(plan), "--out",
                 str(tmp / f"plain{rep}.h5")],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )
        )  # fmt: skip
        viewed = stack.enter_context(
            process(
                [sys.executable, "-m", "sonard", "--port", pty_b, "--plan", str(plan), "--out",
                 str(tmp / f"viewed{rep}.h5"), "--foxglove", "127.0.0.1:0"],
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
            )
        )  # fmt: skip
        port = _port(viewed.stderr)
        stack.enter_context(
            process(
                [sys.executable, str(SUPPORT / "foxglove_client.py"),
                 f"ws://127.0.0.1:{port}", str(WARMUP_S + WINDOW_S + 10)],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            )
        )  # fmt: skip
        assert plain.wait(WARMUP_S + WINDOW_S + 60) == 0
        assert viewed.wait(60) == 0
    return trace_a, trace_b


@pytest.mark.benchmark
@pytest.mark.timeout(400)
def test_sonard_polls_with_a_viewer(tmp_path: Path) -> None:
    plan = _dwell_plan(tmp_path, WARMUP_S + WINDOW_S)
    # best of two side-by-side runs for each: the machine's load moves both alike
    plain_rate = viewed_rate = 0.0
    for rep in range(2):
        trace_a, trace_b = _side_by_side(tmp_path, plan, rep)
        plain_rate = max(plain_rate, _polls_per_s(trace_a)[0])
        viewed_rate = max(viewed_rate, _polls_per_s(trace_b)[0])
    ratio = viewed_rate / plain_rate
    print(
        f"\nsonard polls/s, dwell at 40 ms, 5 sonars, real-timing emulators side by side "
        f"(best of 2):\n  without a viewer: {plain_rate:.2f} /s"
        f"\n  --foxglove, one client: {viewed_rate:.2f} /s"
        f"  -> ratio {ratio:.3f} (target >= {1 - POLL_LOSS_TARGET:.2f})"
    )
    assert ratio >= 1 - POLL_LOSS_TARGET

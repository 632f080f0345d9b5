"""Benchmark: sonard's CPU use at the 40 ms firing rate, against the emulator in real time.

Three processes run over the same wall-clock window, each against its own
``nomad-emulator`` (real timing, 38400 baud, front five sonars firing every 40 ms):

* ``sonard`` running a dwell plan (polls, tags, queues, writes and fsyncs the log);
* a floor: a bare ``nomad200.Client`` loop that only polls GS with the same mask;
* an idle Python process (the interpreter's own background cost).

CPU time comes from ``/proc/<pid>/stat`` (utime + stime). The figure printed is sonard's
CPU as a percentage of one core (target < 5 %) and its ratio to the bare polling loop.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import pytest
import yaml
from procs import stop_process

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "configs" / "worlds" / "lab.yaml"
EMULATOR = [
    sys.executable,
    "-c",
    "import sys; from nomad200.emulator_cli import main; sys.exit(main())",
]
WARMUP_S = 3.0
WINDOW_S = 8.0
SONARS = [0, 2, 14, 1, 15]

BARE_LOOP = f"""
import sys, time
from nomad200 import Client, StateMask
c = Client(sys.argv[1], baud=38400, timeout=0.5)
c.open()
c.configure_mask(StateMask(sonars=frozenset({SONARS}), pose=True, sonar_pose_attachment=True))
c.configure_sonars(order={SONARS}, interval_s=0.04)
end = time.monotonic() + float(sys.argv[2])
while time.monotonic() < end:
    c.get_state()
c.close()
"""


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process (s)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@contextmanager
def emulator(tmp: Path) -> Iterator[str]:
    proc = subprocess.Popen(
        [*EMULATOR, "--world", str(WORLD), "--baud", "38400"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        cwd=tmp,
    )
    try:
        assert proc.stdout is not None
        yield proc.stdout.readline().strip()
    finally:
        stop_process(proc)


@contextmanager
def process(cmd: list[str]) -> Iterator[subprocess.Popen[bytes]]:
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        yield proc
    finally:
        stop_process(proc)


@pytest.mark.benchmark
@pytest.mark.timeout(120)
def test_sonard_cpu_at_40ms(tmp_path: Path) -> None:
    total = WARMUP_S + WINDOW_S + 2.0
    plan = tmp_path / "dwell.yaml"
    plan.write_text(
        yaml.safe_dump(
            {
                "name": "bench",
                "sonars": SONARS,
                "interval": 0.040,
                "baud": 38400,
                "pose_attachments": True,
                "steps": [
                    {"define_pose": {"x": -0.75, "y": 0.0, "theta": 0, "turret": 90}},
                    {"dwell": {"seconds": total}},
                ],
            }
        )
    )
    with ExitStack() as stack:
        pty_a = stack.enter_context(emulator(tmp_path))
        pty_b = stack.enter_context(emulator(tmp_path))
        sonard = stack.enter_context(
            process(
                [
                    sys.executable,
                    "-m",
                    "sonard",
                    "--port",
                    pty_a,
                    "--plan",
                    str(plan),
                    "--out",
                    str(tmp_path / "bench.h5"),
                ]
            )
        )
        bare = stack.enter_context(process([sys.executable, "-c", BARE_LOOP, pty_b, str(total)]))
        idle = stack.enter_context(
            process([sys.executable, "-c", f"import time; time.sleep({total})"])
        )
        time.sleep(WARMUP_S)
        procs = {"sonard": sonard, "bare poll loop": bare, "idle python": idle}
        for name, p in procs.items():
            assert p.poll() is None, f"{name} exited early ({p.returncode})"
        c0 = {n: cpu_seconds(p.pid) for n, p in procs.items()}
        t0 = time.monotonic()
        time.sleep(WINDOW_S)
        c1 = {n: cpu_seconds(p.pid) for n, p in procs.items()}
        wall = time.monotonic() - t0
        sonard.terminate()
        assert sonard.wait(5) == 0
    pct = {n: 100.0 * (c1[n] - c0[n]) / wall for n in procs}
    ratio = pct["sonard"] / max(pct["bare poll loop"], 1e-9)
    print(
        f"\nsonard CPU at 40 ms firing, 5 sonars + pose attachments, 38400 baud, real timing: "
        f"{pct['sonard']:.2f} % of one core over {wall:.1f} s (target < 5 %)\n"
        f"  bare GS poll loop (floor): {pct['bare poll loop']:.2f} %  -> ratio {ratio:.2f}x\n"
        f"  idle python process:       {pct['idle python']:.2f} %"
    )

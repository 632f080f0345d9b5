"""The benchmarks' room log and child-process runner, shared by ``tests/benchmarks``.

The log: 25 firings/s for an hour (90 000 readings) from a Nomad-like ring wandering in a
20 m x 20 m room. Every firing returns the range to the wall along its beam axis (a
diffusely reflecting room: every reading makes an arc, the worst case for the rasteriser).
``run_child`` runs ``python ARGS`` as a fresh process, timed from the outside, with its own
peak RSS.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOM = 20.0
RATE = 25.0
C = 343.3

# The child reports its own peak RSS (VmHWM): Linux carries ru_maxrss across fork + exec,
# so os.wait4 would report the larger of the child and the pytest parent it forked from.
PEAK = (
    "import atexit, re, sys\n"
    "def _peak():\n"
    "    text = open('/proc/self/status').read()\n"
    "    kib = int(re.search(r'VmHWM:\\s*(\\d+)', text).group(1))\n"
    "    sys.stderr.write(f'VMHWM_BYTES={kib * 1024}\\n')\n"
    "atexit.register(_peak)\n"
)
# The report writer is wrapped so the child reports the wall and CPU seconds spent writing
# the report directory (figures, HTML, JSON, CSV, and any import they trigger).
# sonarproc.cli comes first, as in the console script: it sets the one-thread BLAS before
# anything loads numpy (the report module does). Imported after numpy, the run measured
# OpenBLAS's thread pool, which the command never uses (0.4 s more on the real log).
RUN = (
    PEAK
    + "import time\n"
    + "import sonarproc.cli\n"
    + "import sonarproc.report as _report\n"
    + "_write = _report.write_report\n"
    + "def _timed(*a, **k):\n"
    + "    t0, c0 = time.perf_counter(), time.process_time()\n"
    + "    try:\n"
    + "        return _write(*a, **k)\n"
    + "    finally:\n"
    + "        t, c = time.perf_counter() - t0, time.process_time() - c0\n"
    + "        sys.stderr.write(f'REPORT_S={t} {c}\\n')\n"
    + "_report.write_report = _timed\n"
    + "from sonarproc.cli.entry import run_console; run_console()"
)
FLOOR = (
    PEAK
    + """
import sys, numpy as np
from sonarlog import read_log
lg = read_log(sys.argv[1]); n, cells = int(sys.argv[2]), int(sys.argv[3])
rng = np.random.default_rng(0)
idx = rng.integers(0, cells, n)
m = np.bincount(idx, minlength=cells).astype(np.uint16)
print(int(m.sum()), lg.readings.size)
"""
)


def write_room_log(path: Path, hours: float, seed: int = 0, *, truth: bool = True) -> int:
    """Simulate ``hours`` of 16-sonar firings in the room; return the number of readings.

    ``truth=False`` leaves ``/truth`` out (a robot's log: no surface metrics are computed).
    """
    from logbuilders import ring_sensors, ring_walk_readings

    from sonarlog import LogWriter

    n = round(hours * 3600 * RATE)
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    # a slow Lissajous wander over [1.5, 18.5]^2 and a turret turning 10 deg/s
    x = ROOM / 2 + 8.5 * np.sin(2 * np.pi * t / 1370.0)
    y = ROOM / 2 + 8.5 * np.sin(2 * np.pi * t / 910.0 + 0.7)
    turret = np.deg2rad(10.0) * t
    sens = ring_sensors()

    def to_wall(px: np.ndarray, py: np.ndarray, h: np.ndarray) -> np.ndarray:
        c, s = np.cos(h), np.sin(h)
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(c > 0, (ROOM - px) / c, np.where(c < 0, -px / c, np.inf))
            ty = np.where(s > 0, (ROOM - py) / s, np.where(s < 0, -py / s, np.inf))
        return np.asarray(np.minimum(tx, ty))

    r = ring_walk_readings(t, x, y, turret, to_wall, rng, sensors=sens, speed_of_sound=C)
    corners = np.array([[0, 0], [ROOM, 0], [ROOM, ROOM], [0, ROOM], [0, 0]], dtype=float)
    with LogWriter(
        path, sens, speed_of_sound=C, robot="bench", truth=corners if truth else None
    ) as w:
        w.append(r)
    return n


def run_child(
    args: list[str], tmp: Path, env: dict[str, str] | None = None
) -> tuple[float, int, str, str]:
    """Run ``python args``; return wall seconds, its own peak RSS (bytes), stdout, stderr."""
    t0 = time.perf_counter()
    with (tmp / "stderr.txt").open("w+b") as err:
        proc = subprocess.Popen(
            [sys.executable, *args], stdout=subprocess.PIPE, stderr=err, env=env
        )
        try:
            assert proc.stdout is not None
            out = proc.stdout.read()
            _, status, usage = os.wait4(proc.pid, 0)  # this child's rusage, not the maximum
            proc.returncode = os.waitstatus_to_exitcode(status)
        finally:
            if proc.returncode is None:
                proc.kill()
                proc.wait()
            if proc.stdout is not None:
                proc.stdout.close()
        wall = time.perf_counter() - t0
        err.seek(0)
        text = err.read().decode()
        assert proc.returncode == 0, text
    marks = [line for line in text.splitlines() if line.startswith("VMHWM_BYTES=")]
    peak = int(marks[-1].split("=")[1]) if marks else usage.ru_maxrss * 1024
    return wall, peak, out.decode(), text

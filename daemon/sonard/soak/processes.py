"""The processes of a soak: the emulator, the sonards it runs, and looks at their resources.

:class:`SoakProcesses` starts :mod:`sonard.soak.emulator` (the lab world, a fault every few
seconds, a firing trace) in a work directory and starts sonards on its pseudo-terminal with
the plan :func:`write_plan` wrote; :func:`sample_process` reads a process's RSS and open
file descriptors from ``/proc``, :func:`wait_running` waits until a sonard holds the
port's lock file, and :func:`wait_polled` until it has polled the robot for a while.
The checks of what they did are in :mod:`sonard.soak.runner`.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO

__all__ = [
    "INTERVAL",
    "SONARS",
    "Sample",
    "SoakProcesses",
    "sample_process",
    "wait_polled",
    "wait_running",
    "write_plan",
]

#: firing interval (s) and sonars of the soak plan
INTERVAL = 0.04
SONARS = (14, 15, 0, 1, 2)


@dataclass
class Sample:
    """One look at the sonard process."""

    t: float
    rss_kib: int
    fds: int


def write_plan(path: Path, seconds: float) -> None:
    """Write the dwell plan sonard runs for ``seconds`` (and longer: it is stopped first)."""
    chunks = []
    left = seconds + 120.0  # sonard is stopped by SIGTERM before the plan ends
    while left > 0:
        chunks.append(f"  - dwell: {{seconds: {min(left, 3600.0):.1f}}}\n")
        left -= 3600.0
    path.write_text(
        f"name: soak\nsonars: {list(SONARS)}\ninterval: {INTERVAL}\nbaud: 38400\n"
        "pose_attachments: true\nfault_timeout_s: 120\nsteps:\n" + "".join(chunks),
        encoding="utf-8",
    )


def sample_process(pid: int) -> Sample | None:
    """RSS and open file descriptors of process ``pid`` now (None: it is gone)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text(encoding="ascii")
        fds = len(os.listdir(f"/proc/{pid}/fd"))
    except OSError:
        return None
    m = re.search(r"VmRSS:\s+(\d+)", status)
    return Sample(time.monotonic(), int(m.group(1)) if m else 0, fds)


class SoakProcesses:
    """The emulator and sonard processes of one soak, with the paths they share.

    Parameters
    ----------
    work : Path
        The work directory (link, trace, faults, plan, lock files, logs).
    fault_every : float
        Seconds between the emulator's injected faults.
    """

    def __init__(self, work: Path, fault_every: float) -> None:
        self.work = work
        self.link = work / "robot-tty"
        self.trace = work / "trace.jsonl"
        self.faults = work / "faults.jsonl"
        self.plan = work / "plan.yaml"
        self.env = {k: v for k, v in os.environ.items() if k not in ("NOTIFY_SOCKET",)}
        self.env["SONARD_LOCK_DIR"] = str(work / "lock")
        (work / "lock").mkdir(exist_ok=True)
        (work / "logs").mkdir(exist_ok=True)
        from sonarsim.shipped import resolve_shipped

        world = resolve_shipped("lab", kind="worlds")
        self._err = open(work / "emulator.err", "w", encoding="utf-8")  # noqa: SIM115 - closed in close()
        self.emulator = subprocess.Popen(
            [
                *(sys.executable, "-m", "sonard.soak.emulator", "--world", str(world)),
                *("--link", str(self.link), "--trace", str(self.trace)),
                *("--faults", str(self.faults), "--every", str(fault_every)),
            ],
            stdout=subprocess.PIPE,
            stderr=self._err,
            text=True,
            env=self.env,
        )
        assert self.emulator.stdout is not None
        if not self.emulator.stdout.readline().strip():
            raise RuntimeError(f"emulator did not start (see {work / 'emulator.err'})")

    def sonard(self, out: Path, err: IO[str]) -> subprocess.Popen[str]:
        """Start a sonard running the plan into the log ``out``, its stderr to ``err``."""
        return subprocess.Popen(
            [
                *(sys.executable, "-m", "sonard", "--port", str(self.link)),
                *("--plan", str(self.plan), "--out", str(out)),
            ],
            stdout=subprocess.DEVNULL,
            stderr=err,
            text=True,
            env=self.env,
        )

    def close(self) -> None:
        """Stop the emulator (SIGTERM, then SIGKILL after 10 s) and close its files."""
        if self.emulator.poll() is None:
            self.emulator.send_signal(signal.SIGTERM)
            try:
                self.emulator.wait(10)
            except subprocess.TimeoutExpired:
                self.emulator.kill()
                self.emulator.wait()
        if self.emulator.stdout is not None:
            self.emulator.stdout.close()
        self._err.close()


def wait_running(locks: Path, proc: subprocess.Popen[str]) -> None:
    """Until ``proc`` holds the port's lock file: it has finalised the logs and runs."""
    mine = f"{proc.pid:10d}\n"
    # generous: on a loaded machine a sonard's imports alone took over 30 s, and a SIGTERM
    # before it holds the lock leaves the last killed log unfinalised (returns at once
    # when the lock is held)
    deadline = time.monotonic() + 180.0
    while time.monotonic() < deadline and proc.poll() is None:
        for lock in locks.glob("LCK..*"):
            try:
                if lock.read_text(encoding="ascii") == mine:
                    return
            except OSError:
                pass  # a lock file being replaced
        time.sleep(0.1)


def wait_polled(
    trace: Path, start: int, seconds: float, proc: subprocess.Popen[str], timeout: float = 90.0
) -> tuple[float, float] | None:
    """Wait until ``proc`` has polled (GS) the robot for ``seconds`` of robot time.

    Counted on the robot's clock from the sonard's own polls in the emulator's trace, from
    byte ``start`` on (the trace's size when it was started): a loaded machine can take
    20 s of wall time to start a sonard, so a wall-clock delay could end it before its
    first reading.

    Returns
    -------
    (first, last) or None
        Robot times (s) of its first and latest poll; None when it exited or did not get
        there within ``timeout`` s of wall time.
    """
    deadline = time.monotonic() + timeout
    first: float | None = None
    pos, tail = start, b""
    while time.monotonic() < deadline and proc.poll() is None:
        with open(trace, "rb") as fh:  # only what was appended since the last look
            fh.seek(pos)
            chunk = fh.read()
        pos += len(chunk)
        *lines, tail = (tail + chunk).split(b"\n")
        for line in lines:
            if b'"GS"' not in line:
                continue
            t = float(json.loads(line)["t"])
            first = t if first is None else first
            if t - first >= seconds:
                return first, t
        time.sleep(0.05)
    return None

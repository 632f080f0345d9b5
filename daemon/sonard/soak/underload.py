"""Acquisition under load: shipped plans run while busy loops compete for the CPUs.

Usage::

    scripts/load-bench [PLAN ...] [--busy N] [--fast] [--dir DIR]

For each plan (default: every shipped plan) it starts ``--busy`` CPU-bound loops (2 by
default: a robot PC's planner and camera), the emulator on a pty at 38400 baud with a
firing trace, and a real sonard process, then reads the trace and the log:

* every firing after the plan's frame is in the log or inside a logged ``gap``
  (``unaccounted`` must be 0), and no reading lacks a firing;
* replies per second kept against the target (one poll per ``max(interval, line time)``)
  and the link's limit (one poll per line time), on the robot's clock;
* the worst latency: the longest a firing waited for the next reply to report it, and the
  longest interval between two replies (robot clock).

``--fast`` runs the emulator in virtual time (the robot clock moves only with the bytes, so
the host's load shows in wall time only); the default is real time, where it shows in the
polls kept. Prints one table row per plan and exits 1 when a plan failed or left a firing
unaccounted for.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from sonard.link import poll_seconds
from sonard.plan import load_plan
from sonard.soak.accounting import account_firings
from sonarlog import read_log
from sonarsim.shipped import resolve_shipped, shipped_dir

__all__ = ["LoadFigures", "busy_loops", "main", "run_under_load"]

EMULATOR = [
    sys.executable,
    "-c",
    "import sys; from nomad200.emulator_cli import main; sys.exit(main())",
]
SONARD = [sys.executable, "-m", "sonard"]
#: what a busy loop runs: CPU-bound until its parent (this process) is gone
_BUSY = "import os, sys\nparent = int(sys.argv[1])\nwhile os.getppid() == parent:\n    pass\n"


@dataclass
class LoadFigures:
    """What one plan did under load (robot-clock seconds unless said otherwise)."""

    plan: str
    exit_code: int
    wall_s: float
    robot_s: float
    firings: int
    logged: int
    in_gap: int
    unaccounted: int
    extra_readings: int
    replies_per_s: float
    target_per_s: float
    link_limit_per_s: float
    worst_fire_to_reply_s: float
    worst_reply_interval_s: float
    gaps: int
    error: str = ""


@contextlib.contextmanager
def busy_loops(n: int) -> Iterator[list[subprocess.Popen[bytes]]]:
    """Run ``n`` CPU-bound processes for the block; always kill them afterwards.

    Each also ends by itself once this process is gone (it watches its parent), so even a
    SIGKILL of the caller leaves no loop behind.
    """
    procs = [subprocess.Popen([sys.executable, "-c", _BUSY, str(os.getpid())]) for _ in range(n)]
    try:
        yield procs
    finally:
        for p in procs:
            p.kill()
        for p in procs:
            p.wait()


@dataclass
class _Trace:
    """The emulator trace: commands (robot time, name) and firings (robot time, sonar)."""

    cmd_t: np.ndarray
    cmd: list[str]
    fire_t: np.ndarray
    fire_sonar: np.ndarray


def _read_trace(path: Path) -> _Trace:
    cmd_t: list[float] = []
    cmd: list[str] = []
    fire_t: list[float] = []
    fire_sonar: list[int] = []
    for line in path.read_text().splitlines():
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:  # a line cut by the emulator's end
            continue
        if rec.get("type") == "command":
            cmd_t.append(float(rec["t"]))
            cmd.append(str(rec["cmd"]))
        elif rec.get("type") == "firing":
            fire_t.append(float(rec["t"]))
            fire_sonar.append(int(rec["sonar"]))
    return _Trace(np.array(cmd_t), cmd, np.array(fire_t), np.array(fire_sonar, dtype=np.int64))


def run_under_load(
    plan_path: Path,
    work: Path,
    *,
    busy: int = 2,
    fast: bool = False,
    timeout_s: float = 900.0,
) -> LoadFigures:
    """Run one plan with ``busy`` loops competing; return its figures."""
    plan = load_plan(plan_path)
    work.mkdir(parents=True, exist_ok=True)
    trace_path, out = work / "trace.jsonl", work / "run.h5"
    emu_cmd = [*EMULATOR, "--world", "lab", "--baud", "38400", "--trace", str(trace_path)]
    if fast:
        emu_cmd.append("--fast")
    env = {k: v for k, v in os.environ.items() if k not in ("NOTIFY_SOCKET", "JOURNAL_STREAM")}
    with busy_loops(busy):
        emu = subprocess.Popen(
            emu_cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
        )
        try:
            assert emu.stdout is not None
            pty = emu.stdout.readline().strip()
            t0 = time.monotonic()
            proc = subprocess.run(
                [*SONARD, "--port", pty, "--plan", str(plan_path), "--out", str(out)],
                capture_output=True,
                text=True,
                timeout=timeout_s,
                env=env,
                check=False,
            )
            wall = time.monotonic() - t0
        finally:
            emu.terminate()
            emu.wait(10)
    tr = _read_trace(trace_path)
    frame = max(t for t, c in zip(tr.cmd_t, tr.cmd, strict=True) if c in ("DP", "DA", "ZR"))
    end = float(tr.cmd_t[-1])
    reply_t = tr.cmd_t[(tr.cmd_t >= frame) & (tr.cmd_t <= end)]
    log = read_log(out)
    acc = account_firings(tr.fire_t, tr.fire_sonar, log, interval=plan.interval)
    inside = tr.fire_t[(tr.fire_t > frame) & (tr.fire_t < end)]
    nxt = np.minimum(np.searchsorted(reply_t, inside, side="left"), len(reply_t) - 1)
    waited = reply_t[nxt] - inside
    period = max(plan.interval, poll_seconds(len(plan.sonars), plan.use_attachments, plan.baud))
    gaps = 0 if log.events is None else int((log.events["kind"] == b"gap").sum())
    err = proc.stderr.strip().splitlines()[-1] if proc.returncode else ""
    return LoadFigures(
        plan=plan_path.stem,
        exit_code=proc.returncode,
        wall_s=round(wall, 1),
        robot_s=round(end - float(frame), 2),
        firings=acc.firings,
        logged=acc.logged,
        in_gap=acc.in_outage,
        unaccounted=acc.unaccounted,
        extra_readings=acc.extra_readings,
        replies_per_s=round(len(reply_t) / max(end - frame, 1e-9), 2),
        target_per_s=round(1.0 / period, 2),
        link_limit_per_s=round(
            1.0 / poll_seconds(len(plan.sonars), plan.use_attachments, plan.baud), 2
        ),
        worst_fire_to_reply_s=round(float(waited.max(initial=0.0)), 3),
        worst_reply_interval_s=round(float(np.diff(reply_t, prepend=frame).max()), 3),
        gaps=gaps,
        error=err,
    )


def shipped_plans() -> list[Path]:
    """Every plan sonard ships."""
    return sorted(shipped_dir("plans").glob("*.yaml"))


def main(argv: Sequence[str] | None = None) -> int:
    """Run the bench; return 0 when every plan completed with every firing accounted for."""
    p = argparse.ArgumentParser(prog="load-bench", description=__doc__.split("\n\n")[0])
    p.add_argument("plans", nargs="*", help="plan names or files (default: every shipped plan)")
    p.add_argument("--busy", type=int, default=2, help="CPU-bound loops competing (default 2)")
    p.add_argument("--fast", action="store_true", help="emulator in virtual time")
    p.add_argument("--dir", type=Path, help="keep the logs and traces here")
    args = p.parse_args(argv)
    plans = [resolve_shipped(x, kind="plans") for x in args.plans] or shipped_plans()
    work = args.dir or Path(tempfile.mkdtemp(prefix="load-bench-"))
    rows = []
    for plan in plans:
        fig = run_under_load(plan, work / plan.stem, busy=args.busy, fast=args.fast)
        rows.append(fig)
        print(json.dumps(asdict(fig)), flush=True)
    ok = all(f.exit_code == 0 and f.unaccounted == 0 and f.extra_readings == 0 for f in rows)
    print(f"load-bench: {'PASS' if ok else 'FAIL'} ({len(rows)} plans, {args.busy} busy loops, "
          f"{'virtual' if args.fast else 'real'} time; logs in {work})")  # fmt: skip
    return 0 if ok else 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

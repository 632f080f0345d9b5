"""An emulated robot on a real pty and sonard as a real process, for the daemon tests."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml
from procs import stop_process

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "configs" / "worlds" / "lab.yaml"
EMULATOR = [
    sys.executable,
    "-c",
    "import sys; from nomad200.emulator_cli import main; sys.exit(main())",
]


@contextmanager
def emulator_pty(tmp: Path, *extra: str, fast: bool = False) -> Iterator[tuple[str, Path]]:
    """Run nomad-emulator on a pty; yield (pty path, trace path); always stop it."""
    trace = tmp / "trace.jsonl"
    cmd = [*EMULATOR, "--world", str(WORLD), "--baud", "38400", "--trace", str(trace), *extra]
    if fast:
        cmd.append("--fast")
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline().strip()
        assert line.startswith("/dev/"), f"emulator printed {line!r}"
        yield line, trace
    finally:
        stop_process(proc)


def write_plan(tmp: Path, steps: list[Any], name: str = "plan", **over: Any) -> Path:
    """A plan YAML for the front five sonars at 38400 baud."""
    plan: dict[str, Any] = {"name": name, "sonars": [14, 15, 0, 1, 2], "baud": 38400}
    plan.update(over)
    plan["steps"] = steps
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump(plan), encoding="utf-8")
    return path


def start_sonard(port: str, plan: Path, out: Path, lock_dir: Path) -> subprocess.Popen[str]:
    """sonard as a process, lock files in ``lock_dir``, without systemd's variables."""
    env = {k: v for k, v in os.environ.items() if k not in ("NOTIFY_SOCKET", "JOURNAL_STREAM")}
    env["SONARD_LOCK_DIR"] = str(lock_dir)
    return subprocess.Popen(
        [sys.executable, "-m", "sonard", "--port", port, "--plan", str(plan), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )

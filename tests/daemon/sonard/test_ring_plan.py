"""The whole-ring wall-following plan, run by a real ``sonard`` process on the emulator."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from sonarlog import read_log
from sonarsim.shipped import resolve_shipped


def test_wallfollow_ring_plan_records_every_sonar(tmp_path: Path) -> None:
    out = tmp_path / "ring.h5"
    plan = str(resolve_shipped("wallfollow-ring", kind="plans"))
    cmd = [
        sys.executable, "-c", "import sys; from sonard.cli import main; sys.exit(main())",
        "--port", "nomad://?world=lab&fast=1", "--plan", plan, "--out", str(out),
    ]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert proc.returncode == 0, proc.stderr[-2000:]
    lg = read_log(out)
    r = lg.readings
    assert r.size > 1000
    assert np.unique(r["tx"]).tolist() == list(range(16))
    # the robot went round the room: its path spans most of it
    assert np.ptp(r["x"]) > 3.5 and np.ptp(r["y"]) > 2.5
    heard = np.isfinite(r["tof"])
    assert 0.2 < heard.mean() < 1.0

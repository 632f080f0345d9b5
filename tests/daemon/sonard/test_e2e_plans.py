"""End to end, every shipped plan: ``nomad-emulator`` on a real pty, ``sonard`` as a real
subprocess, two busy loops competing for the CPUs.

A file of its own (the other end-to-end cases are in test_e2e.py): the suite hands whole
files to its workers, and these are its longest end-to-end cases, so they run beside the
others rather than after them. The trace/log matching is the one test_e2e.py describes.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from sonard_e2e import (
    PLANS,
    assert_poses_match_truth,
    commands,
    emulator,
    finish,
    load_trace,
    start_sonard,
)

from sonard.plan import load_plan
from sonard.soak.accounting import account_firings, load_firings
from sonard.soak.underload import busy_loops
from sonarlog import read_log

pytestmark = [pytest.mark.timeout(120), pytest.mark.slow]


# ---------------------------------------------------------------------------- plans
@pytest.mark.timeout(400)  # a plan of up to 80 s of robot time, beside two busy loops
@pytest.mark.parametrize("name", ["translate", "turret-sweep", "room", "wallfollow-ring"])
def test_shipped_plan_runs_to_completion_under_load(name: str, tmp_path: Path) -> None:
    """Every shipped plan completes while two busy loops compete for the CPUs (a robot PC
    running a planner and a camera), and every firing is logged or inside a logged gap."""
    out = tmp_path / "run.h5"
    with busy_loops(2), emulator(tmp_path) as (pty, trace_path):
        rc, err = finish(start_sonard(pty, PLANS / f"{name}.yaml", out), 360)
        time.sleep(0.1)
    assert rc == 0, err
    log = read_log(out)
    trace = load_trace(trace_path)
    assert len(log.sensors) == 16
    assert len(log.readings) > 500
    assert log.time_ordered
    assert_poses_match_truth(log, trace)
    cmds = commands(trace)
    assert cmds[-1]["cmd"] == "ST"
    fire_t, fire_sonar = load_firings(trace_path)
    plan = load_plan(PLANS / f"{name}.yaml")
    acc = account_firings(fire_t, fire_sonar, log, interval=plan.interval)
    assert acc.unaccounted == 0 and acc.extra_readings == 0, acc
    assert acc.logged > 0.9 * acc.firings, acc  # gaps are the exception, not the rule
    kinds = [e["kind"].decode() for e in log.events]
    assert kinds[0] == "start" and kinds[-1] == "stop"
    assert "step" in kinds and "error" not in kinds and "late" not in kinds
    if name == "wallfollow-ring":  # every sonar fires; the robot went round the room
        r = log.readings
        assert r.size > 1000 and np.unique(r["tx"]).tolist() == list(range(16))
        assert np.ptp(r["x"]) > 3.5 and np.ptp(r["y"]) > 2.5
        assert 0.2 < np.isfinite(r["tof"]).mean() < 1.0
    if name == "translate":  # Fig. 16: stops every 2.5 cm from x = -0.75 to 0.75 m on y = 0
        r = log.readings
        xs = np.unique(np.round(r["x"] / 0.025))
        assert {-30, 0, 30} <= set(xs.astype(int).tolist())
        assert np.abs(r["y"]).max() < 0.003
        assert np.abs(r["turret"] - math.pi / 2).max() < 0.002

"""Faults beyond the serial link: a full disk, a stepped clock, a stopped daemon, a dead robot.

Each test runs the real ``nomad-emulator`` on a pty and ``sonard`` as a real process, and
states the outcome it expects. Durations are robot time (the plan's dwell) or generous
bounds with their reason beside them: the suite runs on a loaded 2-core machine.
"""

from __future__ import annotations

import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from sonard_e2e import (
    SONARD,
    commands,
    emulator,
    emulator_process,
    finish,
    load_trace,
    match_firings,
    start_sonard,
    write_plan,
)

from sonard.soak.accounting import account_firings, load_firings
from sonarlog import read_log

pytestmark = [pytest.mark.timeout(180), pytest.mark.slow]


def wait_for_recording(trace: Path, extra_s: float) -> None:
    """Wait until sonard set the frame (DA in the trace), then ``extra_s`` more seconds."""
    deadline = time.monotonic() + 60  # sonard's start-up (imports) on a loaded machine
    while time.monotonic() < deadline:
        if trace.exists() and '"cmd": "DA"' in trace.read_text():
            break
        time.sleep(0.05)
    else:
        pytest.fail("sonard never set the frame")
    time.sleep(extra_s)


def error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if "ERROR" in line]


# ------------------------------------------------------------------------------ disk full
def _can_mount_tmpfs() -> str | None:
    """None when this process may mount a tmpfs in a private mount namespace, else why not."""
    if shutil.which("unshare") is None:
        return "no unshare(1) on this machine"
    with tempfile.TemporaryDirectory() as d:
        probe = subprocess.run(
            ["unshare", "-rm", "sh", "-c", f"mount -t tmpfs -o size=64k tmpfs {shlex.quote(d)}"],
            capture_output=True,
            text=True,
            check=False,
        )
    if probe.returncode != 0:
        return f"cannot mount a tmpfs in a user namespace here: {probe.stderr.strip()[:120]}"
    return None


def test_disk_full_stops_cleanly_with_a_closed_log(tmp_path: Path) -> None:
    """The disk fills while logging: exit 1, one ERROR line, a cleanly closed log.

    A real ENOSPC: sonard writes to a 4 MiB tmpfs mounted in a private mount namespace
    (``unshare -rm``: no privileges needed where user namespaces are enabled, nothing left
    mounted if the test dies), and another program fills it while sonard logs.
    """
    why_not = _can_mount_tmpfs()
    if why_not is not None:
        pytest.skip(why_not)
    plan = write_plan(tmp_path, "full", [{"dwell": {"seconds": 60}}])
    keep = tmp_path / "kept"
    keep.mkdir()
    disk = tmp_path / "disk"
    disk.mkdir()
    with emulator(tmp_path, fast=False) as (pty, trace_path):
        sonard = " ".join(shlex.quote(a) for a in SONARD)
        script = f"""
            set -u
            mount -t tmpfs -o size=4m tmpfs {disk}
            {sonard} --port {pty} --plan {plan} --out {disk}/run.h5 2>{keep}/stderr &
            pid=$!
            # sonard gone before its first command (refused, crashed): fail now, by name
            until grep -q '"cmd": "DA"' {trace_path} 2>/dev/null; do
                kill -0 $pid 2>/dev/null || exit 3
                sleep 0.05
            done
            sleep 1
            date +%s.%N > {keep}/filled_at
            dd if=/dev/zero of={disk}/filler bs=64k 2>/dev/null
            wait $pid
            rc=$?
            date +%s.%N > {keep}/ended_at
            ls -a {disk} > {keep}/listing
            cp {disk}/run.h5 {keep}/run.h5
            exit $rc
        """
        res = subprocess.run(
            ["unshare", "-rm", "sh", "-c", script],
            capture_output=True,
            text=True,
            timeout=150,
            check=False,
        )
    stderr = (keep / "stderr").read_text()
    assert res.returncode == 1, stderr + res.stderr
    assert "Traceback" not in stderr
    errors = error_lines(stderr)
    assert len(errors) == 1, stderr
    assert errors[0].endswith(
        "ERROR sonard: cannot write the log {}: No space left on device".format(disk / "run.h5")
    ), stderr
    # it stopped at once, not at the end of its 60 s dwell (generous: a loaded machine)
    took = float((keep / "ended_at").read_text()) - float((keep / "filled_at").read_text())
    assert took < 20.0, took
    # the log is closed cleanly: plain HDF5 opens it, every row is intact, t in order
    with h5py.File(keep / "run.h5", "r") as f:
        assert f["readings"].shape[0] > 0
    log = read_log(keep / "run.h5")
    assert log.log_state == "closed" and log.dropped_rows == 0
    assert log.time_ordered and len(log.readings) > 10  # 1 s at 25 readings/s
    kinds = [e["kind"].decode() for e in log.events]
    assert kinds[-1] == "stop" and kinds.count("error") == 1, kinds
    assert b"No space left on device" in log.events[-1]["detail"]
    # the space reserve beside the log was given back
    assert [n for n in (keep / "listing").read_text().split() if n.endswith(".reserve")] == []


# ---------------------------------------------------------------------------- clock steps
_STEPPING_SONARD = """
import signal, sys, time
from sonard.cli import main

# The system clock as sonard sees it: stepped back an hour on SIGUSR1, forward two hours
# on SIGUSR2 (what an operator's `date -s` or an NTP step does to time.time()).
offset = [0.0]
real_time = time.time
time.time = lambda: real_time() + offset[0]
signal.signal(signal.SIGUSR1, lambda *_: offset.__setitem__(0, offset[0] - 3600.0))
signal.signal(signal.SIGUSR2, lambda *_: offset.__setitem__(0, offset[0] + 7200.0))
sys.exit(main(sys.argv[1:]))
"""


def test_clock_steps_keep_t_ordered_and_are_recorded(tmp_path: Path) -> None:
    """The system clock steps back 1 h, then forward 2 h, while sonard logs.

    The test cannot step this machine's clock (it is shared, and needs CAP_SYS_TIME), so
    the wall-clock source is replaced inside a real sonard process: ``time.time`` is what
    every UNIX time in sonard comes from. Expected: ``t`` stays in firing order and in
    step with the robot's clock, nothing is lost, and each step is a ``clock_step`` event.
    """
    plan = write_plan(tmp_path, "steps", [{"dwell": {"seconds": 5}}])
    out = tmp_path / "run.h5"
    env = {k: v for k, v in os.environ.items() if k not in ("NOTIFY_SOCKET", "JOURNAL_STREAM")}
    with emulator(tmp_path, fast=False) as (pty, trace_path):
        argv = ["--port", pty, "--plan", str(plan), "--out", str(out)]
        proc = subprocess.Popen(
            [sys.executable, "-c", _STEPPING_SONARD, *argv],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        wait_for_recording(trace_path, 1.0)
        proc.send_signal(signal.SIGUSR1)
        time.sleep(1.5)
        proc.send_signal(signal.SIGUSR2)
        rc, err = finish(proc, 90)
    assert rc == 0, err
    log = read_log(out)
    r = log.readings
    assert log.time_ordered and np.all(np.diff(r["t"]) >= 0)
    trace = load_trace(trace_path)
    match_firings(log, trace)  # every reading is its firing, to the millisecond
    steps = [e["detail"].decode() for e in log.events if e["kind"] == b"clock_step"]
    assert len(steps) == 2, steps
    assert "by -3600.0" in steps[0] and "by +7200.0" in steps[1]
    # events keep the log's time too: none is an hour away from the readings
    assert np.abs(log.events["t"] - r["t"].mean()).max() < 60.0
    fire_t, fire_sonar = load_firings(trace_path)
    acc = account_firings(fire_t, fire_sonar, log, interval=0.04)
    assert acc.unaccounted == 0 and acc.extra_readings == 0, acc


# ------------------------------------------------------------------------ SIGSTOP/SIGCONT
def test_sigstop_for_5_s_resumes_and_records_the_stall_as_a_gap(tmp_path: Path) -> None:
    """sonard is stopped (SIGSTOP) for 5 s mid-run: it resumes, and the stall is a gap."""
    plan = write_plan(tmp_path, "stop", [{"dwell": {"seconds": 10}}])
    out = tmp_path / "run.h5"
    with emulator(tmp_path, fast=False) as (pty, trace_path):
        proc = start_sonard(pty, plan, out)
        wait_for_recording(trace_path, 1.0)
        proc.send_signal(signal.SIGSTOP)
        time.sleep(5.0)
        proc.send_signal(signal.SIGCONT)
        rc, err = finish(proc, 90)
    assert rc == 0, err
    log = read_log(out)
    assert log.time_ordered
    gaps = [e for e in log.events if e["kind"] == b"gap"]  # detail: "until T: ..."
    longest = max(float(e["detail"].split()[1].rstrip(b":")) - float(e["t"]) for e in gaps)
    assert 4.5 <= longest <= 15.0, gaps  # the 5 s stop (plus the loaded machine's delays)
    fire_t, fire_sonar = load_firings(trace_path)
    acc = account_firings(fire_t, fire_sonar, log, interval=0.04)
    assert acc.unaccounted == 0 and acc.extra_readings == 0, acc
    assert acc.in_outage > 0.5 * 5.0 / 0.04  # the stall's firings are inside the gap
    assert commands(load_trace(trace_path))[-1]["cmd"] == "ST"  # the plan ran to its end


# ------------------------------------------------------------------------ emulator dies
def test_robot_dies_mid_run_aborts_after_the_fault_timeout(tmp_path: Path) -> None:
    """The emulator is killed mid-run: sonard records the fault, gives up after the fault
    timeout with exit 1 and one ERROR line, and leaves a closed log of what it read."""
    plan = write_plan(tmp_path, "dies", [{"dwell": {"seconds": 60}}], fault_timeout_s=3)
    out = tmp_path / "run.h5"
    with emulator_process(tmp_path, fast=False) as (emu, pty, trace_path):
        proc = start_sonard(pty, plan, out)
        wait_for_recording(trace_path, 1.0)
        emu.kill()
        killed_at = time.monotonic()
        rc, err = finish(proc, 60)
        took = time.monotonic() - killed_at
    assert rc == 1, err
    assert "Traceback" not in err
    errors = error_lines(err)
    assert len(errors) == 1 and "link down longer than 3 s" in errors[0], err
    assert took < 3.0 + 15.0  # the fault timeout plus start-up slack on a loaded machine
    log = read_log(out)
    assert log.log_state == "closed" and log.time_ordered and len(log.readings) > 10
    kinds = [e["kind"].decode() for e in log.events]
    assert "fault" in kinds and "abort" in kinds and kinds[-1] == "stop", kinds
    assert b"not answering" in log.events[-1]["detail"]

"""End to end: ``nomad-emulator`` on a real pty and ``sonard`` as a real subprocess.

The emulator's ``--trace`` holds every command it received and, for every sonar firing,
the robot clock and the TRUE pose; the log's ``clock`` event gives the UNIX time of robot
clock 0, so each logged reading is matched to its firing exactly (sonar id + firing time).
"""

from __future__ import annotations

import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from sonard_e2e import (
    PLANS,
    SONARD,
    assert_poses_match_truth,
    commands,
    emulator,
    finish,
    frame_time,
    load_trace,
    match_firings,
    start_sonard,
    write_plan,
)

from sonard.soak.accounting import account_firings, load_firings
from sonarlog import read_log

pytestmark = [pytest.mark.timeout(120), pytest.mark.slow]


# ---------------------------------------------------------------------- SIGKILL trials
# Real-time emulator + daemon pairs running at once; more would starve each other on the
# 2-core CI machine (the misses measured below are then the machine's, not sonard's).
_CONCURRENT_TRIALS = threading.Semaphore(5)


def _kill_trial(tmp: Path, seed: int, results: list[Any]) -> None:
    with _CONCURRENT_TRIALS:
        _run_kill_trial(tmp, seed, results)


def _run_kill_trial(tmp: Path, seed: int, results: list[Any]) -> None:
    rng = np.random.default_rng(seed)
    plan = write_plan(tmp, f"kill{seed}", [{"dwell": {"seconds": 8}}])
    out = tmp / "run.h5"
    try:
        with emulator(tmp, fast=False) as (pty, trace_path):
            proc = start_sonard(pty, plan, out)
            try:
                _wait_until_recording_for(trace_path, float(rng.uniform(0.8, 2.5)))
                proc.kill()
                proc.wait(5)
            finally:
                if proc.poll() is None:
                    proc.kill()
                proc.communicate()
            time.sleep(0.05)
        trace = load_trace(trace_path)
        log = read_log(out)
        t_frame = frame_time(trace)
        t_kill = commands(trace)[-1]["t"]  # last command sonard managed to send
        got = {(round(f["t"] * 1000), f["sonar"]) for f in match_firings(log, trace)}
        fired = [r for r in trace if r["type"] == "firing" and t_frame + 0.001 < r["t"] <= t_kill]
        last = max(t for t, _ in got) / 1000 if got else t_frame
        # lost to the kill: what fired after the last logged reading; before it, every
        # firing is logged or inside a logged gap (a poll stalled by a loaded machine)
        lost_s = t_kill - last
        fire_t, fire_sonar = load_firings(trace_path)
        acc = account_firings(fire_t, fire_sonar, log, interval=0.04)
        results.append((seed, round(lost_s, 3), len(log.readings), len(fired), acc.unaccounted))
    except BaseException as exc:  # report in the main thread
        results.append((seed, exc))


def _wait_until_recording_for(trace_path: Path, seconds: float) -> None:
    """Return once sonard has polled for ``seconds`` of robot time since it set the frame.

    The kill moment is counted on the robot's clock from sonard's own commands: on a
    loaded machine a sonard start-up took 20 s of wall time, so a wall-clock delay after
    start could kill it before its first reading (a trial that tests nothing).
    """
    # Generous: the 5 trials at once, start-up and 2.5 s of polls, beside two busy loops
    # and other tests on 2 cores (20 s of start-up measured); a sonard that never gets
    # there fails the trial here, by name.
    deadline = time.monotonic() + 90
    while time.monotonic() < deadline:
        cmds = commands(load_trace(trace_path)) if trace_path.exists() else []
        frame = [c["t"] for c in cmds if c["cmd"] == "DA"]
        if frame and cmds[-1]["cmd"] == "GS" and cmds[-1]["t"] - frame[0] >= seconds:
            return
        time.sleep(0.05)
    raise AssertionError(f"sonard did not poll for {seconds:.2f} s after DA within 90 s")


@pytest.mark.timeout(300)  # two waves of five trials, each up to 90 s to start (see above)
def test_sigkill_loses_at_most_one_second(tmp_path: Path) -> None:
    results: list[Any] = []
    threads = []
    for seed in range(10):
        d = tmp_path / f"trial{seed}"
        d.mkdir()
        th = threading.Thread(target=_kill_trial, args=(d, seed, results))
        th.start()
        threads.append(th)
        time.sleep(0.3)  # stagger start-up on 2 cores
    for th in threads:
        th.join(140)  # a trial waits 90 s at most for sonard, then reads its log
    assert len(results) == 10
    for res in results:
        if isinstance(res[1], BaseException):
            raise res[1]
    worst = max(r[1] for r in results)
    print("SIGKILL trials (seed, lost s, logged, fired, unaccounted):", results)
    assert all(r[2] > 0 for r in results)
    # The design bound is 1 s (0.38 s worst in the hour soak). Ten real-time emulator and
    # sonard pairs share the suite's 2 cores with other tests (and two busy loops under
    # --under-load): a starved writer thread flushes late by the scheduler's delay, so 1 s
    # more is allowed here.
    assert worst <= 2.0, results
    assert sum(r[4] for r in results) == 0, results


# ---------------------------------------------------------------------------- SIGTERM
def test_sigterm_stops_robot_and_exits_zero(tmp_path: Path) -> None:
    plan = write_plan(
        tmp_path,
        "term",
        [{"translate": {"distance": 2.0, "speed": 0.3, "mode": "continuous"}}],
    )
    out = tmp_path / "run.h5"
    with emulator(tmp_path, fast=False) as (pty, trace_path):
        proc = start_sonard(pty, plan, out)
        # wait until the robot drives: sonard's handlers are installed long before its
        # plan sends PR. Start-up (imports, opening the robot) takes a second alone and
        # many on a loaded machine; a SIGTERM before the handlers would test nothing.
        deadline = time.monotonic() + 120
        driving = False
        while not driving and time.monotonic() < deadline and proc.poll() is None:
            driving = trace_path.exists() and '"cmd": "PR"' in trace_path.read_text()
            time.sleep(0.05)
        assert driving, "the robot never drove: " + finish(proc, 10)[1]
        time.sleep(0.5)
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        rc, err = finish(proc, 10)
        took = time.monotonic() - t0
        time.sleep(0.6)  # let the emulator log firings of the stopped robot
    assert rc == 0, err
    # sonard stops within 2 s on a machine with a core to spare (ST, drain, close: tens of
    # ms); beside two busy loops on 2 cores its threads wait for the CPU, so 5 s here
    assert took < 5.0
    trace = load_trace(trace_path)
    cmds = commands(trace)
    assert cmds[-1]["cmd"] == "ST"
    t_st = cmds[-1]["t"]
    after = [r["world"] for r in trace if r["type"] == "firing" and r["t"] > t_st + 0.3]
    assert len(after) >= 2
    assert after[0] == after[-1]  # not moving any more
    log = read_log(out)
    assert len(log.readings) > 0
    assert log.events[-1]["kind"] == b"stop"
    assert b"robot stopped" in log.events[-1]["detail"]
    assert_poses_match_truth(log, trace)


# ----------------------------------------------------------------------------- faults
def test_garbage_and_unplug(tmp_path: Path) -> None:
    plan = write_plan(
        tmp_path,
        "faults",
        [
            {"dwell": {"seconds": 2.5}},
            {"translate": {"distance": 0.2, "step": 0.05, "speed": 0.2}},
            {"dwell": {"seconds": 1.0}},
        ],
        fault_timeout_s=10,
        # with 1 % of the reply bytes garbled a 206-byte reply with attachments survives
        # only 13 % of the time; the 26-byte plain reply 77 %: poses are interpolated
        pose_attachments=False,
    )
    out = tmp_path / "run.h5"
    link = tmp_path / "robot-tty"
    extra = ("--link", str(link), "--garble", "0.01", "--unplug-at", "3.0", "--unplug-for", "1.5")
    with emulator(tmp_path, *extra, fast=False) as (_pty, trace_path):
        rc, err = finish(start_sonard(str(link), plan, out), 60)
        time.sleep(0.1)
    assert rc == 0, err
    log = read_log(out)
    kinds = [e["kind"].decode() for e in log.events]
    assert "fault" in kinds and "reconnect" in kinds, kinds
    t_fault = next(float(e["t"]) for e in log.events if e["kind"] == b"fault")
    t_back = max(float(e["t"]) for e in log.events if e["kind"] == b"reconnect")
    r = log.readings
    assert (r["t"] < t_fault).sum() > 10 and (r["t"] > t_back).sum() > 10
    trace = load_trace(trace_path)
    # Without attachments a reading's time is inferred from its poll, and the match above
    # accepts a firing within 0.25 s of it: at 0.2 m/s that is 5 cm (typically 1.5 cm is
    # seen; a loaded machine delays the polls, and 3 cm has been seen).
    assert_poses_match_truth(log, trace, moving_tol=0.2 * 0.25)
    assert np.isclose(r["x"].max(), -0.55, atol=0.003)  # the translation finished
    assert commands(trace)[-1]["cmd"] == "ST"


# ------------------------------------------------------------------------------- CLI
def test_cli_errors(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("sonars: [0]\ninterval: 0.012\nmax_range: 10\nsteps: [zero]\n")
    res = subprocess.run(
        [*SONARD, "--port", "/dev/null", "--plan", str(bad), "--out", str(tmp_path / "x.h5")],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.yaml" in lines[0] and "interval" in lines[0]
    assert "minimum 0.060 s" in lines[0]
    res = subprocess.run(
        [
            *SONARD,
            "--port",
            str(tmp_path / "no-such-tty"),
            "--plan",
            str(PLANS / "translate.yaml"),
            "--out",
            str(tmp_path / "y.h5"),
        ],
        capture_output=True,
        text=True,
        timeout=30,
        check=False,
    )
    assert res.returncode == 1
    assert "Traceback" not in res.stderr
    assert "no-such-tty" in res.stderr.strip().splitlines()[-1]

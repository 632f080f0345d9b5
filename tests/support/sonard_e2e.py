"""Helpers for the end-to-end sonard tests: a real emulator on a pty, sonard as a subprocess.

The emulator's ``--trace`` holds every command it received and, for every sonar firing,
the robot clock and the TRUE pose; the log's ``clock`` event gives the UNIX time of robot
clock 0, so each logged reading is matched to its firing exactly (sonar id + firing time).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from procs import stop_process

from sonarlog import FLAG_NO_ECHO, SonarLog

ROOT = Path(__file__).resolve().parents[2]
WORLD = ROOT / "configs" / "worlds" / "lab.yaml"
PLANS = ROOT / "configs" / "plans"
EMULATOR = [
    sys.executable,
    "-c",
    "import sys; from nomad200.emulator_cli import main; sys.exit(main())",
]
SONARD = [sys.executable, "-m", "sonard"]
IN10 = 0.00254  # protocol resolution: 0.1 in ...
DEG10 = math.pi / 1800  # ... and 0.1 degree
C = 343.3


@contextmanager
def emulator_process(
    tmp: Path, *extra: str, fast: bool = True, baud: int = 38400
) -> Iterator[tuple[subprocess.Popen[str], str, Path]]:
    """Run nomad-emulator; yield (process, pty path, trace path); always terminate it."""
    trace = tmp / "trace.jsonl"
    cmd = [*EMULATOR, "--world", str(WORLD), "--baud", str(baud), "--trace", str(trace), *extra]
    if fast:
        cmd.append("--fast")
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, cwd=tmp
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline().strip()
        assert line.startswith("/dev/"), f"emulator printed {line!r}"
        yield proc, line, trace
    finally:
        stop_process(proc)


@contextmanager
def emulator(
    tmp: Path, *extra: str, fast: bool = True, baud: int = 38400
) -> Iterator[tuple[str, Path]]:
    """Run nomad-emulator; yield (pty path, trace path); always terminate it."""
    with emulator_process(tmp, *extra, fast=fast, baud=baud) as (_, pty, trace):
        yield pty, trace


def start_sonard(port: str, plan: Path, out: Path, *extra: str) -> subprocess.Popen[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("NOTIFY_SOCKET", "JOURNAL_STREAM")}
    return subprocess.Popen(
        [*SONARD, "--port", port, "--plan", str(plan), "--out", str(out), *extra],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def finish(proc: subprocess.Popen[str], timeout: float) -> tuple[int, str]:
    try:
        _, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        pytest.fail(f"sonard did not finish in {timeout} s:\n{err}")
    return proc.returncode, err


def load_trace(path: Path) -> list[dict[str, Any]]:
    recs = []
    for line in path.read_text().splitlines():
        with contextlib.suppress(json.JSONDecodeError):  # a line cut by a kill
            recs.append(json.loads(line))
    return recs


def clock_offset(log: SonarLog) -> float:
    for e in log.events:
        if e["kind"] == b"clock":
            return float(e["detail"].split()[-1])
    raise AssertionError("no clock event")


def frame_time(trace: list[dict[str, Any]]) -> float:
    """Robot time of the last frame definition (DP/DA/ZR) received."""
    return max(r["t"] for r in trace if r["type"] == "command" and r["cmd"] in ("DP", "DA", "ZR"))


def match_firings(
    log: SonarLog, trace: list[dict[str, Any]], *, approx: bool = False
) -> list[dict[str, Any]]:
    """The trace firing of every logged reading (fails on a reading with no firing).

    Exact: same sonar, same robot-clock millisecond (pose attachments). ``approx``
    (interpolated times): the nearest firing of the same sonar within 0.25 s that measured
    the logged range.
    """
    off = clock_offset(log)
    fires = {(round(r["t"] * 1000), r["sonar"]): r for r in trace if r["type"] == "firing"}
    by_sonar: dict[int, list[dict[str, Any]]] = {}
    for r in trace:
        if r["type"] == "firing":
            by_sonar.setdefault(r["sonar"], []).append(r)
    out = []
    for row in log.readings:
        t = float(row["t"]) - off
        key = (round(t * 1000), int(row["tx"]))
        if key in fires:
            out.append(fires[key])
            continue
        assert approx, f"reading {row} has no firing in the trace"
        raw = 255 if np.isnan(row["tof"]) else round(float(row["tof"]) * C / 2 / 0.0254)
        cands = [
            f
            for f in by_sonar.get(int(row["tx"]), [])
            if abs(f["t"] - t) <= 0.25 and f["raw"] == raw
        ]
        assert cands, f"reading {row} matches no firing within 0.25 s"
        out.append(min(cands, key=lambda f: abs(f["t"] - t)))
    return out


def _ang(a: np.ndarray) -> np.ndarray:
    return np.abs((a + np.pi) % (2 * np.pi) - np.pi)


def assert_poses_match_truth(
    log: SonarLog, trace: list[dict[str, Any]], *, moving_tol: float | None = None
) -> None:
    """Every reading's pose equals the TRUE pose of its firing within the protocol resolution.

    With ``moving_tol`` (runs without pose attachments, whose poses are interpolated),
    readings fired while the robot moved need only be within ``moving_tol`` metres.
    """
    fires = match_firings(log, trace, approx=moving_tol is not None)
    r = log.readings
    w = np.array([[f["world"][k] for k in ("x", "y", "theta", "turret")] for f in fires])
    strict = np.ones(len(r), dtype=bool)
    if moving_tol is not None:
        seq = [f for f in trace if f["type"] == "firing"]
        idx = {id(f): i for i, f in enumerate(seq)}
        for k, f in enumerate(fires):
            i = idx[id(f)]
            near = seq[max(0, i - 5) : i + 6]
            strict[k] = all(g["world"] == f["world"] for g in near)
        assert np.hypot(r["x"] - w[:, 0], r["y"] - w[:, 1]).max() <= moving_tol
        assert strict.sum() > 0.25 * len(r)
    assert np.abs(r["x"] - w[:, 0])[strict].max() <= IN10 + 1e-9
    assert np.abs(r["y"] - w[:, 1])[strict].max() <= IN10 + 1e-9
    assert _ang(r["theta"] - w[:, 2])[strict].max() <= DEG10 + 1e-9
    assert _ang(r["turret"] - w[:, 3])[strict].max() <= DEG10 + 1e-9
    # ranges: 255 -> flagged no echo; otherwise tof = 2 * inches * 0.0254 / c
    raw = np.array([f["raw"] for f in fires])
    no_echo = raw == 255
    np.testing.assert_array_equal((r["flags"] & FLAG_NO_ECHO) > 0, no_echo | (raw * 0.0254 < 0.15))
    np.testing.assert_allclose(r["tof"][~no_echo], 2 * raw[~no_echo] * 0.0254 / C, rtol=1e-9)
    assert np.isnan(r["tof"][no_echo]).all()
    assert (r["tx"] == r["rx"]).all() and (r["echo"] == 0).all()


def commands(trace: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [r for r in trace if r["type"] == "command"]


def write_plan(tmp: Path, name: str, steps: list[Any], **over: Any) -> Path:
    plan: dict[str, Any] = {
        "name": name,
        "sonars": [0, 2, 14, 1, 15],
        "baud": 38400,
        "steps": [{"define_pose": {"x": -0.75, "y": 0.0, "theta": 0, "turret": 90}}, *steps],
    }
    plan.update(over)
    path = tmp / f"{name}.yaml"
    path.write_text(yaml.safe_dump(plan))
    return path

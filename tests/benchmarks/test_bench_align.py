"""Benchmark: odometry drift correction of a 10 000-reading log, against a run's read + map.

Input: a Pioneer-like 16-sonar ring driving three and a bit times round the room-box
scenario (the first 10 000 readings), its poses drifted by 2 % of the distance and 2
degrees per 10 m (seed 0). The floor is measured in the same test: a default
``sonarproc run`` of the drifted log in a subprocess, its ``read``, ``select``, ``grid``,
``rasterise`` and ``morphology`` stages (reading the log and building the arc map: the
least a run does). The alignment is timed in process, best of three.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import pytest
from benchtiming import best_of
from drift import drifted_readings, looped_scenario, pose_error_rms

from sonarproc.align import Alignment, align_poses
from sonarproc.simulate import write_result

READINGS = 10_000
FLOOR_STAGES = ("read", "select", "grid", "rasterise", "morphology")


@pytest.mark.benchmark
def test_bench_align_10k(tmp_path: Path) -> None:
    res = looped_scenario("room-box", 4)
    truth = res.readings[:READINGS]
    drifted = drifted_readings(truth, seed=0)
    log = tmp_path / "drifted.h5"
    write_result(dataclasses.replace(res, readings=drifted), log, robot="sonarsim:room-box")
    exe = Path(sys.executable).parent / "sonarproc"
    proc = subprocess.run([str(exe), "run", str(log), "--out", str(tmp_path / "r"), "--json"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    timings = json.loads(proc.stdout)["timings_s"]
    floor = sum(float(timings[k]) for k in FLOOR_STAGES)
    whole = sum(float(v) for v in timings.values())
    result: list[object] = []

    def align() -> None:
        result[:] = [align_poses(drifted, res.sensors, speed_of_sound=res.speed_of_sound)]

    wall = best_of(align, repeat=3)
    a = result[0]
    assert isinstance(a, Alignment)
    removed = 1.0 - pose_error_rms(truth, a.x, a.y) / pose_error_rms(
        truth, drifted["x"], drifted["y"]
    )
    print(
        f"\nalign {READINGS} readings: {wall:.2f} s ({a.rounds} rounds, {a.evaluations} "
        f"evaluations, {a.matches} matches, {a.node_offsets.shape[0]} nodes); "
        f"removed {removed:.0%} of the pose error"
    )
    print(
        f"  floor (read + select + grid + rasterise + morphology of a default run): "
        f"{floor:.2f} s; align / floor = {wall / floor:.2f}; the whole run's stages "
        f"{whole:.2f} s: align / run = {wall / whole:.2f}"
    )
    assert removed >= 0.8

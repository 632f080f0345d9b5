"""Benchmark: the shipped real log (RoboND, 3304 readings) through ``sonarproc run``.

The target: a real log runs, with default options, in at most 5 s per 10 000 readings
(1.65 s for this one). Each run is a fresh ``python`` subprocess timed from the outside
(interpreter start and imports included): the default run (default figures), the
run with ``--figures none``, and the floor, a subprocess that imports sonarproc and
reads the same CSV log and sensors file (the least any run must do). They take turns,
best of three each, so all see the same machine load; the run is printed per 10 000
readings and as a ratio to the floor.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from benchroom import PEAK, RUN, run_child

ROBOND = Path(__file__).resolve().parents[1] / "data" / "real" / "robond"
TARGET_S_PER_10K = 5.0
READINGS = 3304

# start, import sonarproc, read the log: what every run does before its first stage
FLOOR = (
    PEAK
    + """
import sys
from sonarproc.pipeline.run import load_log
lg = load_log(sys.argv[1], sensors=sys.argv[2])
print(lg.readings.size)
"""
)


@pytest.mark.benchmark
def test_bench_real_log(tmp_path: Path) -> None:
    csv, sensors = ROBOND / "readings.csv", ROBOND / "sensors.yaml"
    best = {"default": np.inf, "none": np.inf, "floor": np.inf}
    stages: dict[str, float] = {}
    for _ in range(3):
        for figures in ("default", "none"):
            out = tmp_path / figures
            out.mkdir(exist_ok=True)
            args = ["-c", RUN, "run", str(csv), "--sensors", str(sensors), "--out", str(out),
                    "--json"]  # fmt: skip
            if figures != "default":
                args += ["--figures", figures]
            wall, _, stdout, _ = run_child(args, out)
            doc = json.loads(stdout)
            assert doc["counts"]["readings_total"] == READINGS
            if wall < best[figures] and figures == "default":
                stages = doc["timings_s"]
            best[figures] = min(best[figures], wall)
        fwall, _, fout, _ = run_child(["-c", FLOOR, str(csv), str(sensors)], tmp_path)
        assert int(fout.split()[-1]) == READINGS
        best["floor"] = min(best["floor"], fwall)
    run, none, floor = best["default"], best["none"], best["floor"]
    per10k = run * 10_000 / READINGS
    print(f"\nreal log (RoboND, {READINGS} readings), best of 3 in turns:")
    print(
        f"  default run {run:.2f} s wall = {per10k:.2f} s per 10 000 readings "
        f"(target {TARGET_S_PER_10K:.1f}: ratio {per10k / TARGET_S_PER_10K:.2f}); "
        f"--figures none {none:.2f} s"
    )
    print(
        f"  floor (start, import, read the CSV log) {floor:.2f} s; run / floor = "
        f"{run / floor:.2f}, --figures none / floor = {none / floor:.2f}"
    )
    print("  stages (s): " + ", ".join(f"{k} {v:.3f}" for k, v in stages.items()))

"""Benchmark: the drift correction declining a log, against the search its decision needs.

Input: the shipped corridor-tee scenario (seed of its file), driven once. Its stretches
of track see few walls another stretch saw: the first round's wide match radius finds
enough chance matches to solve the pose graph, and after two solves the shrinking
radius leaves too few, so the alignment declines (as on the shipped RoboND log, after
one solve), and declines again on 2 m and 3 m nodes. The floor is the least a decision
from the match count costs: the echo points of every reading at the raw poses, a k-d
tree of them and the nearest-neighbour search of the first round's queries (same number
of neighbours, same radius). Both are timed in process, in turns, best of five: the
ratio is what the decline adds to that search (the line tests of the matches, the
solves, the later rounds' searches).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from benchtiming import best_of_interleaved
from scipy.spatial import cKDTree

from sonarproc.align import Alignment, align_poses
from sonarproc.align.echoes import echo_rays
from sonarproc.align.matching import NEIGHBOURS

SCENARIO = Path(__file__).resolve().parents[2] / "configs" / "scenarios" / "corridor-tee.yaml"
#: align_poses' defaults: first match radius (m) and queries per correction node
FIRST_RADIUS_M = 0.5
QUERIES_PER_NODE = 60


@pytest.mark.benchmark
def test_bench_align_decline() -> None:
    from sonarsim import load_scenario, simulate

    res = simulate(load_scenario(SCENARIO))
    readings, sensors, c = res.readings, res.sensors, res.speed_of_sound
    found: list[Alignment] = []

    def align() -> None:
        found[:] = [align_poses(readings, sensors, speed_of_sound=c)]

    def floor() -> None:
        order = np.argsort(readings["t"], kind="stable")
        rays = echo_rays(readings, sensors, order, speed_of_sound=c)
        pose = np.column_stack((readings["x"], readings["y"], readings["theta"]))[order]
        at = pose[rays.reading]
        points = rays.points(at[:, 0], at[:, 1], at[:, 2])
        nodes = max(2, math.ceil(float(np.hypot(*np.diff(pose[:, :2], axis=0).T).sum())))
        wanted = min(QUERIES_PER_NODE * nodes, rays.size)
        queries = np.unique(np.linspace(0, rays.size - 1, wanted).astype(np.intp))
        cKDTree(points).query(points[queries], k=min(NEIGHBOURS, rays.size),
                              distance_upper_bound=FIRST_RADIUS_M)  # fmt: skip

    wall, base = best_of_interleaved([align, floor], repeat=5)
    a = found[0]
    assert a.reason.startswith("too few echoes match")
    assert np.array_equal(a.x, readings["x"])  # poses left as they were
    print(
        f"\nalign declining corridor-tee ({readings.size} readings): {wall * 1e3:.1f} ms; "
        f"floor (echo points, k-d tree, first-round search) {base * 1e3:.1f} ms; "
        f"align / floor = {wall / base:.2f}"
    )

"""Benchmark: every map-building method on the 1-hour, 16-sonar room log.

The log is :mod:`test_bench_run`'s (90 000 readings of a Nomad-like ring wandering in a
20 m x 20 m room, mapped at 1 cm over the room: 2000 x 2000 cells, polar fit), built by
its own ``write_room_log`` (loaded from that file, not copied). The log is read once; each
method then runs in this process, timed by process CPU (``t_cpu_s``, the metric the
comparison reports) and wall clock, best of two. The baseline is the paper's
``morphological`` method measured in the same run: each figure is printed with its ratio
to it. No timed asserts.

The log's ranges are taken along each beam's axis, not to the nearest wall point in the
beam as a real sonar measures; for oblique beams the occupancy grid's free cone then
crosses the wall, so its accuracy figures here say nothing (only its time does).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from benchroom import ROOM, write_room_log


@pytest.mark.benchmark
def test_bench_methods(tmp_path: Path) -> None:
    from sonarproc.methods import DEFAULT_METHODS, make_method
    from sonarproc.params import RunParams
    from sonarproc.pipeline import load_log

    path = tmp_path / "room.h5"
    n = write_room_log(path, hours=1.0)
    room = ROOM
    lg = load_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, room, 0.0, room), fit="polar")
    rows = []
    for name in DEFAULT_METHODS:
        method = make_method(name)
        best_cpu = best_wall = float("inf")
        result = None
        for _ in range(2):
            t0 = time.perf_counter()
            result = method.run(lg, params)
            best_wall = min(best_wall, time.perf_counter() - t0)
            best_cpu = min(best_cpu, result.run.t_cpu_s)
        assert result is not None
        m = result.run.metrics
        rows.append((name, best_cpu, best_wall, m.f_c, m.E1_m, result.run.points_x.size))
    base_cpu, base_wall = rows[0][1], rows[0][2]
    print(f"\nmethods on the room log: {n} readings, {result.run.grid.nx} x "
          f"{result.run.grid.ny} cells, polar fit (baseline: morphological, same run)")  # fmt: skip
    print(f"{'method':<14} {'t_cpu s':>8} {'wall s':>7} {'cpu/morph':>9} {'wall/morph':>10} "
          f"{'f_c':>6} {'E1 cm':>7} {'points':>8}")  # fmt: skip
    for name, cpu, wall, fc, e1, pts in rows:
        e1s = "—" if e1 is None else f"{100 * e1:.2f}"
        print(f"{name:<14} {cpu:8.3f} {wall:7.3f} {cpu / base_cpu:9.2f} {wall / base_wall:10.2f} "
              f"{fc:6.3f} {e1s:>7} {pts:8d}")  # fmt: skip

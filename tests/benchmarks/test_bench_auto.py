"""Benchmark: ``sonarproc run --auto`` on the 90 000-reading room log (target: under 5 s).

The log is the one of ``test_bench_run.py`` (a 16-sonar ring wandering for an hour in a
20 m x 20 m room, mapped at 1 cm: 2001 x 2001 cells). ``--auto`` scores its candidates
on a subset of whole firings (:func:`sonarproc.auto.choose`) and then runs the winner on
every reading; the figure is printed as a ratio to one plain ``sonarproc run`` of the
same log measured in the same process (best of two each: the machine is shared), in wall
time and in CPU time (every thread's; on a machine shared by other jobs the wall time
measures them too). The
process keeps freed memory for reuse, as the ``sonarproc`` command does
(:func:`sonarproc.runtime.retain_freed_memory`).
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from benchroom import ROOM, write_room_log

TARGET_S = 5.0


@pytest.mark.benchmark
def test_bench_auto_on_the_room_log(tmp_path: Path) -> None:
    from sonarproc.auto import run_auto
    from sonarproc.params import RunParams
    from sonarproc.pipeline import load_log, process
    from sonarproc.runtime import retain_freed_memory

    retained = retain_freed_memory()
    room = ROOM
    path = tmp_path / "hour.h5"
    n = write_room_log(path, 1.0)
    lg = load_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, room, 0.0, room))

    def best(fn) -> tuple[float, float]:  # type: ignore[no-untyped-def]
        wall, cpu = [], []
        for _ in range(2):
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        return min(wall), min(cpu)

    single, single_cpu = best(lambda: process(lg, params))
    auto, auto_cpu = best(lambda: run_auto(lg, params))
    _, chosen, choice = run_auto(lg, params)
    print(f"\n--auto on {n} readings ({choice.readings_scored} scored, {choice.folds} folds)")
    print(f"  freed memory kept for reuse, as the command does: {retained}")
    print(f"  single run {single:.2f} s; --auto {auto:.2f} s; ratio {auto / single:.2f}")
    print(
        f"  CPU: single run {single_cpu:.2f} s; --auto {auto_cpu:.2f} s; "
        f"ratio {auto_cpu / single_cpu:.2f}"
    )
    print(f"  --auto / target {TARGET_S:.0f} s = {auto / TARGET_S:.2f}")
    print(f"  chose {chosen.candidate.name} (held-out residual {100 * chosen.residual_m:.2f} cm)")
    for s in choice.ranked:
        if s.excluded and s.candidate.family == "surfaces":
            print(f"  {s.candidate.name}: {s.excluded}")
    assert chosen.candidate.name and choice.repeats == 1

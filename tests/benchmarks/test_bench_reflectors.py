"""Benchmark: what reflector classes and the free-space cut add to the 90 000-reading room run.

The log is the one of :mod:`test_bench_run`: an hour of a 16-sonar ring wandering in a
20 m x 20 m room, mapped at 1 cm. ``sonarproc.pipeline.process`` with the default fit
(``auto``: surfaces) runs with every stage, and without both the point reflectors and
free space (:mod:`benchstages`: no point search, no corner fitted as a plane, no corner
on the walls' lines or where two walls meet; no silent readings, no cut at openings, no
join of pieces, no cut of unseen stretches, the merge's fixed gap), and without each of
the two alone (their shares), the runs interleaved, five rounds, in CPU seconds of this
process (the machine may be shared). The figure is (with - without) / without, the
stages' added cost, for the best and the median of the five: the target is at most 25 %.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, ExitStack
from pathlib import Path

import pytest
from benchroom import ROOM, write_room_log
from benchstages import without_free_space, without_point_reflectors

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process

TARGET = 0.25
ROUNDS = 5

#: The runs compared: the stages each leaves out.
RUNS: dict[str, tuple[Callable[[], AbstractContextManager[None]], ...]] = {
    "with": (),
    "without": (without_point_reflectors, without_free_space),
    "no points": (without_point_reflectors,),
    "no free space": (without_free_space,),
}


@pytest.mark.benchmark
def test_bench_reflectors(tmp_path: Path) -> None:
    path = tmp_path / "hour.h5"
    n = write_room_log(path, 1.0, truth=False)
    lg = read_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM), fit="auto")
    times: dict[str, list[float]] = {name: [] for name in RUNS}
    points = 0
    for _ in range(ROUNDS):
        for name, leave_out in RUNS.items():
            with ExitStack() as stack:
                for stage in leave_out:
                    stack.enter_context(stage())
                t0 = time.process_time()
                res = process(lg, params)
                times[name].append(time.process_time() - t0)
            if name == "with" and res.surfaces is not None:
                points = sum(s.model in ("corner", "edge") for s in res.surfaces.surfaces)
    best = {name: min(t) for name, t in times.items()}
    median = {name: statistics.median(t) for name, t in times.items()}

    def added(run: dict[str, float], base: str) -> float:
        return (run["with"] - run[base]) / run[base]

    print(
        f"\nreflector classes + free space on {n} readings (process, fit auto, CPU, "
        f"{ROUNDS} rounds): with {best['with']:.3f} s, without {best['without']:.3f} s "
        f"(best); they add {added(best, 'without'):.2f} of the run (best), "
        f"{added(median, 'without'):.2f} (median); target <= {TARGET:.2f}; "
        f"{points} points reported"
        f"\n  the point reflectors alone add {added(best, 'no points'):.2f}, free space "
        f"alone {added(best, 'no free space'):.2f} (best)"
    )

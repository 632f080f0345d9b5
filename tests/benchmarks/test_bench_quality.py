"""Benchmark: what the truth-free quality figures and the drift correction add to a run.

The log is the one of :mod:`test_bench_run` (an hour of a 16-sonar ring in a 20 m x 20 m
room, 90 000 readings, no truth), mapped at 1 cm with the defaults of ``sonarproc run``
(``fit = "auto"``). Three in-process runs, interleaved, best of three each:
:func:`sonarproc.pipeline.process` as a user runs it (drift correction tried, quality
measured), the same without quality, and the bare map (``--no-align``, no quality). The
ratios to the bare map are the costs; the quality's is one refit of the map without a
tenth of the firings plus the first-echo predictions of 1500 readings, so its stage is
also printed over the fit stage's (about 1 at best).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import pytest
from benchroom import ROOM, write_room_log

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.pipeline.arcmap import build_arc_map
from sonarproc.pipeline.mapping import map_log


@pytest.mark.benchmark
def test_bench_quality_and_alignment_cost(tmp_path: Path) -> None:
    path = tmp_path / "hour.h5"
    write_room_log(path, 1.0, truth=False)
    lg = read_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM), fit="auto")
    bare = replace(params, align=False)

    def default() -> object:
        return process(lg, params)

    def no_quality() -> object:
        from sonarproc.pipeline.alignment import align_log

        aligned, _ = align_log(lg)
        return map_log(aligned, bare, build_arc_map)[0]

    def bare_map() -> object:
        return map_log(lg, bare, build_arc_map)[0]

    runs = {"default": default, "no quality": no_quality, "bare": bare_map}
    best = dict.fromkeys(runs, float("inf"))
    res = None
    for _ in range(3):
        for name, fn in runs.items():
            t0 = time.perf_counter()
            out = fn()
            best[name] = min(best[name], time.perf_counter() - t0)
            if name == "default":
                res = out
    assert res is not None
    q = res.quality  # type: ignore[attr-defined]
    stages = res.timings_s  # type: ignore[attr-defined]
    base = best["bare"]
    print(
        f"\n90 000 readings, fit auto: bare map {base:.2f} s; with drift correction "
        f"{best['no quality']:.2f} s (x{best['no quality'] / base:.2f}); default, with "
        f"quality too, {best['default']:.2f} s (x{best['default'] / base:.2f})"
        f"\n  stages of the default run (s): "
        + ", ".join(f"{k} {v:.3f}" for k, v in stages.items())
        + f"\n  quality: explained {q.explained_fraction:.3f}, held-out median "
        f"{q.heldout_median_m}, p90 {q.heldout_p90_m}; its stage over the fit's "
        f"x{stages['quality'] / stages['fit']:.2f} (its refit is one fit of nine tenths of "
        f"the readings; the rest, the held-out count map and the predictions)"
    )

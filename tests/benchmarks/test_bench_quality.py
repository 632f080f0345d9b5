"""Benchmark: what the truth-free quality figures and the drift correction add to a run.

The log is the one of :mod:`test_bench_run` (an hour of a 16-sonar ring in a 20 m x 20 m
room, 90 000 readings, no truth), mapped at 1 cm with the defaults of ``sonarproc run``
(``fit = "auto"``). Three in-process runs, interleaved, best of three each:
:func:`sonarproc.pipeline.process` as a user runs it (drift correction tried, quality
measured), the same without quality, and the bare map (``--no-align``, no quality). The
ratios to the bare map are the costs; the quality's is one refit of the map without a
tenth of the firings plus the first-echo predictions of 1500 readings, so its stage is
also printed over the fit stage's (about 1 at best). That refit runs in a child forked as
the map is built, while the run fits (:mod:`sonarproc.quality.ahead`, where a fork is
safe): a fourth run computes it in this process instead, and the ratio of the two
quality stages is what the child saves a run (floor: the in-process refit).
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
def test_bench_quality_and_alignment_cost(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from sonarproc.quality import ahead

    path = tmp_path / "hour.h5"
    write_room_log(path, 1.0, truth=False)
    lg = read_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM), fit="auto")
    bare = replace(params, align=False)

    def default() -> object:
        return process(lg, params)

    def quality_here() -> object:
        with monkeypatch.context() as m:
            m.setattr(ahead, "fork_is_safe", lambda: False)
            return process(lg, params)

    def no_quality() -> object:
        from sonarproc.pipeline.alignment import align_log

        aligned, _ = align_log(lg)
        return map_log(aligned, bare, build_arc_map)[0]

    def bare_map() -> object:
        return map_log(lg, bare, build_arc_map)[0]

    runs = {"default": default, "quality here": quality_here, "no quality": no_quality,
            "bare": bare_map}  # fmt: skip
    best = dict.fromkeys(runs, float("inf"))
    res = here = None
    stage_best = {"default": float("inf"), "quality here": float("inf")}
    for _ in range(3):
        for name, fn in runs.items():
            t0 = time.perf_counter()
            out = fn()
            best[name] = min(best[name], time.perf_counter() - t0)
            if name in stage_best:
                stage_best[name] = min(stage_best[name], out.timings_s["quality"])  # type: ignore[attr-defined]
            if name == "default":
                res = out
            elif name == "quality here":
                here = out
    assert res is not None and here is not None
    assert res.quality.to_json() == here.quality.to_json()  # type: ignore[attr-defined]
    q = res.quality  # type: ignore[attr-defined]
    stage_ratio = stage_best["default"] / stage_best["quality here"]
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
        f"\n  held-out refit in a child: quality stage {stage_best['default']:.3f} s, run "
        f"{best['default']:.2f} s; in this process {stage_best['quality here']:.3f} s, run "
        f"{best['quality here']:.2f} s (stage x{stage_ratio:.2f}, "
        f"run x{best['default'] / best['quality here']:.2f})"
    )

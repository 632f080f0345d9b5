"""Benchmark: what free space (cutting walls at openings, joining pieces) adds to a run.

The log is the one of :mod:`test_bench_run`: an hour of a 16-sonar ring wandering in a
20 m x 20 m room, 90 000 readings. ``sonarproc.pipeline.process`` with the default
options (``fit = "auto"``, no truth, as a robot's log) runs with the free-space stages
(:func:`~sonarproc.surfaces.echoes.openings.cut_openings`,
:func:`~sonarproc.surfaces.echoes.openings.join_pieces`,
:func:`~sonarproc.surfaces.echoes.unseen.cut_unseen` and the gap test of
:func:`~sonarproc.surfaces.fitting.merge.merge_collinear`) and without them (the same
functions replaced by ones that pass their input through, and no silent readings
selected), runs interleaved, best of five each, in CPU seconds of this process (the
machine may be shared). The figure is the CPU time spent inside those functions (and in
finding the silent readings and the viewpoints), best of five runs, over the run without
them; the difference of the two whole runs is printed too (noisier). The target for
reflector classification and the free-space stages together is 0.25; the free-space
stages' share is printed here.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from benchroom import ROOM, write_room_log
from benchstages import without_free_space

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process, selection
from sonarproc.surfaces import freespace
from sonarproc.surfaces.echoes import refine
from sonarproc.surfaces.fitting import merge as merge_module

TARGET = 0.25


#: The free-space functions a run calls (module, name), timed where they are looked up.
_STAGES = (
    (selection, "_silent"),
    (refine, "cut_openings"),
    (refine, "join_pieces"),
    (refine, "cut_unseen"),
    (refine, "viewpoint_ids"),
    (freespace, "viewpoint_ids"),
    (merge_module, "_closed"),
)


@contextmanager
def _timed_stages(spent: list[float]) -> Iterator[None]:
    """Add the CPU seconds spent in the free-space functions to ``spent[0]``."""
    saved = [getattr(m, name) for m, name in _STAGES]

    def timed(fn: Any) -> Any:
        def run(*args: Any, **kwargs: Any) -> Any:
            t0 = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent[0] += time.process_time() - t0

        return run

    for (m, name), fn in zip(_STAGES, saved, strict=True):
        setattr(m, name, timed(fn))
    try:
        yield
    finally:
        for (m, name), fn in zip(_STAGES, saved, strict=True):
            setattr(m, name, fn)


@pytest.mark.benchmark
def test_bench_free_space_stages(tmp_path: Path) -> None:
    path = tmp_path / "hour.h5"
    n = write_room_log(path, 1.0, truth=False)
    lg = read_log(path)
    params = replace(RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM)), fit="auto")
    best = {"with": float("inf"), "without": float("inf")}
    surfaces = {}
    for _ in range(5):
        for key in ("without", "with"):
            if key == "without":
                with without_free_space():
                    t0 = time.process_time()
                    res = process(lg, params)
                    t = time.process_time() - t0
            else:
                t0 = time.process_time()
                res = process(lg, params)
                t = time.process_time() - t0
            best[key] = min(best[key], t)
            assert res.surfaces is not None
            surfaces[key] = len(res.surfaces.surfaces)
    stage = float("inf")
    for _ in range(5):
        spent = [0.0]
        with _timed_stages(spent):
            process(lg, params)
        stage = min(stage, spent[0])
    print(
        f"\nfree-space functions on {n} readings: {stage:.3f} CPU s, "
        f"{stage / best['without']:.3f} of the run without them (best of five; target for "
        f"reflector classes + free space together <= {TARGET:.2f})"
    )
    ratio = (best["with"] - best["without"]) / best["without"]
    print(
        f"\nfree space on {n} readings: process (fit auto) {best['with']:.2f} CPU s with, "
        f"{best['without']:.2f} CPU s without; surfaces {surfaces['with']} with, "
        f"{surfaces['without']} without"
        f"\n  the difference of the two runs: {ratio:.3f} of the run (noisier: two whole "
        f"runs on a shared machine)"
    )

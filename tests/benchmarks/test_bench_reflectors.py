"""Benchmark: what the point reflectors (corners, edges) add to the 90 000-reading room run.

The log is the one of :mod:`test_bench_run`: an hour of a 16-sonar ring wandering in a
20 m x 20 m room, mapped at 1 cm. ``sonarproc.pipeline.process`` with the default fit
(``auto``: surfaces) runs with the point reflectors and without them (their search, the
corners fitted as planes, the corners on the walls' lines and the corners where two
walls meet each replaced by one that finds none), the runs interleaved, best of three CPU
times each.
The ratio (with - without) / without is the stage's added cost; the target, with the
free-space cut of the openings, is at most 25 %.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from benchroom import ROOM, write_room_log

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.pipeline import surfacefit as surfacefit_module
from sonarproc.surfaces.reflectors import points as points_module
from sonarproc.surfaces.reflectors.points import ClaimedPoints

TARGET = 0.25


def _none(echoes, *args, **kwargs) -> ClaimedPoints:  # type: ignore[no-untyped-def]
    return ClaimedPoints([], np.zeros(echoes.size, dtype=bool))


@pytest.mark.benchmark
def test_bench_reflectors(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "hour.h5"
    write_room_log(path, 1.0, truth=False)
    lg = read_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM), fit="auto")
    search = surfacefit_module.claim_points
    stages = {"planes_as_corners": points_module.planes_as_corners,
              "corners_on_wall_lines": points_module.corners_on_wall_lines,
              "corners_where_walls_meet": points_module.corners_where_walls_meet}  # fmt: skip
    nothing = {"planes_as_corners": lambda *a, **k: ([], []),
               "corners_on_wall_lines": lambda *a, **k: [],
               "corners_where_walls_meet": lambda *a, **k: []}  # fmt: skip
    best = {"with": float("inf"), "without": float("inf")}
    points = 0
    for _ in range(3):
        for name, fn in (("without", _none), ("with", search)):
            monkeypatch.setattr(surfacefit_module, "claim_points", fn)
            for stage, real in stages.items():
                monkeypatch.setattr(points_module, stage, real if fn is search else nothing[stage])
            t0 = time.process_time()
            res = process(lg, params)
            best[name] = min(best[name], time.process_time() - t0)
            if name == "with" and res.surfaces is not None:
                points = sum(s.model in ("corner", "edge") for s in res.surfaces.surfaces)
    added = (best["with"] - best["without"]) / best["without"]
    print(
        f"\npoint reflectors on the room run (process, fit auto, CPU): with {best['with']:.2f} s,"
        f" without {best['without']:.2f} s: they add {added:.2f} of the run "
        f"(target with the free-space cut <= {TARGET:.2f}); {points} points reported"
    )

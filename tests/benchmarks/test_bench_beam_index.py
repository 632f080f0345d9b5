"""Benchmark: the retro-reflection test's sensor index against scipy's k-d tree.

:class:`~sonarproc.surfaces.reflectors.point_echoes.BeamIndex` sorts the readings'
sensors by cells of half a metre, row by row, and reads the square round a point as one
slice per row of cells. The library's way is ``scipy.spatial.cKDTree.query_ball_point``
on the sensor positions. The workload is the real one: the index and the queries
(a point, a reach) that the run on the 90 000-reading room log of :mod:`test_bench_run`
makes (``sonarproc.pipeline.process``, fit ``auto``), recorded from that run. Both keep
the sensors within the reach whose beams may hold the point near their axis (the same
readings, checked), the tree's build and every query timed together, in turns, best of
seven, in CPU seconds of this process. The ratio, the tree's time over ours, is what
keeps our index (at least 2: the project keeps a kernel of its own where a library has
one only when it is at least twice as fast on the real workload).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from benchroom import ROOM, write_room_log
from scipy.spatial import cKDTree

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors import point_echoes
from sonarproc.surfaces.reflectors.point_echoes import AXIS_SHARE, BeamIndex

#: The least ratio (the tree's time over ours) that keeps a kernel of our own.
KEEP_RATIO = 2.0


class TreeIndex:
    """:class:`BeamIndex`'s answer from scipy's k-d tree of the sensor positions."""

    def __init__(self, echoes: EchoGeometry) -> None:
        self.tree = cKDTree(echoes.xy)
        self.xy = echoes.xy
        self.c, self.s = np.cos(echoes.heading), np.sin(echoes.heading)
        aim = np.minimum(AXIS_SHARE * echoes.half_beam + point_echoes._AIM_MARGIN_RAD, np.pi)
        self.cos_aim = np.cos(aim)

    def aiming(self, p: np.ndarray, reach: float) -> tuple[np.ndarray, ...]:
        near = self.tree.query_ball_point(p, reach + point_echoes._REACH_MARGIN_M)
        rows = np.fromiter(near, dtype=np.intp, count=len(near))
        rel = self.xy[rows] - p
        dist = np.hypot(rel[:, 0], rel[:, 1])
        toward = -(rel[:, 0] * self.c[rows] + rel[:, 1] * self.s[rows])
        keep = np.flatnonzero((dist <= reach) & (toward >= dist * self.cos_aim[rows]))
        return rows[keep], rel[keep], dist[keep]


@pytest.mark.benchmark
def test_bench_beam_index(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "hour.h5"
    write_room_log(path, 1.0, truth=False)
    lg = read_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM), fit="auto")
    # the run's own indexes and queries
    made: list[tuple[EchoGeometry, list[tuple[np.ndarray, float]]]] = []
    init, aiming = BeamIndex.__init__, BeamIndex.aiming

    def record_init(self: BeamIndex, echoes: EchoGeometry) -> None:
        init(self, echoes)
        made.append((echoes, []))

    def record_aiming(self: BeamIndex, p: np.ndarray, reach: float) -> Any:
        made[-1][1].append((np.array(p, dtype=np.float64), float(reach)))
        return aiming(self, p, reach)

    monkeypatch.setattr(BeamIndex, "__init__", record_init)
    monkeypatch.setattr(BeamIndex, "aiming", record_aiming)
    process(lg, params)
    monkeypatch.undo()
    queries = sum(len(q) for _, q in made)
    assert queries > 0

    def run(kind: type[BeamIndex] | type[TreeIndex]) -> list[Any]:
        out = []
        for echoes, asked in made:
            index = kind(echoes)
            out += [index.aiming(p, r) for p, r in asked]
        return out

    for ours, tree in zip(run(BeamIndex), run(TreeIndex), strict=True):
        assert np.array_equal(np.sort(ours[0]), np.sort(tree[0]))
    best = {BeamIndex: float("inf"), TreeIndex: float("inf")}
    for _ in range(7):
        for kind in best:
            t0 = time.process_time()
            run(kind)
            best[kind] = min(best[kind], time.process_time() - t0)
    ratio = best[TreeIndex] / best[BeamIndex]
    print(
        f"\nBeamIndex on the room run's {len(made)} index(es), {queries} queries: "
        f"{best[BeamIndex] * 1e3:.1f} ms; cKDTree.query_ball_point {best[TreeIndex] * 1e3:.1f}"
        f" ms: the tree takes {ratio:.2f}x ours (ours is kept at >= {KEEP_RATIO:.0f}x)"
    )

"""Reflector classes checked on analytic scenes (transducer physics, built here).

Each scene has one kind of reflector whose position or radius is known exactly: a
plane seen from a line of poses (a plane, no point), a 90 degree concave corner (a
corner at its vertex), a convex box corner (an edge at it) and a cylinder (a cylinder of
its radius). The Nomad-like ring drives past or round it; ranges carry the transducer
physics' time walk, 5 mm noise and 1-inch steps.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.pipeline.result import RunResult
from sonarproc.simulate import write_result
from sonarproc.surfaces import SurfaceFit
from sonarsim import scenario_from_dict
from sonarsim import simulate as sim

RING = {"type": "circular", "count": 16, "radius": 0.22, "step_deg": 22.5}
POINT_KINDS = ("corner", "edge")


def _run(tmp_path: Path, world: list[dict[str, Any]], waypoints: list[list[float]]) -> RunResult:
    spec = {
        "name": "reflector-class",
        "world": {"surfaces": world},
        "array": RING,
        "path": {"locations": {"waypoints": waypoints, "step": 0.05}},
        "pairs": "own",
        "first_echo_only": True,
        "physics": "transducer",
        "imperfections": {"range_noise_sigma": 0.005, "quantise": True},
        "record_no_echo": True,
        "seed": 41,
    }
    out = tmp_path / "log.h5"
    write_result(sim(scenario_from_dict(spec)), out)
    return process(read_log(out), RunParams(cell=0.01, fit="auto"))


def _of_kind(res: RunResult, *kinds: str) -> list[SurfaceFit]:
    assert res.surfaces is not None
    return [s for s in res.surfaces.surfaces if s.model in kinds]


def _nearest(points: list[SurfaceFit], xy: tuple[float, float]) -> tuple[SurfaceFit, float]:
    d = [math.dist(tuple(p.polyline[0]), xy) for p in points]
    k = int(np.argmin(d))
    return points[k], d[k]


def test_a_plane_seen_from_a_line_of_poses_is_one_plane_and_no_point(tmp_path: Path) -> None:
    # a wall x = 2 (a vertical one: not a function of x, so the surfaces are fitted)
    res = _run(tmp_path, [{"type": "wall", "start": [2.0, -1.0], "end": [2.0, 5.0]}],
               [[0.5, 0.0], [0.5, 4.0]])  # fmt: skip
    assert not _of_kind(res, *POINT_KINDS)
    planes = [s for s in _of_kind(res, "line") if s.length_m > 1.0]
    assert len(planes) == 1
    assert np.abs(planes[0].polyline[:, 0] - 2.0).max() < 0.02


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> RunResult:
    # a 4 m x 3 m room (four right-angled concave corners), the ring driving a loop 1 m
    # off its walls
    walls = [{"type": "room", "x_min": 0.0, "x_max": 4.0, "y_min": 0.0, "y_max": 3.0}]
    loop = [[1.0, 1.0], [3.0, 1.0], [3.0, 2.0], [1.0, 2.0], [1.0, 1.0]]
    return _run(tmp_path_factory.mktemp("room"), walls, loop)


@pytest.mark.parametrize("corner", [(0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0)])
def test_a_concave_right_angle_corner_is_a_corner_at_its_vertex(
    room: RunResult, corner: tuple[float, float]
) -> None:
    found = _of_kind(room, *POINT_KINDS)
    assert found, "no point reflector"
    p, d = _nearest(found, corner)
    assert p.model == "corner" and d <= 0.02, (p.model, d)
    assert p.support >= 8 and p.arcs >= 5 and p.length_m == 0.0


def test_a_corner_s_readings_are_not_fitted_as_a_line(room: RunResult) -> None:
    # no diagonal line through the corners' arcs: every line lies on a wall
    for s in _of_kind(room, "line"):
        x, y = s.polyline[:, 0], s.polyline[:, 1]
        on_x = min(np.abs(x).max(), np.abs(x - 4.0).max()) < 0.05
        on_y = min(np.abs(y).max(), np.abs(y - 3.0).max()) < 0.05
        assert on_x or on_y, s.polyline[[0, -1]]


def test_a_convex_box_corner_is_an_edge(tmp_path: Path) -> None:
    box = [[2.0, 2.0], [3.0, 2.0], [3.0, 2.8], [2.0, 2.8]]
    world = [{"type": "polyline", "points": box, "closed": True}]
    # the ring drives round the box, 0.9 m off its faces
    res = _run(tmp_path, world, [[1.1, 1.1], [3.9, 1.1], [3.9, 3.7], [1.1, 3.7], [1.1, 1.1]])
    found = _of_kind(res, *POINT_KINDS)
    assert found, "no point reflector"
    for vertex in box:
        p, d = _nearest(found, (vertex[0], vertex[1]))
        assert p.model == "edge" and d <= 0.02, (vertex, p.model, d)


@pytest.mark.parametrize("radius", [0.3])
def test_a_cylinder_is_a_cylinder_of_its_radius(tmp_path: Path, radius: float) -> None:
    # in a 6 m square room (so that the map is not one curve y = f(x))
    room = {"type": "room", "x_min": -3.0, "x_max": 3.0, "y_min": -3.0, "y_max": 3.0}
    world = [{"type": "circle", "center": [0.0, 0.0], "radius": radius}, room]
    res = _run(tmp_path, world, [[-1.2, -1.2], [1.2, -1.2], [1.2, 1.2], [-1.2, 1.2], [-1.2, -1.2]])
    assert all(max(abs(v) for v in p.polyline[0]) > 2.5 for p in _of_kind(res, *POINT_KINDS))
    arcs = _of_kind(res, "arc")
    assert arcs, [s.model for s in res.surfaces.surfaces]  # type: ignore[union-attr]
    best = max(arcs, key=lambda s: s.length_m)
    assert abs(float(best.params["radius"]) - radius) <= 0.02, best.params["radius"]
    assert math.dist(tuple(best.params["centre"]), (0.0, 0.0)) <= 0.02

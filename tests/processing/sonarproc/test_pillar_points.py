"""A pillar passed by a line of poses gives no corner or edge (transducer physics, built here).

A small cylinder answers each sensor from the point of it facing the sensor. Passed by a
Pioneer-like ring driving a straight line, its echo points lie on a short arc, and planes
may be fitted through parts of it; a corner searched on such a plane's line, where the
line leaves the pillar's surface, is one cylinder's echo with the plane's readings, not a
corner or an edge. Ranges carry the time walk, 5 mm noise and 1-inch steps; seeded.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.simulate import write_result
from sonarsim import scenario_from_dict
from sonarsim import simulate as sim

RING = {"type": "circular", "count": 16, "radius": 0.22, "step_deg": 22.5}


@pytest.mark.parametrize(("radius", "offset"), [(0.15, 0.8), (0.15, 1.2), (0.2, 0.8), (0.25, 1.8)])
def test_a_pillar_passed_by_a_line_of_poses_is_no_point(
    tmp_path: Path, radius: float, offset: float
) -> None:
    room = {"type": "room", "x_min": -3.0, "x_max": 3.0, "y_min": -1.5, "y_max": 3.5}
    pillar = {"type": "circle", "center": [0.0, offset], "radius": radius}
    spec = {
        "name": "pillar-pass",
        "world": {"surfaces": [pillar, room]},
        "array": RING,
        "path": {"locations": {"waypoints": [[-2.0, 0.0], [2.0, 0.0]], "step": 0.05}},
        "pairs": "own",
        "first_echo_only": True,
        "physics": "transducer",
        "imperfections": {"range_noise_sigma": 0.005, "quantise": True},
        "record_no_echo": True,
        "seed": 41,
    }
    out = tmp_path / "log.h5"
    write_result(sim(scenario_from_dict(spec)), out)
    res = process(read_log(out), RunParams(cell=0.01, fit="auto"))
    assert res.surfaces is not None
    on_pillar = [(s.model, s.polyline[0].tolist()) for s in res.surfaces.surfaces
                 if s.model in ("corner", "edge")
                 and math.dist(tuple(s.polyline[0]), (0.0, offset)) < radius + 0.15]  # fmt: skip
    assert on_pillar == []

"""Multi-wall worlds: routes, occlusion, first echo only, truth with NaN separators."""

from __future__ import annotations

import numpy as np
import pytest

from sonarsim import load_scenario, scenario_from_dict, simulate
from sonarsim.paths import route_poses
from sonarsim.scenario import ScenarioError
from sonarsim.search import echoes
from sonarsim.surfaces import wall
from sonarsim.world import World, load_world


def test_route_poses_face_along_the_route() -> None:
    p = route_poses([(0.0, 0.0), (1.0, 0.0), (1.0, -0.5)], step=0.25)
    assert len(p) == 7
    assert np.allclose(np.rad2deg(p.theta), [0, 0, 0, 0, -90, -90, -90])
    assert np.array_equal(p.theta, p.turret)
    with pytest.raises(ValueError, match="differ"):
        route_poses([(0.0, 0.0), (0.0, 0.0)], step=0.1)


def test_a_route_refuses_explicit_headings() -> None:
    spec = {
        "world": {"surfaces": [{"type": "wall", "start": [0, 1], "end": [1, 1]}]},
        "array": {"type": "circular", "count": 4},
        "path": {"locations": {"waypoints": [[0, 0], [1, 0]], "step": 0.5}, "theta_deg": 10},
    }
    with pytest.raises(ScenarioError, match="route sets the headings"):
        scenario_from_dict(spec)


def test_a_wall_behind_another_is_occluded() -> None:
    w = World([wall((-1.0, 1.0), (1.0, 1.0)), wall((-1.0, 2.0), (1.0, 2.0))])
    up = np.pi / 2
    ev = echoes(w, [[0.0, 0.0]], [up], [[0.0, 0.0]], [up], half_beamwidth=0.3)
    assert ev.path.tolist() == pytest.approx([2.0])  # the far wall is hidden
    short = World([wall((-1.0, 1.0), (-0.5, 1.0)), wall((-1.0, 2.0), (1.0, 2.0))])
    ev2 = echoes(short, [[0.0, 0.0]], [up], [[0.0, 0.0]], [up], half_beamwidth=0.3)
    assert ev2.path.tolist() == pytest.approx([4.0])


def test_multi_surface_truth_is_separated_by_nan_rows() -> None:
    w = load_world("corridor-l")
    t = w.truth_profile(0.01)
    gaps = np.flatnonzero(np.isnan(t).all(axis=1))
    assert gaps.size == len(w.surfaces) - 1
    assert np.isfinite(np.delete(t, gaps, axis=0)).all()


@pytest.mark.parametrize(
    "name",
    ["corridor-l", "room-box", "hall-pillar", "office-door", "corridor-tee", "curved-room",
     "pioneer-hall"],
)  # fmt: skip
def test_shipped_multiwall_scenarios_simulate_first_echoes(name: str) -> None:
    scn = load_scenario(name)
    assert scn.first_echo_only and scn.pairs == "own"
    res = simulate(scn)
    r = res.readings
    assert r.size > 1000
    assert np.all(r["echo"] == 0)  # one echo per firing: the first
    assert np.all(r["tx"] == r["rx"])
    heard = np.isfinite(r["tof"])
    assert 0.1 < heard.mean() < 1.0  # many beams meet walls obliquely: no echo
    assert np.isnan(res.truth).all(axis=1).sum() >= 1

"""The transducer physics, checked against closed-form answers.

Each scene is built so exactly one reflector can answer (a plane's foot of the
perpendicular, a corner's vertex, an edge, a cylinder's facing point); the expected
range is then the geometric distance plus the documented time walk
``c rise_time_s threshold / (2 A)``.
"""

from __future__ import annotations

import hashlib
import math
from typing import Any

import numpy as np
import pytest

from sonarsim import ScenarioError, load_scenario, scenario_from_dict, simulate
from sonarsim.physical_echoes import HeardEchoes, transducer_echoes
from sonarsim.reflectors import world_vertices
from sonarsim.specular import Sensors
from sonarsim.surfaces import Circle, Polyline, wall
from sonarsim.transducer import TransducerParams, directivity, time_walk
from sonarsim.world import World, WorldError, load_world, world_from_dict

C = 343.0
P = TransducerParams()
NO_WALK = TransducerParams(rise_time_s=0.0)


def _hear(
    world: World, xy: tuple[float, float], heading: float, params: TransducerParams = P
) -> HeardEchoes:
    s = Sensors(np.array([xy], dtype=float), np.array([heading]), np.array([0.2]),
                np.array([0.1]), np.array([10.0]))  # fmt: skip
    return transducer_echoes(world, s, np.array([0]), params, C)


def _ranges(world: World, xy: tuple[float, float], heading: float, params: TransducerParams = P):  # type: ignore[no-untyped-def]
    return np.sort(0.5 * _hear(world, xy, heading, params).path)


def _edge_angle(d: float) -> float:
    """Beam edge (rad) of a plane at perpendicular distance ``d`` (Gaussian model)."""
    x = math.sqrt(-4.0 * math.log(P.threshold * d**2 / P.reference_range**2))
    return math.asin(x / P.ka(C))


PLANE = World([wall((-5.0, 2.0), (5.0, 2.0))])


def test_plane_head_on_reads_the_exact_range() -> None:
    assert _ranges(PLANE, (0.0, 0.0), math.pi / 2, NO_WALK).tolist() == pytest.approx(
        [2.0], abs=1e-12
    )
    r = _ranges(PLANE, (0.0, 0.0), math.pi / 2)
    walk = float(time_walk(0.25, P, C))  # A = (1 m / 2 m)^2 on the axis
    assert r.tolist() == pytest.approx([2.0 + walk], abs=1e-12)
    assert walk < 1e-3


def test_beam_edge_reads_long_by_the_time_walk_and_past_it_nothing() -> None:
    d = 1.5
    world = World([wall((-9.0, d), (9.0, d))])
    edge = _edge_angle(d)
    inside = _ranges(world, (0.0, 0.0), math.pi / 2 + edge - 1e-4)
    assert inside.size == 1
    # at the edge A -> threshold, so the bias -> c rise_time / 2 = 1.49 cm
    assert inside[0] - d == pytest.approx(0.5 * C * P.rise_time_s, abs=2e-4)
    assert 0.01 < inside[0] - d < 0.02
    assert _ranges(world, (0.0, 0.0), math.pi / 2 + edge + 1e-3).size == 0


def test_effective_beam_is_nominal_at_1_5_m_wider_close_narrower_far() -> None:
    assert math.degrees(_edge_angle(1.5)) == pytest.approx(12.5, abs=0.3)
    assert math.degrees(_edge_angle(0.5)) > 15.0
    assert math.degrees(_edge_angle(4.0)) < 9.0


def test_piston_main_lobe_ends_at_its_first_null() -> None:
    ka = P.ka(C)
    null = math.asin(3.8317059702075125 / ka)
    assert float(directivity(null - 1e-3, ka, "piston")) > 0.0
    assert float(directivity(null + 1e-3, ka, "piston")) == 0.0
    assert float(directivity(0.1, ka, "gaussian")) == pytest.approx(
        float(directivity(0.1, ka, "piston")), abs=0.02
    )


CORNER = World([Polyline(np.array([[1.5, 3.0], [3.0, 3.0], [3.0, 1.5]]))])


def test_concave_corner_retro_reflects_from_inside_its_opening() -> None:
    # the walls' feet of the perpendicular, (0, 3) and (3, 0), are off the walls: only
    # the corner can answer, at the distance to its vertex
    for xy, head in [((0.0, 0.0), math.pi / 4), ((1.0, 0.2), math.atan2(2.8, 2.0))]:
        r = _ranges(CORNER, xy, head, NO_WALK)
        assert r.tolist() == pytest.approx([math.dist(xy, (3.0, 3.0))], abs=1e-9)


def test_convex_box_corner_is_heard_only_close_by() -> None:
    box = World([Polyline(np.array([[1.0, 1.0], [2.0, 1.0], [2.0, 2.0], [1.0, 2.0]]), True)])
    near = 0.5
    s = 1.0 - near / math.sqrt(2.0)
    r = _ranges(box, (s, s), math.pi / 4, NO_WALK)
    assert r.tolist() == pytest.approx([near], abs=1e-9)
    far = 1.0 - 2.5 / math.sqrt(2.0)
    assert _ranges(box, (far, far), math.pi / 4).size == 0
    # a concave corner's far side is a convex edge: heard close by, not from afar
    r = _ranges(CORNER, (3.5, 3.5), -3 * math.pi / 4, NO_WALK)
    assert r.tolist() == pytest.approx([math.sqrt(0.5)], abs=1e-9)
    assert _ranges(CORNER, (5.0, 5.0), -3 * math.pi / 4).size == 0


@pytest.mark.parametrize(("radius", "d"), [(0.3, 2.0), (0.15, 1.2)])
def test_cylinder_reads_distance_minus_radius(radius: float, d: float) -> None:
    world = World([Circle((0.0, d), radius)])
    r = _ranges(world, (0.0, 0.0), math.pi / 2, NO_WALK)
    assert r.tolist() == pytest.approx([d - radius], abs=2e-3)


def test_cylinder_is_weaker_than_a_plane_by_its_divergence() -> None:
    radius = 0.3
    # R / (R + r) with r = 1.7 m: heard; at r = 3.7 m it falls under the threshold that a
    # plane at the same range still clears
    r = _ranges(World([Circle((0.0, 2.0), radius)]), (0.0, 0.0), math.pi / 2)
    walk = float(time_walk((1 / 1.7) ** 2 * radius / (radius + 1.7), P, C))
    assert r.tolist() == pytest.approx([1.7 + walk], abs=2e-3)
    assert _ranges(World([Circle((0.0, 4.0), radius)]), (0.0, 0.0), math.pi / 2).size == 0
    assert _ranges(World([wall((-5.0, 3.7), (5.0, 3.7))]), (0.0, 0.0), math.pi / 2).size == 1


def test_a_nearer_surface_blocks_the_path() -> None:
    front = World([*PLANE.surfaces, wall((-0.4, 1.0), (0.4, 1.0))])
    r = _ranges(front, (0.0, 0.0), math.pi / 2, NO_WALK)
    assert r.tolist() == pytest.approx([1.0])
    screened = World([*CORNER.surfaces, wall((2.5, 0.5), (0.5, 2.5))])
    r = _ranges(screened, (0.0, 0.0), math.pi / 4, NO_WALK)
    assert r.tolist() == pytest.approx([1.5 * math.sqrt(2.0)])  # the screen, not the corner


def test_vertices_are_derived_from_the_polylines() -> None:
    verts = world_vertices(load_world("room-box"))
    arms = sorted(v.arms.size for v in verts)
    # 2 door jambs (free ends), 4 room corners, 4 box corners
    assert arms == [1, 1] + [2] * 8


# --- scenarios ---------------------------------------------------------------------------


def _scn(**extra: Any) -> dict[str, Any]:
    return {
        "world": {"surfaces": [{"type": "room", "x_min": -2, "x_max": 2, "y_min": -2,
                                "y_max": 2}]},
        "array": {"type": "circular", "count": 8},
        **extra,
    }  # fmt: skip


def test_physics_is_validated_with_a_one_line_error() -> None:
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(_scn(physics="real"), source="s.yaml")
    msg = str(err.value)
    assert "\n" not in msg and "physics" in msg and "'ideal'" in msg and "'transducer'" in msg
    with pytest.raises(WorldError, match="physics"):
        world_from_dict({"physics": "x", "surfaces": [{"type": "wall", "start": [0, 0],
                                                        "end": [1, 0]}]})  # fmt: skip
    with pytest.raises(ScenarioError, match="pairs"):
        scenario_from_dict(_scn(physics="transducer", pairs="all"))


def test_physics_comes_from_the_scenario_else_the_world_else_ideal() -> None:
    assert scenario_from_dict(_scn()).physics == "ideal"
    w = {**_scn()["world"], "physics": "transducer"}
    assert scenario_from_dict(_scn(world=w)).physics == "transducer"
    assert scenario_from_dict(_scn(world=w, physics="ideal")).physics == "ideal"


def test_transducer_scenario_reports_first_echoes_only() -> None:
    res = simulate(scenario_from_dict(_scn(physics="transducer", record_no_echo=True)))
    r = res.readings
    assert r.size == 8 and np.all(r["echo"] == 0)
    # centred in a 4 m square room: the four axis sonars read 2 m plus a small time walk
    # (their 0.22 m mount puts them 1.78 m from the wall); the diagonal ones hear corners
    rng = 0.5 * r["tof"] * res.speed_of_sound
    axis = rng[[0, 2, 4, 6]]
    assert axis == pytest.approx(np.full(4, 1.78), abs=2e-3)
    assert rng[[1, 3, 5, 7]] == pytest.approx(np.full(4, 2 * math.sqrt(2) - 0.22), abs=3e-3)
    assert res.attrs["physics"] == "transducer"


def test_office_corners_are_heard_where_no_wall_is_in_view() -> None:
    res = simulate(load_scenario("office-door"))
    r, s = res.readings, res.sensors
    heard = np.isfinite(r["tof"])
    r = r[heard]
    k = np.searchsorted(s["id"], r["rx"])
    c, sn = np.cos(r["turret"]), np.sin(r["turret"])
    xy = np.c_[r["x"] + c * s["x"][k] - sn * s["y"][k], r["y"] + sn * s["x"][k] + c * s["y"][k]]
    rng = 0.5 * r["tof"] * res.speed_of_sound
    corners = np.array([[0.0, 0.0], [6.0, 0.0], [6.0, 5.0], [0.0, 5.0]])
    d = np.linalg.norm(xy[:, None, :] - corners[None], axis=2)
    # every room corner answers some readings at its distance (to quantisation and noise)
    near = np.abs(rng[:, None] - d) < 0.03
    on_axis = np.abs(
        (np.arctan2(corners[None, :, 1] - xy[:, None, 1], corners[None, :, 0] - xy[:, None, 0])
         - (r["turret"] + s["heading"][k])[:, None] + np.pi) % (2 * np.pi) - np.pi
    ) < np.deg2rad(5.0)  # fmt: skip
    assert np.all((near & on_axis).sum(axis=0) >= 5)


#: sha256 of the readings and truth of shipped ideal scenes, from before the transducer
#: physics existed: the ideal physics must not change a byte.
IDEAL_DIGESTS = {
    "fig12": ("365fb4cb961004b1e017304d03a4b9aa94727d98bdca75e438f4f71fc83fc53e",
              "dc69d8532832a7d3b5b3d0203ddcaf896d4352f79c04cfe0d95e2e6ef633230f"),
    "room-box": ("8e9bdf6607881eb4751e11dc090ff9bd371ff9a4b9835e9510082e675fc595a6",
                 "7d3225d6de8fbe42132aded0bb2b62fa990d578cf615694ca18412766cdcfbc1"),
}  # fmt: skip


@pytest.mark.parametrize("name", sorted(IDEAL_DIGESTS))
def test_ideal_physics_output_is_unchanged(name: str) -> None:
    res = simulate(load_scenario(name))
    got = (hashlib.sha256(res.readings.tobytes()).hexdigest(),
           hashlib.sha256(res.truth.tobytes()).hexdigest())  # fmt: skip
    assert got == IDEAL_DIGESTS[name]
    assert "physics" not in res.attrs

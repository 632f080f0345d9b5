"""Tests for the corner, far-output and doorway scores of the transducer-physics table."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from sonarlog import read_log
from sonarlog.reader import SonarLog
from sonarmorph_tools import TEST_SCENARIOS
from sonarmorph_tools.reproduction.multi_surface import SurfaceRow, reflector_section
from sonarmorph_tools.reproduction.reflector_score import (
    ReflectorScore,
    convex_gaps,
    corner_sectors,
    score_reflectors,
)
from sonarproc.simulate import simulate_to_log
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarsim.scenario import load_scenario
from sonarsim.world import World

SCENE = TEST_SCENARIOS / "open-doorway-corridor.yaml"


def _line(a: tuple[float, float], b: tuple[float, float]) -> SurfaceFit:
    poly = np.array([a, b], dtype=np.float64)
    return SurfaceFit("line", poly, float(np.hypot(*(poly[1] - poly[0]))), 0.0, 9, 9)


def _point(kind: str, xy: tuple[float, float]) -> SurfaceFit:
    return SurfaceFit(kind, np.array([xy], dtype=np.float64), 0.0, 0.0, 9, 9)


#: The corridor's walls as a perfect map (the office behind the doorway included).
WALLS = [_line((0.0, 0.0), (7.0, 0.0)), _line((0.0, 2.0), (3.0, 2.0)),
         _line((3.9, 2.0), (7.0, 2.0)), _line((2.0, 2.0), (2.0, 5.0)),
         _line((2.0, 5.0), (5.5, 5.0)), _line((5.5, 5.0), (5.5, 2.0))]  # fmt: skip


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> tuple[World, SonarLog]:
    log = tmp_path_factory.mktemp("score") / "door.h5"
    simulate_to_log(SCENE, log)
    return load_scenario(SCENE).world, read_log(log)


def test_geometry_of_doorway_and_corners() -> None:
    world = load_scenario(SCENE).world
    truth = world.truth_profile(spacing=0.005, surfaces=range(len(world.surfaces)))
    gaps = convex_gaps(world, truth[np.isfinite(truth).all(axis=1)])
    assert len(gaps) == 1
    assert sorted(np.round(np.vstack(gaps[0]), 6).tolist()) == [[3.0, 2.0], [3.9, 2.0]]
    # the office's two far corners; the office walls meet the corridor wall in T joints
    # whose free-space sectors are right angles too
    xy = sorted(tuple(np.round(v, 6).tolist()) for v, _s, _w in corner_sectors(world))
    assert (2.0, 5.0) in xy and (5.5, 5.0) in xy


def test_perfect_map_scores_full(scene: tuple[World, SonarLog]) -> None:
    world, log = scene
    corners = [_point("corner", (2.0, 5.0)), _point("corner", (5.5, 5.0)),
               _point("corner", (2.0, 2.0)), _point("corner", (5.5, 2.0))]  # fmt: skip
    s = score_reflectors(world, log, [*WALLS, *corners])
    assert s.far_share == 0.0
    assert s.doors_seen == 1 and s.doors_open == 1
    assert s.corners_in_view >= 1 and s.corners_reported == s.corners_in_view
    # the scene's other right-angled sectors (walls' solid sides) no sensor was in
    assert s.corners_out_of_view == len(corner_sectors(world)) - s.corners_in_view


def test_bridged_doorway_phantom_and_edge_instead_of_corner(scene: tuple[World, SonarLog]) -> None:
    world, log = scene
    bridge = _line((2.9, 2.0), (4.0, 2.0))
    phantom = _line((1.0, 1.0), (1.0, 1.5))  # 51 samples, 1 m from every wall
    s = score_reflectors(world, log, [*WALLS, bridge, phantom, _point("edge", (2.0, 5.0))])
    assert s.doors_seen == 1 and s.doors_open == 0
    assert s.corners_reported == 0 and s.missed_corners
    # the phantom (51 samples) and the bridge's middle (69) of about 2430 samples
    assert s.far_share == pytest.approx(120 / 2430, abs=0.003)


def test_reflector_section_rows() -> None:
    seen = SurfaceRow("office-door", "s", 1, 2, 3, "auto", 0.005, 0.9, 1.0,
                      ReflectorScore(0.01, 4, 4, 1, 1))  # fmt: skip
    held = SurfaceRow("heldout-x", "s", 1, 2, 3, "auto", 0.005, 0.8, 1.0,
                      ReflectorScore(0.05, 2, 3, 0, 1, ((1.0, 2.5),), 2),
                      held_out=True)  # fmt: skip
    plain = SurfaceRow("corridor-l", "s", 1, 2, 3, "auto", 0.005, 0.9, 1.0)
    text = "\n".join(reflector_section([held, plain, seen]))
    assert (
        "| `office-door` | seen | 0.50 | 0.900 | 1.0 | 4 of 4 (0 not in view) | 1 of 1 | yes |"
        in text
    )
    assert ("| `heldout-x` | held out | 0.50 | 0.800 | 5.0 | 2 of 3 (2 not in view) | 0 of 1 | no |"
            in text)  # fmt: skip
    assert "- `heldout-x`: (1, 2.5)" in text
    assert text.index("office-door") < text.index("heldout-x") and "corridor-l" not in text
    assert reflector_section([plain]) == []


def test_score_without_fits(scene: tuple[World, SonarLog], tmp_path: Path) -> None:
    world, log = scene
    s = score_reflectors(world, log, [])
    assert s.far_share == 0.0 and s.corners_reported == 0 and s.doors_open == s.doors_seen


def test_corner_no_reading_heard_is_not_in_view(scene: tuple[World, SonarLog]) -> None:
    world, log = scene
    full = score_reflectors(world, log, WALLS)
    assert full.corners_in_view >= 1
    # the same poses, each echo 10 cm long: every corner was in the beams, none was heard
    readings = log.readings.copy()
    readings["tof"] += 2 * 0.10 / float(log.attrs.get("speed_of_sound", 343.0))
    deaf = score_reflectors(world, dataclasses.replace(log, readings=readings), WALLS)
    assert deaf.corners_in_view == 0 and deaf.missed_corners == ()
    assert deaf.corners_out_of_view == len(corner_sectors(world))

"""A corner on a wall's line needs one pose fewer than a free point, heard from far.

A sparse log (one reading per scan, a scan every 0.25 m) hears a room's corner (0, 0)
from 4-5 m a few times only, from a track along y = 3.8 (1-inch range steps, 5 mm noise,
seeded); the walls y = 0 and x = 0 are fitted from readings seen head on. On a wall's line
the corner has one unknown, so four poses give the three tests of coincidence that five
give a free point: it is found. Three poses are too few; four readings from one pose
repeat one arc; four poses heard from within an edge's reach (an edge's diffracted echo
is heard there too) are no corner.
"""

from __future__ import annotations

import numpy as np
from cornerlogs import HALF_BEAM, quantised, wall_fit

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.line_corners import MIN_LINE_POSES, corners_on_wall_lines
from sonarproc.surfaces.reflectors.rcd import MIN_POSES


def _log(corner_xy: np.ndarray, seed: int = 7) -> EchoGeometry:
    """The walls' head-on readings, and the corner heard from ``corner_xy`` (its sensors)."""
    rng = np.random.default_rng(seed)
    wall_x = np.linspace(1.2, 3.8, 12)
    south_s, west_s = np.c_[wall_x, np.full(12, 1.5)], np.c_[np.full(12, 1.5), wall_x]
    walls_r = quantised(np.full(24, 1.5), rng)
    aim = np.arctan2(-corner_xy[:, 1], -corner_xy[:, 0])  # the sensors look at the corner
    heading = np.r_[aim + rng.uniform(-0.1, 0.1, aim.size), np.full(12, -np.pi / 2),
                    np.full(12, np.pi)]  # fmt: skip
    xy = np.r_[corner_xy, south_s, west_s]
    r = np.r_[quantised(np.hypot(*corner_xy.T), rng), walls_r]
    return EchoGeometry(xy, heading, np.full(xy.shape[0], HALF_BEAM), r)


def _walls() -> list[SurfaceFit]:
    return [wall_fit((1.0, 0.0), (4.0, 0.0)), wall_fit((0.0, 1.0), (0.0, 4.0))]


def _track(xs: np.ndarray, y: float) -> np.ndarray:
    return np.c_[xs, np.full(xs.size, y)]


def test_the_support_rule_is_one_unknown_fewer() -> None:
    assert MIN_LINE_POSES == MIN_POSES - 1 == 4


def test_a_corner_heard_from_four_far_poses_is_found_on_the_walls_lines() -> None:
    echoes = _log(_track(np.array([2.4, 2.65, 2.9, 3.15]), 3.8))
    found = corners_on_wall_lines(_walls(), echoes, [])
    assert len(found) == 1
    assert float(np.hypot(*found[0].xy)) < 0.02
    assert found[0].support == 4
    assert found[0].poses == 4


def test_three_poses_are_too_few() -> None:
    echoes = _log(_track(np.array([2.4, 2.65, 2.9]), 3.8))
    assert corners_on_wall_lines(_walls(), echoes, []) == []


def test_readings_of_one_pose_repeat_one_arc() -> None:
    # two poses, each heard twice (the same arc): two poses, not four
    echoes = _log(_track(np.array([2.4, 2.41, 2.9, 2.91]), 3.8))
    assert corners_on_wall_lines(_walls(), echoes, []) == []


def test_four_poses_within_an_edges_reach_are_no_corner() -> None:
    # 1.3-1.6 m away: a convex edge's weak echo is heard there too
    echoes = _log(_track(np.array([0.75, 0.85, 0.95, 1.05]), 1.1))
    assert corners_on_wall_lines(_walls(), echoes, []) == []

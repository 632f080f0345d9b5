"""A corner on a wall's line is not vetoed by one blocked sight line or by a tilted plane.

A room's corner (0, 0) is heard from 4-5 m by a few poses (1-inch range steps, 5 mm
noise, seeded); its walls are fitted from readings seen head on.

* A short plane fitted a few centimetres past its end crosses one reading's sight line
  to the corner: that reading is left out, and the others still place the corner.
* Heard from a track straight towards it, 20 degrees off the wall's normal, its ranges
  are explained as well by a plane a dozen degrees off the wall's line (the plane's
  tilt barely changes the ranges' slope along such a track). That plane passes the
  wall's end, 1.2 m from the corner, far off: it is no more of the wall, and the corner
  stands.
"""

from __future__ import annotations

import numpy as np
from cornerlogs import HALF_BEAM, quantised, wall_fit

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.line_corners import corners_on_wall_lines


def _log(corner_xy: np.ndarray, walls: list[tuple[np.ndarray, float]], seed: int) -> EchoGeometry:
    """The corner heard from ``corner_xy``, and each wall's head-on readings (sensors, heading)."""
    rng = np.random.default_rng(seed)
    aim = np.arctan2(-corner_xy[:, 1], -corner_xy[:, 0])  # the sensors look at the corner
    xy = [corner_xy] + [s for s, _ in walls]
    heading = [aim + rng.uniform(-0.05, 0.05, aim.size)]
    heading += [np.full(s.shape[0], h) for s, h in walls]
    r = [quantised(np.hypot(*corner_xy.T), rng)] + [quantised(np.full(s.shape[0], 1.5), rng)
                                                      for s, _ in walls]  # fmt: skip
    xy_all = np.concatenate(xy)
    return EchoGeometry(xy_all, np.concatenate(heading), np.full(xy_all.shape[0], HALF_BEAM),
                        np.concatenate(r))  # fmt: skip


def _room_log(seed: int = 11) -> EchoGeometry:
    """Corner heard from five poses along y = 3.8; walls y = 0 and x = 0 seen head on."""
    wall_x = np.linspace(1.2, 3.8, 12)
    south = (np.c_[wall_x, np.full(12, 1.5)], -np.pi / 2)
    west = (np.c_[np.full(12, 1.5), wall_x], np.pi)
    track = np.c_[np.array([2.4, 2.65, 2.9, 3.15, 3.4]), np.full(5, 3.8)]
    return _log(track, [south, west], seed)


def test_a_corner_is_found_without_the_reading_a_fitted_plane_blocks() -> None:
    walls = [wall_fit((1.0, 0.0), (4.0, 0.0)), wall_fit((0.0, 1.0), (0.0, 4.0))]
    # a short plane crossing the last pose's sight line (x = 1.7 at y = 1.9) only
    stub = wall_fit((1.65, 1.9), (2.2, 1.9))
    echoes = _room_log()
    found = corners_on_wall_lines(walls, echoes, [])
    assert len(found) == 1 and found[0].poses == 5
    found = corners_on_wall_lines([*walls, stub], echoes, [])
    assert len(found) == 1
    assert float(np.hypot(*found[0].xy)) < 0.03
    assert found[0].poses == 4
    assert 4 not in found[0].readings.tolist()  # the blocked one


def _normal_log(seed: int) -> EchoGeometry:
    """Corner heard from seven poses 4.4 .. 4.9 m away, 20 degrees off the wall's normal
    (x = 0), looking 5 and 17 degrees beside it in turn; the wall seen head on."""
    sight = np.radians(-20.0)
    d = np.linspace(4.4, 4.9, 7)
    track = -d[:, None] * np.array([np.cos(sight), np.sin(sight)])
    west = (np.c_[np.full(12, -1.5), np.linspace(1.8, 3.8, 12)], 0.0)
    echoes = _log(track, [west], seed)
    heading = echoes.heading.copy()
    heading[:7] = np.radians(np.where(np.arange(7) % 2, -3.0, -15.0))
    return EchoGeometry(echoes.xy, heading, echoes.half_beam, echoes.range_m)


def test_a_tilted_plane_that_misses_the_walls_end_does_not_hide_the_corner() -> None:
    # the plane heard by every beam that explains the ranges best lies 12-13 degrees off
    # the wall's line, and passes the wall's end (0, 1.2) 0.3 m off
    for seed in range(4):
        found = corners_on_wall_lines([wall_fit((0.0, 1.2), (0.0, 4.0))], _normal_log(seed), [])
        assert len(found) == 1
        assert float(np.hypot(*found[0].xy)) < 0.03
        assert found[0].poses == 7

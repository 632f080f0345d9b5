"""A corner on a wall's line heard from one straight row of poses far off.

A ring sensor on a robot driving straight (its heading fixed) hears a room's corner
(0, 0) from about 4.4 m, nine times over 0.4 m of track along y = 3.6; the wall y = 0 is
fitted from x = 1 to 4. The echoes read long by the time walk of a weak echo (up to
1.5 cm, growing towards the beam's edge), then in 1-inch steps with 5 mm of noise
(seeded). A plane normal to the line of sight explains such ranges about as well as the
point (their curvature over the row is a few millimetres), and better once they are
rounded to even steps: the corner is found all the same, on the wall's line within the
5 cm a corner is matched to, with the walk taken out.
"""

from __future__ import annotations

import numpy as np
import pytest
from cornerlogs import HALF_BEAM, quantised, wall_fit

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.line_corners import corners_on_wall_lines
from sonarproc.surfaces.reflectors.time_walk import TIME_WALK_M, walk_shape

#: The row's heading: a ring sensor looking back past the corner, 5 degrees off the
#: bearing from the row's middle (the corner drifts across the beam along the row).
HEADING = np.arctan2(-3.6, -2.5) - np.radians(5.0)


def _row_log(seed: int) -> EchoGeometry:
    """The corner's readings, then the wall's, seen head on."""
    rng = np.random.default_rng(seed)
    xy = np.c_[np.linspace(2.3, 2.7, 9), np.full(9, 3.6)]
    heading = np.full(xy.shape[0], HEADING)
    walk = TIME_WALK_M * walk_shape(xy, heading, np.full(xy.shape[0], HALF_BEAM), np.zeros(2))
    r = quantised(np.hypot(*xy.T) + walk, rng)
    wall_s = np.c_[np.linspace(1.2, 3.8, 12), np.full(12, 1.5)]  # the wall's, head on
    xy = np.r_[xy, wall_s]
    heading = np.r_[heading, np.full(12, -np.pi / 2)]
    r = np.r_[r, quantised(np.full(12, 1.5), rng)]
    return EchoGeometry(xy, heading, np.full(xy.shape[0], HALF_BEAM), r)


@pytest.mark.parametrize("seed", range(20))
def test_a_corner_heard_from_one_far_row_is_found_within_5_cm(seed: int) -> None:
    found = corners_on_wall_lines([wall_fit((1.0, 0.0), (4.0, 0.0))], _row_log(seed), [])
    assert len(found) == 1
    assert float(np.hypot(*found[0].xy)) < 0.05
    assert found[0].poses == 9

"""Echo points of readings on surfaces whose extent surrounds the sensor."""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces import EchoGeometry, echo_points
from sonarproc.surfaces.planar.polylines import resample


def _two_walls() -> np.ndarray:
    """A room's north wall y = 4.5 (x 0 .. 4) and a diagonal wall to (6, 2.5), one polyline
    (a 135-degree concave corner at (4, 4.5)), sampled every centimetre."""
    return resample(np.array([[0.0, 4.5], [4.0, 4.5], [6.0, 2.5]]), 0.01)


def test_a_sensor_inside_a_cornered_surfaces_extent_finds_its_echo() -> None:
    # sensors 0.6 m below the north wall face it; the middle of the surface's bounding box
    # lies behind them (south-east), yet each reading echoes from the wall at its range
    poly = _two_walls()
    x = np.arange(1.0, 3.6, 0.25)
    g = EchoGeometry(np.c_[x, np.full(x.size, 3.9)], np.full(x.size, math.pi / 2),
                     np.full(x.size, np.deg2rad(12.5)), np.full(x.size, 0.6))  # fmt: skip
    got = echo_points([poly], [False], g, tol=0.03)[0]
    assert sorted(got.readings.tolist()) == list(range(x.size))
    np.testing.assert_allclose(got.points[:, 1], 4.5, atol=1e-9)
    np.testing.assert_allclose(np.sort(got.points[:, 0]), x, atol=1e-9)


def test_a_sensor_inside_a_cornered_surfaces_extent_facing_away_finds_none() -> None:
    # the same sensors facing south (away from both walls) echo from neither
    poly = _two_walls()
    x = np.arange(1.0, 3.6, 0.25)
    g = EchoGeometry(np.c_[x, np.full(x.size, 3.9)], np.full(x.size, -math.pi / 2),
                     np.full(x.size, np.deg2rad(12.5)), np.full(x.size, 0.6))  # fmt: skip
    assert echo_points([poly], [False], g, tol=0.03)[0].readings.size == 0

"""A point reflector's position with its echoes' time walk taken out (narrow span)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sonarproc.surfaces.reflectors.rcd import _fit_point
from sonarproc.surfaces.reflectors.time_walk import (
    TIME_WALK_M,
    fit_point_with_walk,
    walk_shape,
)
from sonarsim.transducer import TransducerParams, amplitude, time_walk

C = 343.0
HALF_BEAM = math.radians(12.5)


def _corner_seen_through_a_gap(
    p: np.ndarray, heading: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One sensor passing ``p`` 4 m away, heard through a 0.75 m gap only, 5 cm steps.

    Ranges by the simulator's transducer physics: a corner's echo (spreading 1/r^2)
    heard above the threshold, late by its time walk; no noise, no range steps.
    """
    tp = TransducerParams()
    xy = np.column_stack((np.arange(-1.0, 1.5, 0.05), np.zeros(50)))
    rel = p - xy
    r = np.hypot(rel[:, 0], rel[:, 1])
    off = np.arctan2(rel[:, 1], rel[:, 0]) - heading
    amp = amplitude(off, off, r, tp.corner_reflectivity, 2.0, tp, C)
    # the gap: a doorway in a wall near the track hides the rest of the track
    heard = (amp >= tp.threshold) & (xy[:, 0] >= 0.0) & (xy[:, 0] <= 0.75)
    rng = r + time_walk(amp, tp, C)
    return xy[heard], rng[heard], np.full(int(heard.sum()), heading)


@pytest.mark.parametrize(("heading_deg", "plain_off_m"), [(75.0, 0.05), (80.0, 0.005), (90.0, 0.1)])
def test_walk_fit_puts_a_far_corner_back(heading_deg: float, plain_off_m: float) -> None:
    p = np.array([1.0, 4.0])
    xy, rng, heading = _corner_seen_through_a_gap(p, math.radians(heading_deg))
    assert 5 <= xy.shape[0] <= 16
    assert float(np.max(rng - np.hypot(*(p - xy).T))) <= TIME_WALK_M + 1e-3
    start = p + np.array([0.03, -0.03])
    plain, _ = _fit_point(xy, rng, start)
    shape = walk_shape(xy, heading, np.full(xy.shape[0], HALF_BEAM), plain)
    walked, w = fit_point_with_walk(xy, rng, shape, plain)
    assert 0.0 <= w <= TIME_WALK_M
    # the walk pulls the plain fit sideways (by up to 13 cm); the walk fit is back
    # within 2 cm
    assert math.dist(plain, p) > plain_off_m
    assert math.dist(walked, p) < 0.02
    assert math.dist(walked, p) < 0.5 * math.dist(plain, p)


def test_walk_shape_grows_off_the_axis_and_with_range() -> None:
    xy = np.array([[0.0, -1.0], [0.0, -2.0], [0.3, -2.0], [0.6, -2.0]])
    shape = walk_shape(xy, np.full(4, math.pi / 2), np.full(4, HALF_BEAM), np.zeros(2))
    assert shape.max() == 1.0 and np.all(shape > 0)
    assert shape[0] < shape[1] < shape[2] < shape[3]

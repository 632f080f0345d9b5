"""Sensor arrays and paths of poses."""

from __future__ import annotations

import numpy as np
import pytest

from sonarsim.arrays import (
    NOMAD_FRONT_FIVE,
    circular_array,
    linear_array,
    make_array,
    random_array,
)
from sonarsim.paths import Poses, grid_poses, line_locations, sweep
from sonarsim.records import READING_DTYPE, SENSOR_DTYPE


def test_record_dtypes_match_sonarlog() -> None:
    import sonarlog

    assert SENSOR_DTYPE == sonarlog.SENSOR_DTYPE
    assert READING_DTYPE == sonarlog.READING_DTYPE
    from sonarsim import records

    assert records.FLAG_NO_ECHO == sonarlog.FLAG_NO_ECHO
    assert records.FLAG_CROSSTALK == sonarlog.FLAG_CROSSTALK


def test_nomad_ring_geometry() -> None:
    ring = circular_array()
    assert len(ring) == 16
    ang = np.deg2rad(22.5 * np.arange(16))
    np.testing.assert_allclose(ring.x, 0.22 * np.cos(ang), atol=1e-12)
    np.testing.assert_allclose(ring.y, 0.22 * np.sin(ang), atol=1e-12)
    np.testing.assert_allclose(np.cos(ring.heading), np.cos(ang), atol=1e-12)
    np.testing.assert_allclose(np.sin(ring.heading), np.sin(ang), atol=1e-12)
    assert np.all(np.abs(ring.heading) <= np.pi)
    assert ring.half_beamwidth == pytest.approx(np.deg2rad(12.5))
    assert ring.min_range[0] == 0.15 and ring.max_range[0] == 10.7
    front = ring.select(NOMAD_FRONT_FIVE)
    np.testing.assert_allclose(np.rad2deg(front.heading), [-45, -22.5, 0, 22.5, 45])
    rec = front.records()
    assert rec.dtype == SENSOR_DTYPE and rec["id"].tolist() == [14, 15, 0, 1, 2]


def test_world_pose_of_ring_sonar_follows_contract() -> None:
    ring = circular_array()
    xy, h = ring.world([1.0], [2.0], [np.pi / 2])
    # Sonar 0 faces the turret heading, 0.22 m out along it.
    np.testing.assert_allclose(xy[0, 0], [1.0, 2.22], atol=1e-12)
    assert h[0, 0] == pytest.approx(np.pi / 2)
    # Sonar 4 (90 deg CCW) ends up on the -x side.
    np.testing.assert_allclose(xy[0, 4], [0.78, 2.0], atol=1e-12)


def test_linear_array() -> None:
    a = linear_array(11, 0.5, origin=(0.0, 2.0))
    np.testing.assert_allclose(a.x, np.arange(11) * 0.5)
    np.testing.assert_allclose(a.y, 2.0)
    b = linear_array(3, 1.0, direction=np.pi / 2, heading=0.0)
    np.testing.assert_allclose(b.y, [0.0, 1.0, 2.0], atol=1e-12)


def test_random_array_is_seeded_and_uniform() -> None:
    lim = ((0.0, 5.0), (0.0, 3.6), (np.deg2rad(40), np.deg2rad(140)))
    a = random_array(4000, *lim, np.random.default_rng(7))
    b = random_array(4000, *lim, np.random.default_rng(7))
    np.testing.assert_array_equal(a.x, b.x)
    for v, (lo, hi) in zip((a.x, a.y, a.heading), lim, strict=True):
        assert lo <= v.min() and v.max() <= hi
        assert np.mean(v) == pytest.approx((lo + hi) / 2, rel=0.03)
        assert np.std(v) == pytest.approx((hi - lo) / np.sqrt(12), rel=0.03)


def test_array_validation() -> None:
    with pytest.raises(ValueError, match="unique"):
        make_array([0, 1], 0, 0, ids=[3, 3])
    with pytest.raises(ValueError, match="beam"):
        make_array([0], 0, 0, half_beamwidth=2.0)
    with pytest.raises(ValueError, match="range"):
        make_array([0], 0, 0, min_range=2.0, max_range=1.0)
    with pytest.raises(ValueError, match="no sensor with id 16"):
        circular_array().select([1, 16])


def test_sweep_and_locations() -> None:
    np.testing.assert_allclose(np.rad2deg(sweep(*np.deg2rad([40, 140, 10]))), range(40, 141, 10))
    loc = line_locations((-0.75, 0.0), (0.75, 0.0), step=0.025)
    assert loc.shape == (61, 2)
    np.testing.assert_allclose(np.diff(loc[:, 0]), 0.025)
    assert line_locations((0, 0), (5, 0), count=20)[-1, 0] == 5.0
    with pytest.raises(ValueError, match="exactly one"):
        line_locations((0, 0), (1, 0))


def test_grid_poses_order_and_turret() -> None:
    loc = np.array([[0.0, 0.0], [1.0, 0.0]])
    p = grid_poses(loc, theta=[0.0], turret=[0.1, 0.2, 0.3])
    assert len(p) == 6
    np.testing.assert_allclose(p.x, [0, 0, 0, 1, 1, 1])
    np.testing.assert_allclose(p.turret, [0.1, 0.2, 0.3] * 2)
    q = grid_poses(loc, theta=[0.5])
    np.testing.assert_allclose(q.turret, q.theta)
    s = Poses.still()
    assert len(s) == 1 and s.turret[0] == 0.0

"""Odometry drift correction on simulated logs whose true poses are known.

The drift (2 % of the distance driven and 2 degrees of heading per 10 m, signs seeded)
is injected into the exact poses of a simulated log; the alignment must remove at least
80 % of the RMS position error over the readings. room-box was used while developing;
hall-pillar (another robot, another room) was not.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from drift import drifted_readings, looped_scenario, pose_error_rms
from scipy.optimize import approx_fprime

from sonarlog import READING_DTYPE, SENSOR_DTYPE
from sonarproc.align import align_poses, align_readings, corrected_readings
from sonarproc.align.echoes import echo_rays
from sonarproc.align.graph import PoseGraphProblem, odometry_ties
from sonarproc.align.matching import RayFrame, line_matches, match_lines
from sonarproc.align.track import place_nodes, travel


@cache
def _log(name: str) -> tuple[np.ndarray, np.ndarray, float]:
    res = looped_scenario(name, 3)
    return res.readings, res.sensors, float(res.speed_of_sound)


@pytest.mark.slow
@pytest.mark.parametrize(("scene", "seed"), [("room-box", 0), ("room-box", 1), ("hall-pillar", 2)])
def test_alignment_removes_most_of_the_drift(scene: str, seed: int) -> None:
    truth, sensors, c = _log(scene)
    drifted = drifted_readings(truth, seed=seed)
    before = pose_error_rms(truth, drifted["x"], drifted["y"])
    a = align_poses(drifted, sensors, speed_of_sound=c)
    after = pose_error_rms(truth, a.x, a.y)
    assert before > 0.08  # 30 m of travel: the drift is worth correcting
    # measured: 0.10, 0.04 and 0.06 of the drift remain (the issue asks for 0.2 at most)
    assert after <= 0.15 * before, (before, after)
    assert a.reason == ""
    assert a.cost_after < a.cost_before
    # the correction is the difference between the paths, and it is reported as such
    moved = np.hypot(a.x - drifted["x"], a.y - drifted["y"])
    assert a.path_difference_max_m == pytest.approx(moved.max(), abs=1e-9)
    assert a.path_difference_mean_m == pytest.approx(moved.mean(), abs=1e-9)
    assert a.raw_path.shape == a.corrected_path.shape == (a.node_offsets.shape[0], 2)


@pytest.mark.slow
def test_a_drift_free_log_is_left_nearly_unchanged() -> None:
    truth, sensors, c = _log("room-box")
    a = align_poses(truth, sensors, speed_of_sound=c)
    assert a.path_difference_max_m < 0.02
    assert a.path_difference_mean_m < 0.01
    assert a.heading_difference_max_rad < math.radians(0.5)


@pytest.mark.slow
def test_corrected_readings_change_only_the_poses() -> None:
    truth, sensors, c = _log("room-box")
    drifted = drifted_readings(truth, seed=0)
    out, a = align_readings(drifted, sensors, speed_of_sound=c)
    assert out.dtype == drifted.dtype and out.shape == drifted.shape
    for name in ("t", "tx", "rx", "echo", "tof", "flags"):
        np.testing.assert_array_equal(out[name], drifted[name])
    np.testing.assert_array_equal(out["x"], a.x)
    turn = np.angle(np.exp(1j * (out["theta"] - drifted["theta"])))
    turret_turn = np.angle(np.exp(1j * (out["turret"] - drifted["turret"])))
    np.testing.assert_allclose(turret_turn, turn, atol=1e-12)


def test_rows_out_of_time_order_get_the_same_poses() -> None:
    truth, sensors, c = _log("room-box")
    part = drifted_readings(truth[:2000], seed=3)
    perm = np.random.default_rng(0).permutation(part.size)
    a = align_poses(part, sensors, speed_of_sound=c)
    b = align_poses(part[perm], sensors, speed_of_sound=c)
    # a stable time sort: rows with equal t keep their order, so compare per row
    np.testing.assert_allclose(b.x, a.x[perm], atol=1e-6)
    np.testing.assert_allclose(b.theta, a.theta[perm], atol=1e-6)


def test_short_or_silent_logs_are_left_unchanged() -> None:
    sensors = np.zeros(1, SENSOR_DTYPE)
    sensors["max_range"] = 5.0
    r = np.zeros(10, READING_DTYPE)
    r["t"] = np.arange(10.0)
    r["x"] = np.linspace(0.0, 5.0, 10)
    r["flags"] = 1  # no echo anywhere
    a = align_poses(r, sensors)
    assert a.reason == "no echo point matches another stretch of the track"
    np.testing.assert_array_equal(a.x, r["x"])
    still = np.zeros(4, READING_DTYPE)
    assert align_poses(still, sensors).reason == "the track is shorter than half a node spacing"
    assert align_poses(np.zeros(0, READING_DTYPE), sensors).reason == "no readings"
    out = corrected_readings(r, a)
    np.testing.assert_array_equal(out, r)


def test_bad_poses_and_mismatched_alignments_are_refused() -> None:
    sensors = np.zeros(1, SENSOR_DTYPE)
    r = np.zeros(3, READING_DTYPE)
    r["x"][1] = np.nan
    # a run goes on without the correction: alignment declines, it does not fail
    assert align_poses(r, sensors).reason == "the poses are not all finite (x, y, theta)"
    far = np.zeros(3, READING_DTYPE)
    far["x"] = [0.0, 1e200, 2e200]
    assert align_poses(far, sensors).reason == "the track has more node spacings than readings"
    sensors_nan = np.zeros(1, SENSOR_DTYPE)
    sensors_nan["x"] = np.nan
    track = np.zeros(3, READING_DTYPE)
    track["x"] = [0.0, 1.0, 2.0]
    assert align_poses(track, sensors_nan).reason == "a sensor's mount is not finite"
    a = align_poses(np.zeros(2, READING_DTYPE), sensors)
    with pytest.raises(ValueError, match="has 2 poses for 3 readings"):
        corrected_readings(r, a)


def test_nodes_cover_the_track_and_interpolate() -> None:
    u = travel(np.linspace(0.0, 10.0, 101), np.zeros(101), np.zeros(101), turn_radius=0.25)
    n = place_nodes(u, spacing=1.0)
    assert n.count == 11
    np.testing.assert_allclose(n.u, np.arange(11.0))
    np.testing.assert_allclose(n.u[n.lo] * (1 - n.w) + n.u[n.lo + 1] * n.w, u)
    with pytest.raises(ValueError, match="spacing must be > 0"):
        place_nodes(u, spacing=0.0)


def test_closed_form_jacobian_matches_finite_differences() -> None:
    truth, sensors, c = _log("room-box")
    r = drifted_readings(truth[:3000], seed=1)
    order = np.argsort(r["t"], kind="stable")
    track = np.column_stack((r["x"], r["y"], r["theta"]))[order]
    u = travel(track[:, 0], track[:, 1], track[:, 2], turn_radius=0.25)
    driven = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(track[:, :2], axis=0).T))))
    nodes = place_nodes(u, spacing=1.0, driven=driven)
    # the route turns on the spot: position and heading weights differ there
    assert np.abs(nodes.w_xy - nodes.w).max() > 0.1
    rays = echo_rays(r, sensors, order, speed_of_sound=c)
    pose = track[rays.reading]
    xy, look = rays.sensors(pose[:, 0], pose[:, 1], pose[:, 2])
    pts = rays.points(pose[:, 0], pose[:, 1], pose[:, 2])
    raw = RayFrame(pts, xy, look, rays.range_m, rays.half_beam, u[rays.reading], pose[:, :2])
    stretch = nodes.lo[rays.reading]
    q, nb = match_lines(pts, stretch, np.arange(rays.size), radius=0.3, min_points=4,
                        max_thickness=0.03)  # fmt: skip
    m = line_matches(q, nb, raw, look[q], min_points=4, min_places=3)
    assert m.size > 50
    driven = np.full(nodes.count - 1, 1.0)
    ties = odometry_ties(track[nodes.at], driven, np.zeros(nodes.count - 1),
                         drift_fraction=0.005, heading_drift=1e-3, turn_radius=0.25,
                         position_floor=0.005, heading_floor=1e-3)  # fmt: skip
    prob = PoseGraphProblem(nodes, ties, rays, track, m, 0.03)
    x = np.random.default_rng(4).normal(0.0, 0.05, 3 * (nodes.count - 1) + 2)
    jac = prob.jacobian(x).toarray()
    rows = np.random.default_rng(5).choice(jac.shape[0], 40, replace=False)
    for i in rows:
        num = approx_fprime(x, lambda p, i=i: prob.residuals(p)[i], 1e-7)
        np.testing.assert_allclose(jac[i], num, atol=1e-3 * max(1.0, np.abs(num).max()))

"""Pose interpolation, stale detection, no-echo flags, presets and tf mount chains."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from bagbuilders import T0, BagWriter, sim_run
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarlog import FLAG_NO_ECHO
from sonarlog.sources import load_sensors, preset_names, read_source
from sonarlog.sources.poses import PoseTrack, wrap_angle, yaw_from_quaternion
from sonarlog.sources.rosmsgs import StaticTransforms
from sonarlog.sources.stale import stale_mask, value_key


@settings(max_examples=60, deadline=None)
@given(
    a=st.floats(-math.pi, math.pi),
    turn=st.floats(-3.0, 3.0),
    f=st.floats(0.0, 1.0),
)
def test_yaw_interpolates_the_short_way_round(a: float, turn: float, f: float) -> None:
    track = PoseTrack.of([0.0, 1.0], [0.0, 2.0], [1.0, 1.0], wrap_angle([a, a + turn]))
    x, y, theta, inside = track.at(np.array([f]))
    assert inside[0]
    assert abs(x[0] - 2.0 * f) < 1e-12 and abs(y[0] - 1.0) < 1e-12
    want = a + f * turn
    assert abs(math.remainder(float(theta[0]) - want, 2 * math.pi)) < 1e-9
    assert -math.pi < theta[0] <= math.pi


@settings(max_examples=60, deadline=None)
@given(yaw=st.floats(-math.pi, math.pi))
def test_quaternion_yaw(yaw: float) -> None:
    got = float(yaw_from_quaternion(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)))
    assert abs(math.remainder(got - yaw, 2 * math.pi)) < 1e-12


def test_pose_track_outside_span_and_duplicates() -> None:
    track = PoseTrack.of([2.0, 1.0, 2.0], [5.0, 1.0, 3.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0])
    assert track.t.tolist() == [1.0, 2.0] and track.x.tolist() == [1.0, 3.0]  # last sample wins
    x, _, _, inside = track.at(np.array([0.5, 1.5, 2.5]))
    assert inside.tolist() == [False, True, False]
    assert np.isnan(x[0]) and x[1] == 2.0


def test_stale_mask_is_per_sensor_and_bitwise() -> None:
    sensor = np.array([3, 3, 4, 3, 4, 4, 3])
    value = np.array([1.0, 1.0, 2.0, 1.0000001, 2.0, 2.0, 1.0])
    assert stale_mask(sensor, value_key(value)).tolist() == [
        False, True, False, False, True, True, False,
    ]  # fmt: skip
    xy = value_key(np.array([1.0, 1.0, 1.0]), np.array([2.0, 2.5, 2.5]))
    assert stale_mask(np.zeros(3, int), xy).tolist() == [False, False, True]


def test_presets_ship_and_load() -> None:
    names = preset_names()
    for want in ("pioneer-dx-front", "pioneer3-dx", "pioneer3-at", "pioneer3-at-front",
                 "nomad200-ring", "generic-ring"):  # fmt: skip
        assert want in names
    p3 = load_sensors("pioneer3-dx")
    assert len(p3.table) == 16 and p3.robot == "pioneer3-dx"
    # ARIA p3dx.p SonarUnit 3: 166 27 10 (mm, mm, deg); SonarUnit 11: -255 -27 -170.
    np.testing.assert_allclose(
        [p3.table["x"][3], p3.table["y"][3], np.degrees(p3.table["heading"][3])],
        [0.166, 0.027, 10.0], atol=1e-5,
    )  # fmt: skip
    assert p3.table["x"][11] == -0.255 and round(np.degrees(p3.table["heading"][11])) == -170
    assert len(load_sensors("pioneer-dx-front").table) == 8
    at = load_sensors("pioneer3-at").table
    assert at["x"][3] == 0.245  # p3at.p SonarUnit 3: 245 27 10
    nomad = load_sensors("nomad200-ring").table
    assert len(nomad) == 16 and abs(nomad["x"][0] - 0.22) < 1e-12
    assert abs(np.degrees(nomad["half_beamwidth"][0]) - 12.5) < 1e-9
    assert len(load_sensors("generic-ring").table) == 12
    ring = load_sensors("ring-6-0.3").table
    np.testing.assert_allclose(np.hypot(ring["x"], ring["y"]), 0.3)
    np.testing.assert_allclose(np.degrees(ring["heading"][1]), 60.0)


def test_static_transform_chain() -> None:
    st_ = StaticTransforms()
    st_.parent["ring"] = ("base_link", 0.1, 0.0, math.pi / 2)
    st_.parent["sonar_a"] = ("ring", 0.2, 0.0, 0.0)
    x, y, yaw = st_.mount("sonar_a", "base_link") or (0.0, 0.0, 0.0)
    assert abs(x - 0.1) < 1e-12 and abs(y - 0.2) < 1e-12 and abs(yaw - math.pi / 2) < 1e-12
    assert st_.mount("elsewhere", "base_link") is None


def test_range_no_echo_invalid_and_out_of_span(tmp_path: Path) -> None:
    run = sim_run("pioneer-dx-front", stops=1)
    s = run.sensors[0]
    bag = tmp_path / "edge.bag"
    values = [1.0, 5.0, math.inf, 4.9999, -math.inf, math.nan, 2.0, 3.0]
    with BagWriter(bag, "ros1") as bw:
        bw.write("/tf_static", "tf2_msgs/msg/TFMessage", T0,
                 bw.tf(T0, [("base_link", "sonar_0", s["x"], s["y"], s["heading"])]))  # fmt: skip
        for t in (T0, T0 + 6.5):
            bw.write("/odom", "nav_msgs/msg/Odometry", t, bw.odometry(t, 1.0, 2.0, 0.5))
        for k, v in enumerate(values):
            t = T0 + k
            bw.write("/sonar_0", "sensor_msgs/msg/Range", t, bw.range_msg(t, "sonar_0", s, v))
        bw.write("/ir", "sensor_msgs/msg/Range", T0, bw.range_msg(T0, "ir_0", s, 0.5, kind=1))
    log, summary = read_source(bag)
    r = log.readings
    c = summary.counts
    # NaN and -inf (too close) are invalid; the reading at T0 + 7 s is past the last pose.
    assert (c.values, c.invalid_dropped, c.out_of_pose_range_dropped) == (8, 2, 1)
    assert c.readings == 5 and c.no_echo_flagged == 3
    assert (r["flags"] & FLAG_NO_ECHO).tolist() == [0, 1, 1, 1, 0]
    np.testing.assert_allclose(0.5 * r["tof"] * log.speed_of_sound, [1.0, 5.0, 5.0, 5.0, 2.0])
    np.testing.assert_allclose(r["x"], 1.0)
    np.testing.assert_allclose(r["theta"], 0.5)
    assert "skipped 1 infrared Range message(s)" in summary.notes
    assert summary.sonar_topics == ("/ir", "/sonar_0")

"""Round trips: simulated runs written as ROS 1/ROS 2 bags and Player logs read back equal."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bagbuilders import (
    Expected,
    SimRun,
    sim_run,
    write_cloud_bag,
    write_player_log,
    write_range_bag,
)

from sonarlog import FLAG_NO_ECHO, SonarLog, read_log
from sonarlog.sources import (
    OutputExistsError,
    import_to_sonarlog,
    list_source,
    load_sensors,
    read_source,
    write_rosbag2,
)

MM = 1e-3
DEG01 = np.deg2rad(0.1)


@pytest.fixture(scope="module")
def run() -> SimRun:
    return sim_run("pioneer3-dx")


def _bag_path(tmp: Path, kind: str) -> Path:
    return tmp / ("run.bag" if kind == "ros1" else f"run-{kind}")


def _angle_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))


def _check(log: SonarLog, exp: Expected) -> None:
    r = log.readings
    assert len(r) == len(exp.t)
    np.testing.assert_allclose(r["t"], exp.t, atol=1e-6, rtol=0)
    np.testing.assert_array_equal(r["tx"], exp.sensor)
    np.testing.assert_array_equal(r["rx"], exp.sensor)
    np.testing.assert_array_equal(r["echo"], 0)
    rng = 0.5 * r["tof"] * log.speed_of_sound
    assert np.max(np.abs(rng - exp.range)) < MM
    assert np.max(np.abs(r["x"] - exp.pose[:, 0])) < MM
    assert np.max(np.abs(r["y"] - exp.pose[:, 1])) < MM
    assert np.max(_angle_diff(r["theta"], exp.pose[:, 2])) < DEG01
    np.testing.assert_array_equal(r["turret"], r["theta"])
    np.testing.assert_array_equal(r["flags"], exp.flags)


@pytest.mark.parametrize(
    ("kind", "odom"), [("ros1", "odometry"), ("sqlite3", "tf"), ("mcap", "posestamped")]
)
def test_range_bags_round_trip(tmp_path: Path, run: SimRun, kind: str, odom: str) -> None:
    bag = _bag_path(tmp_path, kind)
    exp = write_range_bag(bag, kind, run, odom=odom)
    log, summary = read_source(bag)
    _check(log, exp)
    assert summary.style == "range"
    assert summary.sensors_from == "/tf_static"
    assert summary.counts.stale_dropped == exp.stale > 0
    assert summary.counts.values == len(exp.t) + exp.stale
    assert summary.counts.out_of_pose_range_dropped == 0
    assert summary.format == {"ros1": "ros1", "sqlite3": "ros2-sqlite3", "mcap": "ros2-mcap"}[kind]
    # Mounts come from /tf_static exactly; the beam and range limits from the Range fields.
    used = run.sensors[np.isin(run.sensors["id"], log.sensors["id"])]
    for name in ("id", "x", "y", "heading", "min_range", "max_range", "half_beamwidth"):
        np.testing.assert_allclose(log.sensors[name], used[name], rtol=0, atol=1e-12)
    assert summary.frames == {f"sonar_{i}": int(i) for i in log.sensors["id"]}


def test_range_one_topic_frames_and_preset(tmp_path: Path, run: SimRun) -> None:
    bag = _bag_path(tmp_path, "ros1")
    exp = write_range_bag(bag, "ros1", run, one_topic=True, stale_every=2)
    log, summary = read_source(bag, robot="pioneer3-dx", sonar_topic="/sonar")
    _check(log, exp)
    assert summary.sonar_topics == ("/sonar",)
    assert summary.sensors_from == "preset pioneer3-dx"
    np.testing.assert_array_equal(log.sensors, load_sensors("pioneer3-dx").table)
    assert summary.counts.stale_dropped == exp.stale


@pytest.mark.parametrize(("kind", "cloud2"), [("ros1", False), ("sqlite3", True), ("mcap", False)])
def test_rosaria_cloud_bags_round_trip(
    tmp_path: Path, run: SimRun, kind: str, cloud2: bool
) -> None:
    bag = _bag_path(tmp_path, kind)
    exp = write_cloud_bag(bag, kind, run, cloud2=cloud2)
    log, summary = read_source(bag, robot="pioneer3-dx")
    _check(log, exp)
    np.testing.assert_array_equal(log.sensors, load_sensors("pioneer3-dx").table)
    assert summary.style == ("pointcloud2" if cloud2 else "pointcloud")
    assert summary.sonar_topics == ("/RosAria/sonar",)
    assert summary.counts.stale_dropped == exp.stale > 100
    assert summary.counts.no_echo_flagged == int((exp.flags & FLAG_NO_ECHO).sum()) > 0
    rows = {row.name: row for row in list_source(bag)}
    assert rows["/RosAria/sonar"].role == "sonar"
    assert rows["/odom"].role == "odometry"


def test_player_log_round_trip(tmp_path: Path, run: SimRun) -> None:
    path = tmp_path / "run.log"
    exp = write_player_log(path, run)
    log, summary = read_source(path)
    _check(log, exp)
    assert summary.format == "player"
    assert summary.sensors_from == "player geometry"
    assert summary.counts.stale_dropped == exp.stale
    np.testing.assert_allclose(log.sensors["x"], run.sensors["x"], atol=5e-4)
    np.testing.assert_allclose(log.sensors["heading"], run.sensors["heading"], atol=5e-5)
    # A preset wins over the log's (rounded) geometry.
    log2, s2 = read_source(path, robot="pioneer3-dx")
    np.testing.assert_array_equal(log2.sensors, load_sensors("pioneer3-dx").table)
    assert s2.sensors_from == "preset pioneer3-dx"
    assert [r.name for r in list_source(path) if r.role] == ["position2d:0", "sonar:0"]


def test_import_writes_sonarlog_and_refuses_to_overwrite(tmp_path: Path, run: SimRun) -> None:
    bag = _bag_path(tmp_path, "sqlite3")
    exp = write_range_bag(bag, "sqlite3", run)
    out = tmp_path / "run.h5"
    summary = import_to_sonarlog(bag, out, temperature_c=20.0)
    back = read_log(out)
    _check(back, exp)
    assert back.attrs["temperature_c"] == 20.0
    assert abs(back.speed_of_sound - 343.21) < 0.01
    assert f'"stale_dropped": {exp.stale}' in back.attrs["import_summary"]
    assert summary.counts.readings == len(back.readings)
    assert back.poses is not None and len(back.poses) == summary.counts.poses
    before = out.read_bytes()
    with pytest.raises(OutputExistsError, match="exists already"):
        import_to_sonarlog(bag, out)
    assert out.read_bytes() == before
    import_to_sonarlog(bag, out, force=True, temperature_c=0.0)
    assert abs(read_log(out).speed_of_sound - 331.3) < 1e-9
    # The dispatcher reads a sonarlog too, unchanged.
    again, s3 = read_source(out)
    np.testing.assert_array_equal(again.readings, read_log(out).readings)
    assert s3.format == "sonarlog"


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rosbag2_export_reads_back(tmp_path: Path, run: SimRun, storage: str) -> None:
    from rosbags.highlevel import AnyReader

    bag = _bag_path(tmp_path, "ros1")
    write_range_bag(bag, "ros1", run)
    log, _ = read_source(bag)
    wall = np.array([[-3.0, 3.5], [3.0, 3.5], [np.nan, np.nan], [3.0, -1.5], [3.0, 3.5]])
    curve = np.column_stack([np.linspace(-1, 1, 5), np.linspace(1, 2, 5)])
    out = tmp_path / f"export-{storage}"
    res = write_rosbag2(log, out, surfaces=[wall, curve], storage=storage)
    assert res.markers == 3 and res.skipped_bistatic == 0
    # Our own reader gives the same readings back.
    back, summary = read_source(out)
    np.testing.assert_allclose(back.readings["t"], log.readings["t"], atol=1e-9, rtol=0)
    for name in ("tx", "rx", "flags"):
        np.testing.assert_array_equal(back.readings[name], log.readings[name])
    for name in ("tof", "x", "y"):
        np.testing.assert_allclose(back.readings[name], log.readings[name], atol=1e-6, rtol=0)
    assert np.max(_angle_diff(back.readings["theta"], log.readings["theta"])) < 1e-9
    np.testing.assert_allclose(back.sensors["x"], log.sensors["x"], atol=1e-12)
    assert summary.counts.stale_dropped == 0
    # And rosbags' reader sees the markers as sent.
    with AnyReader([out]) as reader:
        conns = [c for c in reader.connections if c.topic == "/map/surfaces"]
        msgs = [reader.deserialize(d, c.msgtype) for c, _, d in reader.messages(connections=conns)]
        topics = set(reader.topics)
    assert len(msgs) == 1
    markers = msgs[0].markers  # type: ignore[attr-defined]
    assert [(m.ns, m.id, m.type) for m in markers] == [
        ("surfaces", 0, 4),
        ("surfaces", 1, 4),
        ("surfaces", 2, 4),
    ]
    pts = [np.array([(p.x, p.y) for p in m.points]) for m in markers]
    np.testing.assert_array_equal(pts[0], wall[:2])
    np.testing.assert_array_equal(pts[1], wall[3:])
    np.testing.assert_array_equal(pts[2], curve)
    assert {"/tf", "/tf_static", "/map/surfaces"} <= topics
    with pytest.raises(OutputExistsError):
        write_rosbag2(log, out, storage=storage)
    assert write_rosbag2(log, out, storage=storage, force=True).markers == 0

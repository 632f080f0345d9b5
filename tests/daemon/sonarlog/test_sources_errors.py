"""Bad bags and bad arguments give one SourceError line naming the file and what is wrong."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bagbuilders import T0, BagWriter, SimRun, sim_run, write_range_bag

from sonarlog import SonarLogError
from sonarlog.sources import SourceError, list_source, load_sensors, read_source


@pytest.fixture(scope="module")
def run() -> SimRun:
    return sim_run("pioneer-dx-front", stops=2)


def _one_line(err: pytest.ExceptionInfo[SourceError], path: Path, *words: str) -> None:
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith(str(path))
    for w in words:
        assert w in msg, msg
    assert isinstance(err.value, ValueError) and isinstance(err.value, SonarLogError)


def _bag(tmp: Path, kind: str, name: str = "bag") -> Path:
    return tmp / (f"{name}.bag" if kind == "ros1" else f"{name}-{kind}")


@pytest.mark.parametrize("kind", ["ros1", "sqlite3"])
def test_no_sonar_topic(tmp_path: Path, kind: str) -> None:
    bag = _bag(tmp_path, kind)
    with BagWriter(bag, kind) as bw:
        bw.write("/odom", "nav_msgs/msg/Odometry", T0, bw.odometry(T0, 0.0, 0.0, 0.0))
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "no sonar topic", "/odom")
    assert [r.role for r in list_source(bag)] == ["odometry"]


def test_no_odometry(tmp_path: Path, run: SimRun) -> None:
    bag = _bag(tmp_path, "mcap")
    s = run.sensors[0]
    with BagWriter(bag, "mcap") as bw:
        bw.write("/sonar/sonar_0", "sensor_msgs/msg/Range", T0, bw.range_msg(T0, "sonar_0", s, 1.0))
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "no odometry")


def test_tf_without_odometry_pair(tmp_path: Path, run: SimRun) -> None:
    bag = _bag(tmp_path, "sqlite3")
    s = run.sensors[0]
    with BagWriter(bag, "sqlite3") as bw:
        bw.write("/sonar/sonar_0", "sensor_msgs/msg/Range", T0, bw.range_msg(T0, "sonar_0", s, 1.0))
        bw.write("/tf", "tf2_msgs/msg/TFMessage", T0, bw.tf(T0, [("map", "odom", 0, 0, 0)]))
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "no odometry", "/tf")


@pytest.mark.parametrize(("topic", "words"), [
    ("/odom", ["/odom", "nav_msgs/msg/Odometry", "not a sonar type"]),
    ("/chatter", ["/chatter", "std_msgs/msg/String", "not a sonar type"]),
    ("/nothing*", ["no sonar topic matches"]),
])  # fmt: skip
def test_unknown_message_type_on_chosen_topic(tmp_path: Path, topic: str, words: list[str]) -> None:
    bag = _bag(tmp_path, "ros1")
    with BagWriter(bag, "ros1") as bw:
        bw.write("/odom", "nav_msgs/msg/Odometry", T0, bw.odometry(T0, 0.0, 0.0, 0.0))
        bw.write("/chatter", "std_msgs/msg/String", T0, bw.T["std_msgs/msg/String"](data="hi"))
    with pytest.raises(SourceError) as err:
        read_source(bag, sonar_topic=topic)
    _one_line(err, bag, *words)


def test_odometry_topic_of_wrong_type(tmp_path: Path, run: SimRun) -> None:
    bag = _bag(tmp_path, "ros1")
    write_range_bag(bag, "ros1", run)
    with pytest.raises(SourceError) as err:
        read_source(bag, odom_topic="/sonar/sonar_0")
    _one_line(err, bag, "not an odometry type")


@pytest.mark.parametrize("kind", ["ros1", "sqlite3", "mcap"])
def test_empty_bag(tmp_path: Path, kind: str) -> None:
    bag = _bag(tmp_path, kind)
    with BagWriter(bag, kind) as bw:
        bw.conns["/odom"] = bw.writer.add_connection(
            "/odom", "nav_msgs/msg/Odometry", typestore=bw.store
        )
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "empty bag")


@pytest.mark.parametrize(
    ("kind", "keep"), [("ros1", 0.5), ("ros1", 0.97), ("sqlite3", 0.5), ("mcap", 0.6)]
)
def test_truncated_bag(tmp_path: Path, run: SimRun, kind: str, keep: float) -> None:
    bag = _bag(tmp_path, kind)
    write_range_bag(bag, kind, run)
    data = next(
        p for p in ([bag] if kind == "ros1" else bag.iterdir()) if p.name != "metadata.yaml"
    )
    raw = data.read_bytes()
    data.write_bytes(raw[: int(len(raw) * keep)])
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "truncated or unreadable bag")


def test_cloud_needs_a_preset_and_matching_point_count(tmp_path: Path) -> None:
    bag = _bag(tmp_path, "ros1")
    s = load_sensors("pioneer3-dx").table  # 16 end points, 1 m ahead of each transducer
    ahead = np.column_stack((s["x"] + np.cos(s["heading"]), s["y"] + np.sin(s["heading"])))
    with BagWriter(bag, "ros1") as bw:
        bw.write("/odom", "nav_msgs/msg/Odometry", T0, bw.odometry(T0, 0.0, 0.0, 0.0))
        bw.write("/RosAria/sonar", "sensor_msgs/msg/PointCloud", T0, bw.cloud(T0, ahead))
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "carries no mounts", "preset")
    with pytest.raises(SourceError) as err:
        read_source(bag, robot="pioneer-dx-front")
    _one_line(err, bag, "16 points", "8 transducers")
    log, _ = read_source(bag, robot="pioneer3-dx")
    assert len(log.readings) == 16


def test_range_without_mount(tmp_path: Path, run: SimRun) -> None:
    bag = _bag(tmp_path, "sqlite3")
    s = run.sensors[0]
    with BagWriter(bag, "sqlite3") as bw:
        bw.write("/odom", "nav_msgs/msg/Odometry", T0, bw.odometry(T0, 0.0, 0.0, 0.0))
        bw.write("/us/left", "sensor_msgs/msg/Range", T0, bw.range_msg(T0, "us_left", s, 1.0))
    with pytest.raises(SourceError) as err:
        read_source(bag)
    _one_line(err, bag, "no mount for sonar frame us_left")


def test_not_a_log_and_missing_file(tmp_path: Path) -> None:
    junk = tmp_path / "notes.txt"
    junk.write_text("hello\n")
    with pytest.raises(SourceError) as err:
        read_source(junk)
    _one_line(err, junk, "not a log this tool reads", "ROS 1 bag")
    with pytest.raises(FileNotFoundError):
        read_source(tmp_path / "absent.bag")


def test_bad_presets_and_temperature(tmp_path: Path, run: SimRun) -> None:
    with pytest.raises(SourceError, match=r"no preset of that name.*pioneer3-dx"):
        load_sensors("pioneer9")
    bad = tmp_path / "s.yaml"
    bad.write_text("sensors:\n  - {id: 0, x: 0, y: 0, heading: 0, half_beamwidth: 0.2, "
                   "min_range: 2, max_range: 1}\n")  # fmt: skip
    with pytest.raises(SourceError, match=r"s\.yaml: sensors\.0.*max_range"):
        load_sensors(bad)
    bag = _bag(tmp_path, "ros1")
    write_range_bag(bag, "ros1", run)
    with pytest.raises(SourceError, match="temperature"):
        read_source(bag, temperature_c=200.0)

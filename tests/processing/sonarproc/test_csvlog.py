"""Tests for sonarlog.csvlog: readings CSV + sensors YAML from any robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarlog.csvlog import load_sensors_yaml, read_csv_log, read_truth_csv

SENSORS = """\
robot: test-bot
speed_of_sound: 340.0
sensors:
  - {id: 0, x: 0.2, y: 0.0, heading: 0.0, half_beamwidth: 0.2182, min_range: 0.15,
     max_range: 10.7}
  - {id: 3, x: 0.0, y: 0.2, heading: 1.5708, half_beamwidth: 0.2182, min_range: 0.15,
     max_range: 10.7}
"""


@pytest.fixture
def sensors(tmp_path: Path) -> Path:
    p = tmp_path / "sensors.yaml"
    p.write_text(SENSORS)
    return p


def test_round_trip_with_optional_columns(tmp_path: Path, sensors: Path) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text(
        "# comment line\n"
        "t, tx, rx, tof, x, y, theta, turret, flags, echo, extra\n"
        "0.0, 0, 0, 0.01, 1.0, 2.0, 0.1, 0.2, 0, 0, 9\n"
        "0.04, 3, 0, nan, 1.0, 2.0, 0.1, 0.2, 1, 1, 9\n"
    )
    lg = read_csv_log(csv, sensors)
    r = lg.readings
    assert r.size == 2
    assert r["tx"].tolist() == [0, 3] and r["flags"].tolist() == [0, 1]
    assert r["echo"].tolist() == [0, 1]
    assert r["tof"][0] == 0.01 and np.isnan(r["tof"][1])
    assert lg.speed_of_sound == 340.0 and lg.attrs["robot"] == "test-bot"
    assert lg.sensors["id"].tolist() == [0, 3]
    tp = lg.transducer_poses(r[:1])
    np.testing.assert_allclose(tp.tx_xy[0], [1.0 + 0.2 * np.cos(0.2), 2.0 + 0.2 * np.sin(0.2)])


def test_range_column_becomes_tof(tmp_path: Path, sensors: Path) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text("t,tx,rx,range,x,y,theta,turret\n0,0,0,1.7,0,0,0,0\n")
    lg = read_csv_log(csv, sensors)
    assert lg.path_lengths()[0] == pytest.approx(3.4)
    assert lg.readings["flags"][0] == 0


@pytest.mark.parametrize("column", ["tof", "range"])
def test_a_value_too_large_to_convert_is_no_echo(
    tmp_path: Path, sensors: Path, column: str
) -> None:
    # 1e308 s or m overflows when converted (to a range or a time): beyond every max_range
    csv = tmp_path / "r.csv"
    csv.write_text(f"t,tx,rx,{column},x,y,theta,turret\n0,0,0,1e308,0,0,0,0\n")
    lg = read_csv_log(csv, sensors)
    assert lg.readings["flags"][0] == 1 and lg.attrs["no_echo_at_max_range"] == 1


def test_header_only_gives_empty_log(tmp_path: Path, sensors: Path) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text("t,tx,rx,tof,x,y,theta,turret\n")
    assert read_csv_log(csv, sensors).readings.size == 0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty file"),
        ("t,tx,rx,x,y,theta,turret\n", "exactly one of the columns 'tof'"),
        ("t,tx,tof,x,y,theta,turret\n", "missing required column(s) rx"),
        ("t,tx,rx,tof,x,y,theta,turret\n0,0.5,0,1,0,0,0,0\n", "'tx' must hold integers"),
        ("t,tx,rx,tof,x,y,theta,turret\n0,0,0,abc,0,0,0,0\n", "could not convert"),
        ("t,tx,rx,tof,x,y,theta,turret\n0,0,0,1,0,0\n", "r.csv"),
        ("t,tx,rx,tof,x,y,theta,turret\n0,0,0,1,nan,0,0,0\n", "'x' is not finite"),
        ("t,t,rx,tof,x,y,theta,turret\n", "repeats"),
    ],
)
def test_bad_csv_names_file_and_problem(
    tmp_path: Path, sensors: Path, text: str, message: str
) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text(text)
    with pytest.raises(ValueError, match=r"r\.csv") as info:
        read_csv_log(csv, sensors)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[1, 2]", "must hold a mapping"),
        ("sensors: []", "sensors"),
        (
            "sensors: [{id: 0, x: 0, y: 0, heading: 0, half_beamwidth: 4, min_range: 0, "
            "max_range: 1}]",
            "half_beamwidth",
        ),
        (
            "sensors: [{id: 0, x: 0, y: 0, heading: 0, half_beamwidth: 0.2, min_range: 2, "
            "max_range: 1}]",
            "max_range must be greater",
        ),
        (
            "sensors: [{id: 0, x: 0, y: 0, heading: 0, half_beamwidth: 0.2, min_range: 0, "
            "max_range: 1, colour: red}]",
            "colour",
        ),
        (
            "sensors:\n - {id: 1, x: 0, y: 0, heading: 0, half_beamwidth: 0.2, min_range: 0, "
            "max_range: 1}\n - {id: 1, x: 0, y: 0, heading: 0, half_beamwidth: 0.2, min_range: 0, "
            "max_range: 1}",
            "repeat",
        ),
        ("sensors: [unclosed", "not a readable YAML file"),
    ],
)
def test_bad_sensors_yaml(tmp_path: Path, text: str, message: str) -> None:
    p = tmp_path / "s.yaml"
    p.write_text(text)
    with pytest.raises(ValueError, match=r"s\.yaml") as info:
        load_sensors_yaml(p)
    assert message in str(info.value)


def test_truth_csv(tmp_path: Path) -> None:
    p = tmp_path / "truth.csv"
    p.write_text("x,y\n0,1\n1,1.5\n")
    np.testing.assert_array_equal(read_truth_csv(p), [[0.0, 1.0], [1.0, 1.5]])
    p.write_text("a,b\n0,1\n")
    with pytest.raises(ValueError, match="columns x and y"):
        read_truth_csv(p)
    p.write_text("x,y\n0,1\n")
    with pytest.raises(ValueError, match="at least 2"):
        read_truth_csv(p)


def test_shipped_example_pair_reads(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[3]
    lg = read_csv_log(
        root / "configs/sensors/example-readings.csv", root / "configs/sensors/example-sensors.yaml"
    )
    assert lg.readings.size > 0
    lg.transducer_poses()

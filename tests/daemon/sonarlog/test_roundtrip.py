"""Round trips, transducer poses, validation errors and the recover command."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from logbuilders import random_readings, ring_sensors

from sonarlog import (
    POSE_DTYPE,
    READING_DTYPE,
    InvalidLogError,
    LogWriter,
    read_log,
    recover_log,
)
from sonarproc.cli import main


def _write(path: Path, readings: np.ndarray, **kw: object) -> None:
    with LogWriter(path, ring_sensors(), robot="test", flush_interval=0, **kw) as w:  # type: ignore[arg-type]
        for part in np.array_split(readings, 7):
            w.append(part)


def test_round_trip_keeps_every_field(tmp_path: Path) -> None:
    rng = np.random.default_rng(1)
    readings = random_readings(rng, 10_000)
    truth = np.column_stack([np.linspace(0, 5, 501), np.sin(np.linspace(0, 5, 501))])
    poses = np.zeros(3, POSE_DTYPE)
    poses["t"] = [1.0, 2.0, 3.0]
    poses["x"] = [0.1, 0.2, 0.3]
    path = tmp_path / "log.h5"
    with LogWriter(
        path,
        ring_sensors(),
        speed_of_sound=340.0,
        robot="nomad200",
        attrs={"baud": 9600, "plan": "steps: []"},
        truth=truth,
        flush_interval=0.05,
    ) as w:
        w.append(readings[:4000])
        w.append_poses(poses)
        w.event("start", "plan translate.yaml", t=5.0)
        w.append(readings[4000:])
        assert w.n_readings == 10_000

    log = read_log(path)
    assert log.readings.dtype == READING_DTYPE
    np.testing.assert_array_equal(log.readings, readings)
    np.testing.assert_array_equal(log.sensors, ring_sensors())
    np.testing.assert_array_equal(log.truth, truth)
    assert log.poses is not None
    np.testing.assert_array_equal(log.poses, poses)
    assert log.events is not None
    assert log.events["kind"].tolist() == [b"start"]
    assert log.events["t"].tolist() == [5.0]
    assert log.speed_of_sound == 340.0
    assert log.attrs["format"] == "sonarlog"
    assert log.attrs["format_version"] == 1
    assert log.attrs["robot"] == "nomad200"
    assert log.attrs["baud"] == 9600
    assert log.attrs["created"].endswith("+00:00")
    assert log.dropped_rows == 0
    np.testing.assert_allclose(log.path_lengths(), readings["tof"] * 340.0)


def test_closed_file_opens_with_plain_hdf5_and_pins_v110(tmp_path: Path) -> None:
    path = tmp_path / "log.h5"
    _write(path, random_readings(np.random.default_rng(2), 100))
    with h5py.File(path, "r") as f:  # no SWMR flag left behind after a clean close
        assert f["readings"].shape == (100,)
        assert f["readings"].chunks is not None
        assert f["readings"].maxshape == (None,)
    # Superblock version 3 is what HDF5 1.10+ writes for the v110 format; 1.12/1.14 read it.
    assert path.read_bytes()[8] == 3


def test_transducer_poses_match_the_contract_formula() -> None:
    rng = np.random.default_rng(3)
    readings = random_readings(rng, 500)
    sensors = ring_sensors()
    from sonarlog import SonarLog

    log = SonarLog(
        path=Path("mem.h5"), attrs={"speed_of_sound": 343.3}, sensors=sensors, readings=readings
    )
    tp = log.transducer_poses()
    for k in rng.choice(len(readings), 25, replace=False):
        r = readings[k]
        ends = (("tx", tp.tx_xy, tp.tx_heading), ("rx", tp.rx_xy, tp.rx_heading))
        for which, xy, heading in ends:
            s = sensors[sensors["id"] == r[which]][0]
            c, si = np.cos(r["turret"]), np.sin(r["turret"])
            expect = (r["x"] + c * s["x"] - si * s["y"], r["y"] + si * s["x"] + c * s["y"])
            np.testing.assert_allclose(xy[k], expect, atol=1e-12)
            assert heading[k] == pytest.approx(r["turret"] + s["heading"])
    assert tp.tx_xy.shape == (500, 2)
    assert np.all(tp.rx_half_beamwidth == np.deg2rad(12.5))
    assert np.all(tp.max_range == 10.7)


def test_unknown_sensor_id_is_named(tmp_path: Path) -> None:
    readings = random_readings(np.random.default_rng(4), 10)
    readings["tx"][3] = 42
    path = tmp_path / "log.h5"
    _write(path, readings)
    with pytest.raises(InvalidLogError, match=r"sensor id\(s\) 42 with no /sensors row"):
        read_log(path).transducer_poses()


def test_minimal_file_with_only_required_fields_is_accepted(tmp_path: Path) -> None:
    path = tmp_path / "minimal.h5"
    readings = random_readings(np.random.default_rng(5), 20)
    with h5py.File(path, "w") as f:
        f.attrs.update(
            format="sonarlog",
            format_version=1,
            speed_of_sound=343.3,
            robot="other",
            created="2024-01-01T00:00:00Z",
        )
        f["sensors"] = ring_sensors()
        f["readings"] = readings
    log = read_log(path)
    np.testing.assert_array_equal(log.readings, readings)
    assert log.truth is None and log.poses is None and log.events is None


def _bad_file(tmp_path: Path, case: str) -> Path:
    path = tmp_path / f"{case}.h5"
    if case == "not-hdf5":
        path.write_text("t,tx,rx\n1,2,3\n")
        return path
    _write(path, random_readings(np.random.default_rng(6), 10))
    with h5py.File(path, "r+") as f:
        if case == "wrong-format":
            f.attrs["format"] = "rosbag"
        elif case == "newer-version":
            f.attrs["format_version"] = 2
        elif case == "missing-field":
            data = f["readings"][()]
            del f["readings"]
            names = [n for n in data.dtype.names if n != "tof"]
            f["readings"] = data[names]
        elif case == "missing-attr":
            del f.attrs["speed_of_sound"]
        elif case == "missing-sensors":
            del f["sensors"]
    return path


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("not-hdf5", "not an HDF5 file"),
        ("wrong-format", "format is 'rosbag', expected 'sonarlog'"),
        ("newer-version", "format_version 2 is newer than this reader supports (1)"),
        ("missing-field", "missing required field readings.tof"),
        ("missing-attr", "missing required attribute(s) speed_of_sound"),
        ("missing-sensors", "missing required dataset /sensors"),
    ],
)
def test_bad_input_is_one_line_naming_the_file_and_exit_2(
    tmp_path: Path, case: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _bad_file(tmp_path, case)
    with pytest.raises(InvalidLogError) as info:
        read_log(path)
    assert str(path) in str(info.value)
    assert message in str(info.value)
    assert main(["recover", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("sonarproc: error: ") and message in err
    assert "Traceback" not in err


def test_recover_cli_writes_a_clean_copy(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "run.h5"
    readings = random_readings(np.random.default_rng(7), 1000)
    _write(path, readings, truth=np.ones((4, 2)))
    assert main(["recover", str(path)]) == 0
    out = capsys.readouterr().out
    fixed = tmp_path / "run.recovered.h5"
    assert f"{fixed}: 1000 readings kept, 0 torn row(s) dropped" in out
    log = read_log(fixed)
    np.testing.assert_array_equal(log.readings, readings)
    np.testing.assert_array_equal(log.truth, np.ones((4, 2)))
    assert log.attrs["recovered_from"] == str(path)
    with pytest.raises(ValueError, match="must not overwrite"):
        recover_log(path, path)

"""Readings and truth CSVs through ``sonarproc run`` and ``import``: no echo at max_range,
angle units, an optional turret, several truth polylines; and ``import``'s help and list."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from sonarlog import FLAG_NO_ECHO, read_log
from sonarlog.csvlog import read_csv_log, read_truth_csv
from sonarlog.sources import load_sensors, preset_names
from sonarproc.cli import main

ROOT = Path(__file__).resolve().parents[3]
READINGS = ROOT / "configs/sensors/example-readings.csv"
SENSORS = ROOT / "configs/sensors/example-sensors.yaml"
HEADER = "t,tx,rx,range,x,y,theta,turret\n"


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def _example_with_max_range(tmp_path: Path, every: int = 4) -> tuple[Path, int]:
    """The shipped example, every ``every``-th reading replaced by its sensor's max_range."""
    lg = read_csv_log(READINGS, SENSORS)
    r = lg.readings
    max_range = load_sensors(SENSORS).table["max_range"][0]
    rng = 0.5 * r["tof"] * lg.speed_of_sound
    rng[::every] = max_range
    echo = (r["flags"] & FLAG_NO_ECHO) == 0
    rng[~echo] = 0.0  # the shipped example's own no-echo rows: tof nan, flagged
    rows = np.column_stack([r["t"], r["tx"], r["rx"], rng, r["x"], r["y"], r["theta"], r["flags"]])
    p = tmp_path / "with-max.csv"
    head = "t,tx,rx,range,x,y,theta,flags"
    np.savetxt(p, rows, delimiter=",", header=head, comments="", fmt="%.9g")
    return p, int(echo[::every].sum())


def test_range_at_max_range_is_no_echo_and_counted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    csv, n_max = _example_with_max_range(tmp_path)
    lg = read_csv_log(csv, SENSORS)
    flagged = (lg.readings["flags"] & FLAG_NO_ECHO) != 0
    assert lg.attrs["no_echo_at_max_range"] == n_max > 30
    assert flagged[::4].all()
    n_own = int(((read_csv_log(READINGS, SENSORS).readings["flags"] & FLAG_NO_ECHO) != 0).sum())
    assert int(flagged.sum()) == n_max + n_own
    out = tmp_path / "rep"
    args = ["run", str(csv), "--sensors", str(SENSORS), "--out", str(out), "--fit", "poly"]
    assert main(args) == 0
    shown = capsys.readouterr().out
    counts = json.loads((out / "report.json").read_text())["counts"]
    assert counts["flagged_no_echo"] == n_max + n_own
    skipped = counts["skipped_out_of_range"]
    assert re.search(rf"skipped out of range\s+│?\s*{skipped} \({n_max + n_own} no echo\)", shown)


def test_import_of_a_csv_flags_no_echo(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    csv, n_max = _example_with_max_range(tmp_path)
    out = tmp_path / "log.h5"
    assert main(["import", str(csv), "--sensors", str(SENSORS), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    n_own = int(((read_csv_log(READINGS, SENSORS).readings["flags"] & FLAG_NO_ECHO) != 0).sum())
    assert f"no echo flagged {n_max + n_own}" in err
    assert f"no echo at or beyond max_range: {n_max} reading(s) flagged" in err
    lg = read_log(out)
    assert int(((lg.readings["flags"] & FLAG_NO_ECHO) != 0).sum()) == n_max + n_own


@pytest.mark.parametrize(
    ("theta", "message"),
    [
        (
            "7.0",
            "column 'theta' holds 7 at data row 2, outside +-2 pi rad; degrees? pass --degrees",
        ),
        (
            "4",
            "column 'theta' looks like degrees (whole numbers up to 4, beyond pi); pass "
            "--degrees, or convert it to radians",
        ),
    ],
)
def test_angles_that_cannot_be_radians_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], theta: str, message: str
) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text(HEADER + "0,0,0,1.0,0,0,0,0\n" + f"0.1,0,0,1.0,0,0,{theta},0\n")
    sensors = tmp_path / "s.yaml"
    sensors.write_text(
        "sensors: [{id: 0, x: 0, y: 0, heading: 0, half_beamwidth: 0.2, min_range: 0.1, "
        "max_range: 4}]\n"
    )
    assert main(["run", str(csv), "--sensors", str(sensors), "--out", str(tmp_path / "o")]) == 2
    assert one_error_line(capsys.readouterr().err) == f"sonarproc: error: {csv}: {message}"
    assert not (tmp_path / "o").exists()
    assert (
        main(["import", str(csv), "--sensors", str(sensors), "--out", str(tmp_path / "x.h5")]) == 2
    )
    assert message in one_error_line(capsys.readouterr().err)


def test_turret_in_degrees_is_refused_by_name(tmp_path: Path) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text(HEADER + "0,0,0,1.0,0,0,0,90\n")
    with pytest.raises(ValueError, match=r"column 'turret' holds 90 at data row 1"):
        read_csv_log(csv, SENSORS)


def test_degrees_option_gives_the_radian_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lg = read_csv_log(READINGS, SENSORS)
    r = lg.readings
    deg = tmp_path / "deg.csv"
    rows = np.column_stack(
        [r["t"], r["tx"], r["rx"], r["tof"], r["x"], r["y"], np.degrees(r["theta"]),
         np.degrees(r["turret"]), r["flags"]]
    )  # fmt: skip
    np.savetxt(deg, rows, delimiter=",", header="t,tx,rx,tof,x,y,theta,turret,flags",
               comments="", fmt="%.17g")  # fmt: skip
    docs = []
    for log, extra in ((READINGS, []), (deg, ["--degrees"])):
        out = tmp_path / f"rep-{log.stem}"
        # the metrics are compared, not the figures: none are drawn
        argv = ["run", str(log), "--sensors", str(SENSORS), "--out", str(out), "--json",
                "--figures", "none",
                "--truth", str(ROOT / "configs/sensors/example-truth.csv"), *extra]  # fmt: skip
        assert main(argv) == 0
        docs.append(json.loads((out / "report.json").read_text()))
    capsys.readouterr()
    for key in ("e", "f_c", "E1_m", "E2"):
        assert docs[1]["metrics"][key] == pytest.approx(docs[0]["metrics"][key], rel=1e-9)
    out = tmp_path / "deg.h5"
    argv = ["import", str(deg), "--sensors", str(SENSORS), "--degrees", "--out", str(out)]
    assert main(argv) == 0
    np.testing.assert_allclose(read_log(out).readings["theta"], r["theta"], atol=1e-12)


def test_turret_defaults_to_theta(tmp_path: Path) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text("t,tx,rx,range,x,y,theta\n0,0,0,1.0,0,0,0.5\n0.1,0,0,1.2,0.1,0,-0.25\n")
    lg = read_csv_log(csv, SENSORS)
    assert lg.readings["turret"].tolist() == [0.5, -0.25]


def test_truth_csv_holds_several_polylines(tmp_path: Path) -> None:
    blank = tmp_path / "blank.csv"
    blank.write_text("x,y\n0,0\n1,0\n\n1,0.5\n1,2\n\n\n2,2\n3,2\n")
    nan = tmp_path / "nan.csv"
    nan.write_text("x,y\n0,0\n1,0\nnan,nan\n1,0.5\n1,2\nNaN,NaN\n2,2\n3,2\nnan,nan\n")
    want = [[0, 0], [1, 0], [np.nan] * 2, [1, 0.5], [1, 2], [np.nan] * 2, [2, 2], [3, 2]]
    np.testing.assert_array_equal(read_truth_csv(blank), want)
    np.testing.assert_array_equal(read_truth_csv(nan), want)
    one = tmp_path / "one.csv"
    one.write_text("x,y\n0,0\n1,0\n\n5,5\n")
    with pytest.raises(ValueError, match="polylines of at least 2 finite points"):
        read_truth_csv(one)
    half = tmp_path / "half.csv"
    half.write_text("x,y\n0,0\n1,nan\n")
    with pytest.raises(ValueError, match="both nan to separate polylines"):
        read_truth_csv(half)


def test_truth_polylines_are_stored_with_nan_rows(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    truth = tmp_path / "truth.csv"
    truth.write_text("x,y\n-1,2\n1,2\n\n1,2\n1,0\n")
    out = tmp_path / "log.h5"
    argv = ["import", str(READINGS), "--sensors", str(SENSORS), "--truth", str(truth)]
    assert main([*argv, "--out", str(out)]) == 0
    capsys.readouterr()
    stored = read_log(out).truth
    np.testing.assert_array_equal(stored, [[-1, 2], [1, 2], [np.nan, np.nan], [1, 2], [1, 0]])


def test_import_help_lists_only_presets_that_load(capsys: pytest.CaptureFixture[str]) -> None:
    from sonarproc.cli.import_log import shipped_preset_names

    assert shipped_preset_names() == preset_names()
    assert main(["import", "--help"]) == 0
    text = re.sub(r"[│\s]+", " ", capsys.readouterr().out)
    listed = re.search(r"Mount preset: (.*?), or ring-N\[-R\]", text)
    assert listed is not None, text
    names = [n.strip() for n in listed.group(1).split(",")]
    assert names == preset_names() and "nomad200" not in names
    for name in names:
        assert len(load_sensors(name).table) > 0


def test_import_list_folds_long_names_on_a_narrow_terminal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from bagbuilders import BagWriter

    long_topic = "/robot_with_a_long_namespace/front_sonar_ring/sonar_0/range_filtered"
    bag = tmp_path / "long.bag"
    sensor = load_sensors("pioneer3-dx").table[0]
    with BagWriter(bag, "ros1") as bw:
        for k in range(3):
            t = 1_700_000_000.0 + k
            bw.write("/odom", "nav_msgs/msg/Odometry", t, bw.odometry(t, 0.0, 0.0, 0.0))
            bw.write(long_topic, "sensor_msgs/msg/Range", t, bw.range_msg(t, "s0", sensor, 1.0))
    monkeypatch.setenv("COLUMNS", "60")
    assert main(["import", str(bag), "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert max(len(ln) for ln in lines) <= 60
    first_cells = [ln.split("│")[1].strip() for ln in lines if ln.count("│") >= 2]
    assert long_topic in "".join(first_cells)
    types = "".join(ln.split("│")[2].strip() for ln in lines if ln.count("│") >= 2)
    assert "sensor_msgs/msg/Range" in types or "sensor_msgs/Range" in types

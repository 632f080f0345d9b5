"""Tests for ``sonarproc run`` through ``sonarproc.cli.main``: files, output, exit codes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarlog import FLAG_NO_ECHO, LogWriter
from sonarlog.csvlog import read_csv_log, read_truth_csv
from sonarproc.cli import main
from sonarproc.report.units import sig3

EXAMPLES = Path(__file__).resolve().parents[3] / "configs" / "sensors"
READINGS = EXAMPLES / "example-readings.csv"
SENSORS = EXAMPLES / "example-sensors.yaml"
TRUTH = EXAMPLES / "example-truth.csv"


def write_h5(path: Path, *, mutate: object = None, truth: bool = True) -> Path:
    """The shipped example CSV log as a sonarlog v1 file, optionally altered."""
    lg = read_csv_log(READINGS, SENSORS)
    readings = lg.readings.copy()
    if callable(mutate):
        mutate(readings)
    t = read_truth_csv(TRUTH) if truth else None
    with LogWriter(path, lg.sensors, speed_of_sound=lg.speed_of_sound, truth=t) as w:
        w.append(readings)
    return path


@pytest.fixture(scope="module")
def log_h5(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_h5(tmp_path_factory.mktemp("log") / "scan.h5")


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("sonarproc: error: ")
    assert "Traceback" not in err
    return lines[0]


def test_run_writes_report_and_summary(
    tmp_path: Path, log_h5: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "rep"
    rc = main(["run", str(log_h5), "--out", str(out), "--cell", "0.02", "--order", "6"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    assert "readings used" in captured.out and "E1" in captured.out
    assert captured.err == ""
    doc = json.loads((out / "report.json").read_text())
    assert doc["parameters"]["ops"] == "thinning:3"
    assert doc["fit"]["order"] == 6 and doc["fit"]["ok"] is True
    assert doc["metrics"]["E1_m"] > 0 and doc["metrics"]["t_cpu_s"] > 0
    assert doc["counts"]["skipped_out_of_range"] == 305 - doc["counts"]["readings_used"]
    assert (out / "profile.csv").read_text().startswith("x,y\n")
    xs = np.loadtxt(out / "profile.csv", delimiter=",", skiprows=1)[:, 0]
    assert np.all(np.diff(xs) > 0)
    for name in ("arcmap.png", "processed.png", "fit.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    html = (out / "report.html").read_text()
    assert f"<td>{sig3(doc['metrics']['E2'])}</td>" in html and "thinning:3" in html
    assert f"<td>{sig3(100 * doc['metrics']['E1_m'])} cm</td>" in html


def test_json_goes_to_stdout_and_default_out_dir(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    p = write_h5(tmp_path / "scan.h5")
    rc = main(["run", str(p), "--cell", "0.02", "--json", "--ops", "closing,thinning:4"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc = json.loads(captured.out)
    assert doc["parameters"]["ops"] == "closing,thinning:4"
    assert json.loads((tmp_path / "scan_report" / "report.json").read_text()) == doc


def test_csv_log_with_sensors_and_truth(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["run", str(READINGS), "--sensors", str(SENSORS), "--truth", str(TRUTH)]
    rc = main([*args, "--out", str(tmp_path), "--cell", "0.02", "--fit", "spline", "--json"])
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc = json.loads(captured.out)
    assert doc["fit"]["kind"] == "spline" and doc["metrics"]["E1_m"] is not None
    assert doc["counts"]["readings_total"] == 305


def test_bbox_option_with_negative_numbers(
    tmp_path: Path, log_h5: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(["run", str(log_h5), "--out", str(tmp_path), "--cell", "0.02",
               "--bbox", "-0.5,0.5,0.9,1.6", "--json"])  # fmt: skip
    doc = json.loads(capsys.readouterr().out)
    assert rc == 0
    assert doc["grid"]["x0"] == pytest.approx(-0.5)
    assert doc["parameters"]["bbox"] == [-0.5, 0.5, 0.9, 1.6]


def test_failed_fit_exits_zero_with_a_warning(
    tmp_path: Path, log_h5: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(["run", str(log_h5), "--out", str(tmp_path), "--cell", "0.02", "--order", "40",
               "--ops", "erosion,erosion,erosion,erosion", "--fit", "poly"])  # fmt: skip
    captured = capsys.readouterr()
    assert rc == 0
    assert captured.err.startswith("sonarproc: warning: fit failed")
    assert "FAILED" in captured.out
    assert json.loads((tmp_path / "report.json").read_text())["fit"]["ok"] is False


def _flag_all(r: np.ndarray) -> None:
    r["flags"] |= FLAG_NO_ECHO


def _bad_tof(r: np.ndarray) -> None:
    r["tof"][np.flatnonzero(r["flags"] == 0)[2]] = -1.0


def _nan_tof(r: np.ndarray) -> None:
    r["tof"][np.flatnonzero(r["flags"] == 0)[0]] = np.nan


def _unknown_sensor(r: np.ndarray) -> None:
    r["tx"][4] = 77


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (_flag_all, "all 305 readings are flagged"),
        (_bad_tof, "tof <= 0 or NaN"),
        (_nan_tof, "tof <= 0 or NaN"),
        (_unknown_sensor, "sensor id(s) 77 with no /sensors row"),
        (lambda r: None, None),
    ],
)
def test_bad_logs_exit_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], mutate: object, message: str | None
) -> None:
    p = write_h5(tmp_path / "bad.h5", mutate=mutate)
    rc = main(["run", str(p), "--out", str(tmp_path / "o"), "--cell", "0.02", "--json"])
    captured = capsys.readouterr()
    if message is None:
        assert rc == 0
        return
    assert rc == 2
    assert message in one_error_line(captured.err)
    assert captured.out == ""


def test_empty_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "empty.h5"
    lg = read_csv_log(READINGS, SENSORS)
    with LogWriter(p, lg.sensors):
        pass
    assert main(["run", str(p)]) == 2
    assert "holds no readings" in one_error_line(capsys.readouterr().err)
    csv = tmp_path / "empty.csv"
    csv.write_text("t,tx,rx,tof,x,y,theta,turret\n")
    assert main(["run", str(csv), "--sensors", str(SENSORS)]) == 2
    assert "holds no readings" in one_error_line(capsys.readouterr().err)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--cell", "0"], "cell: must be > 0"),
        (["--cell", "-0.01"], "cell: must be > 0"),
        (["--bbox", "20,21,20,21"], "no arc touches the bbox"),
        (["--bbox", "1,0,0,1"], "xmin < xmax"),
        (["--bbox", "1,2,3"], "bbox: must be 4 comma-separated numbers"),
        (["--ops", "thinning:9"], "thinning:9"),
        (["--ops", "blur"], "unknown morphological operation"),
        (["--fit", "cubic"], "fit: must be one of"),
        (["--order", "-1"], "order: must be between"),
        (["--centre", "1"], "centre: must be 2"),
    ],
)
def test_bad_options_exit_2(
    tmp_path: Path, log_h5: Path, capsys: pytest.CaptureFixture[str], args: list[str],
    message: str,
) -> None:  # fmt: skip
    rc = main(["run", str(log_h5), "--out", str(tmp_path), *args])
    assert rc == 2
    assert message in one_error_line(capsys.readouterr().err)


def test_missing_files_and_csv_without_sensors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", str(tmp_path / "nope.h5")]) == 2
    assert "no such file" in one_error_line(capsys.readouterr().err)
    assert main(["run", str(READINGS)]) == 2
    assert "--sensors: is required for a CSV log" in one_error_line(capsys.readouterr().err)
    assert main(["run", str(READINGS), "--sensors", str(tmp_path / "s.yaml")]) == 2
    assert "no such sensors file" in one_error_line(capsys.readouterr().err)
    notlog = tmp_path / "x.h5"
    notlog.write_bytes(b"not hdf5 at all")
    assert main(["run", str(notlog)]) == 2
    assert "x.h5" in one_error_line(capsys.readouterr().err)


def test_out_dir_under_a_file_is_refused_first(
    tmp_path: Path, log_h5: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["run", str(log_h5), "--out", str(blocker / "sub"), "--cell", "0.02"]) == 2
    one_error_line(capsys.readouterr().err)


def test_delayed_progress_starts_late_and_stops_cleanly() -> None:
    import threading
    import time

    from sonarproc.cli.run import _DelayedProgress

    off = _DelayedProgress(enabled=False)
    off("read")
    off.close()
    bar = _DelayedProgress(enabled=True, delay=0.0)
    deadline = time.monotonic() + 60.0  # a timer thread a loaded machine may start late
    while not bar._started and time.monotonic() < deadline:
        time.sleep(0.01)
    assert bar._started
    for stage in ("read", "rasterise", "report", "not-a-stage"):
        bar(stage)
    bar.close()
    assert bar._progress is None
    late = _DelayedProgress(enabled=True, delay=30.0)
    late.close()  # closed before the delay: never shown, timer cancelled
    assert not late._started
    assert all(
        not isinstance(t, threading.Timer) or not t.is_alive() for t in threading.enumerate()
    )

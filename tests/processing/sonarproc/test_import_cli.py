"""``sonarproc import`` and bags read directly by ``run``, through ``main(argv)``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from bagbuilders import SimRun, sim_run, write_range_bag

from sonarlog import read_log
from sonarproc.cli import main


@pytest.fixture(scope="module")
def run() -> SimRun:
    return sim_run("pioneer3-dx", stops=6, seed=5)


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_import_lists_then_converts_and_refuses_to_overwrite(
    tmp_path: Path, run: SimRun, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "run.bag"
    exp = write_range_bag(bag, "ros1", run)
    assert main(["import", str(bag), "--list"]) == 0
    listing = capsys.readouterr().out
    assert "sonar" in listing and "odometry" in listing
    out = tmp_path / "run.h5"
    assert main(["import", str(bag), "--out", str(out)]) == 0
    capsys.readouterr()
    lg = read_log(out)
    assert len(lg.readings) == len(exp.t)
    assert abs(lg.readings["tof"] * lg.speed_of_sound / 2 - exp.range).max() < 1e-3
    assert main(["import", str(bag), "--out", str(out)]) == 2
    assert "exists already" in one_error_line(capsys.readouterr().err)
    assert main(["import", str(bag), "--out", str(out), "--force"]) == 0


def test_run_reads_a_ros2_bag_directly(
    tmp_path: Path, run: SimRun, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "run-sqlite3"
    write_range_bag(bag, "sqlite3", run)
    rep = tmp_path / "rep"
    args = ["--json", "--cell", "0.02", "--figures", "none"]  # the counts are looked at
    assert main(["run", str(bag), "--out", str(rep), *args]) == 0
    doc = json.loads((rep / "report.json").read_text())
    assert doc["counts"]["readings_used"] > 50 and doc["log_state"] == "closed"


def test_bad_inputs_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(tmp_path)]) == 2
    assert "is a directory" in one_error_line(capsys.readouterr().err)
    junk = tmp_path / "junk.bag"
    junk.write_bytes(b"#ROSBAG V2.0\n" + b"\x00" * 40)
    assert main(["import", str(junk), "--out", str(tmp_path / "x.h5")]) == 2
    assert str(junk) in one_error_line(capsys.readouterr().err)
    assert main(["import", str(junk)]) == 2
    assert "--out is required" in one_error_line(capsys.readouterr().err)


def test_export_rosbag2_replays_the_run(
    tmp_path: Path, run: SimRun, capsys: pytest.CaptureFixture[str]
) -> None:
    from rosbags.highlevel import AnyReader

    bag = tmp_path / "run.bag"
    write_range_bag(bag, "ros1", run)
    out = tmp_path / "exp"
    args = ["export", str(bag), "--format", "rosbag2", "--out", str(out), "--cell", "0.02"]
    assert main(args) == 0
    capsys.readouterr()
    target = out / "morphological_rosbag2"
    with AnyReader([target]) as reader:
        topics = {c.topic: c.msgcount for c in reader.connections}
    assert topics["/map/surfaces"] >= 1
    assert sum(n for t, n in topics.items() if t.startswith("/sonar/")) > 50
    assert main(args) == 2  # the bag exists: refused without --force
    assert "exists" in one_error_line(capsys.readouterr().err)
    assert main([*args, "--force"]) == 0


def test_sweep_takes_a_bag(tmp_path: Path, run: SimRun, capsys: pytest.CaptureFixture[str]) -> None:
    bag = tmp_path / "run.bag"
    write_range_bag(bag, "ros1", run)
    out = tmp_path / "sweep"
    grid = "cell=0.02|0.03;ops=thinning:1"
    assert main(["sweep", str(bag), "--grid", grid, "--jobs", "1", "--out", str(out)]) == 0
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 3 and all("run.bag" in r for r in rows[1:])


def test_watch_once_takes_a_bag(
    tmp_path: Path, run: SimRun, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = tmp_path / "run-sqlite3"
    write_range_bag(bag, "sqlite3", run)
    out = tmp_path / "w"
    assert main(["watch", str(bag), "--once", "--out", str(out), "--cell", "0.02"]) == 0
    doc = json.loads((out / "report.json").read_text())
    assert doc["live"]["writer_closed"] is True and doc["counts"]["readings_used"] > 50


def test_run_a_rosaria_bag_with_a_preset(
    tmp_path: Path, run: SimRun, capsys: pytest.CaptureFixture[str]
) -> None:
    from bagbuilders import write_cloud_bag

    bag = tmp_path / "pioneer.bag"
    write_cloud_bag(bag, "ros1", run)
    out = tmp_path / "rep"
    assert main(["run", str(bag), "--out", str(out)]) == 2  # a cloud has no mounts of its own
    assert str(bag) in one_error_line(capsys.readouterr().err)
    args = ["--robot", "pioneer3-dx", "--json", "--figures", "none"]  # counts looked at
    assert main(["run", str(bag), "--out", str(out), *args]) == 0
    capsys.readouterr()
    assert json.loads((out / "report.json").read_text())["counts"]["readings_used"] > 50
    h5 = tmp_path / "p.h5"
    assert main(["import", str(bag), "--robot", "pioneer3-dx", "--out", str(h5)]) == 0
    capsys.readouterr()
    assert main(["run", str(h5), "--robot", "pioneer3-dx", "--out", str(out)]) == 2
    assert "--robot" in one_error_line(capsys.readouterr().err)

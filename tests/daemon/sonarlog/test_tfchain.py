"""Poses from a tf chain: ``world -> map -> odom -> base_link`` in bags written by rosbags.

A simulated Pioneer run (tests/support/bagbuilders.py) is written as a SLAM-corrected
robot would publish it: the odometry (``odom -> base_link``) drifts, a ``map -> odom``
correction at 2 Hz undoes the drift, and a static ``world -> map`` places the map. The
import with ``pose_frame="world"`` must give back the true poses moved by the static
link; without it, the drifting odometry.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from bagbuilders import T0, BagWriter, SimRun, sim_run

from sonarlog.sources import SourceError, read_source
from sonarlog.sources.tfchain import chain_frames, chain_track
from sonarproc.cli import main

WORLD = (1.0, -2.0, 0.3)  # the static world -> map link: x, y, yaw


def _compose(a: tuple[float, float, float], b: tuple[float, float, float]) -> tuple[float, ...]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]


def _inverse(a: tuple[float, float, float]) -> tuple[float, float, float]:
    c, s = math.cos(a[2]), math.sin(a[2])
    return -c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2]


def _correction(t: float) -> tuple[float, float, float]:
    """map -> odom at time t: a slowly growing drift correction (linear in time)."""
    u = t - T0
    return 0.3 + 0.02 * u, -0.2 + 0.01 * u, 0.05 + 0.004 * u


def _write_slam_bag(path: Path, kind: str, run: SimRun) -> None:
    r = run.readings
    half = 0.5 * r["tof"] * run.speed_of_sound
    by_id = {int(s["id"]): s for s in run.sensors}
    end = float(run.stop_t[-1, 1]) + 1.0
    with BagWriter(path, kind) as bw:
        mounts = [("base_link", f"sonar_{int(s['id'])}", s["x"], s["y"], s["heading"])
                  for s in run.sensors]  # fmt: skip
        static = bw.tf(T0 - 1.0, [*mounts, ("world", "map", *WORLD)])
        bw.write("/tf_static", "tf2_msgs/msg/TFMessage", T0 - 1.0, static)
        for t in np.arange(T0 - 1.0, end, 0.5):
            bw.write("/tf", "tf2_msgs/msg/TFMessage", float(t),
                     bw.tf(float(t), [("map", "odom", *_correction(float(t)))]))  # fmt: skip
        for k, pose in enumerate(run.stop_pose):
            for t in (run.stop_t[k, 0] - 0.002, run.stop_t[k, 1] + 0.005):
                odom = _compose(_inverse(_correction(float(t))), tuple(pose))
                bw.write("/tf", "tf2_msgs/msg/TFMessage", float(t),
                         bw.tf(float(t), [("odom", "base_link", *odom)]))  # fmt: skip
        for i in range(r.size):
            sid, t = int(r["rx"][i]), float(r["t"][i])
            msg = bw.range_msg(t, f"sonar_{sid}", by_id[sid], half[i])
            bw.write(f"/sonar/sonar_{sid}", "sensor_msgs/msg/Range", t, msg)


@pytest.fixture(scope="module")
def run() -> SimRun:
    return sim_run("pioneer3-dx", stops=5)


@pytest.mark.parametrize("kind", ["ros1", "sqlite3"])
def test_poses_in_the_fixed_frame_are_the_composed_chain(
    run: SimRun, kind: str, tmp_path: Path
) -> None:
    bag = tmp_path / ("slam.bag" if kind == "ros1" else "slam")
    _write_slam_bag(bag, kind, run)
    lg, summary = read_source(bag, pose_frame="world")
    r = lg.readings
    order = np.argsort(run.readings["t"], kind="stable")
    truth = run.stop_pose[run.stop[order]]
    expect = np.array([_compose(WORLD, tuple(p)) for p in truth])
    assert r.size == run.readings.size
    np.testing.assert_allclose(r["t"], run.readings["t"][order], atol=1e-6)
    np.testing.assert_allclose(r["x"], expect[:, 0], atol=1e-6)
    np.testing.assert_allclose(r["y"], expect[:, 1], atol=1e-6)
    turn = (r["theta"] - expect[:, 2] + np.pi) % (2 * np.pi) - np.pi
    np.testing.assert_allclose(turn, 0.0, atol=1e-6)
    assert "tf chain world -> base_link" in " ".join(summary.lines())
    # the mounts still come from /tf_static
    mount = {int(s["id"]): (float(s["x"]), float(s["y"])) for s in run.sensors}
    for s in lg.sensors:
        assert (float(s["x"]), float(s["y"])) == pytest.approx(mount[int(s["id"])], abs=1e-6)
    # without a fixed frame: the drifting odometry, tens of centimetres away
    raw, _ = read_source(bag)
    off = np.hypot(raw.readings["x"] - expect[:, 0], raw.readings["y"] - expect[:, 1])
    assert off.min() > 0.3


def test_a_missing_frame_is_one_line_naming_the_frames(run: SimRun, tmp_path: Path) -> None:
    bag = tmp_path / "slam.bag"
    _write_slam_bag(bag, "ros1", run)
    with pytest.raises(SourceError) as err:
        read_source(bag, pose_frame="earth")
    text = str(err.value)
    assert "\n" not in text and "no tf chain from earth to base_link" in text
    assert "map" in text and "odom" in text and "world" in text


def test_cli_import_and_run_take_the_pose_frame(run: SimRun, tmp_path: Path) -> None:
    bag = tmp_path / "slam.bag"
    _write_slam_bag(bag, "ros1", run)
    out = tmp_path / "slam.h5"
    assert main(["import", str(bag), "--out", str(out), "--pose-frame", "map"]) == 0
    rep = tmp_path / "rep"
    args = ["run", str(bag), "--pose-frame", "map", "--out", str(rep), "--figures", "none"]
    assert main([*args, "--json"]) == 0
    assert (rep / "report.json").is_file()
    assert main(["run", str(out), "--pose-frame", "map", "--out", str(tmp_path / "x")]) == 2


def test_chain_track_interpolates_each_link_and_keeps_the_overlap() -> None:
    q = (0.0, 0.0, math.sin(0.25), math.cos(0.25))  # yaw 0.5 rad
    rows = [
        ("map", "odom", 0.0, 1.0, 0.0, (0.0, 0.0, 0.0, 1.0)),
        ("map", "odom", 10.0, 2.0, 0.0, (0.0, 0.0, 0.0, 1.0)),
        *[("odom", "base", float(t), 0.1 * t, 0.0, q) for t in range(-2, 13)],
    ]
    track = chain_track(rows, {}, "map", "base")
    np.testing.assert_allclose(track.t, np.arange(0.0, 11.0))  # inside both links' spans
    np.testing.assert_allclose(track.x, 1.0 + 0.1 * track.t + 0.1 * track.t)
    np.testing.assert_allclose(track.theta, 0.5)
    assert chain_frames(rows, {}, "map", "base") == [("odom", "base", True), ("map", "odom", True)]
    with pytest.raises(SourceError, match="all static"):
        chain_track([], {"base": ("map", 0.0, 0.0, 0.0)}, "map", "base")

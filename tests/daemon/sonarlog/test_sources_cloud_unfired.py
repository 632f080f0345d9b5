"""A RosAria cloud whose rear ring never fires: its points sit at the robot's centre.

A real Pioneer 3-DX bag (RosAria, 8 front sonars, the robot set up with 16) carries the
eight rear points at (0, 0) in every message. They are no readings: before the fix the
import kept each one once, at 0.21-0.26 m, behind its transducer.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from bagbuilders import T0, BagWriter

from sonarlog import FLAG_NO_ECHO
from sonarlog.sources import load_sensors, read_source


def _write(path: Path, kind: str) -> np.ndarray:
    """Five clouds a second apart, the front ring's ranges changing, the rear at (0, 0)."""
    s = load_sensors("pioneer3-dx").table
    front = s["id"] < 8
    rng = np.random.default_rng(11)
    ranges = rng.uniform(0.5, 3.0, size=(5, int(front.sum())))
    with BagWriter(path, kind) as bw:
        for k in range(5):
            t = T0 + k
            for tt in (t - 0.05, t + 0.05):
                bw.write("/RosAria/pose", "nav_msgs/msg/Odometry", tt,
                         bw.odometry(tt, 0.1 * k, 0.0, 0.0))  # fmt: skip
            xy = np.zeros((len(s), 2))
            f = s[front]
            xy[front, 0] = f["x"] + ranges[k] * np.cos(f["heading"])
            xy[front, 1] = f["y"] + ranges[k] * np.sin(f["heading"])
            bw.write("/RosAria/sonar", "sensor_msgs/msg/PointCloud", t, bw.cloud(t, xy))
    return ranges


@pytest.mark.parametrize("kind", ["ros1", "sqlite3"])
def test_points_at_the_robot_centre_are_no_readings(tmp_path: Path, kind: str) -> None:
    bag = tmp_path / ("run.bag" if kind == "ros1" else "run-ros2")
    ranges = _write(bag, kind)
    log, summary = read_source(bag, robot="pioneer3-dx")
    r = log.readings
    # Every front value changed each time: 5 x 8 readings, none from the rear ring.
    assert len(r) == 40
    assert set(np.unique(r["tx"]).tolist()) == set(range(8))
    got = 0.5 * r["tof"] * log.speed_of_sound
    np.testing.assert_allclose(np.sort(got), np.sort(ranges.ravel()), atol=1e-5, rtol=0)
    # The rear points: the first of each is invalid, the 4 x 8 repeats are stale.
    assert summary.counts.invalid_dropped == 8
    assert summary.counts.stale_dropped == 32
    assert summary.counts.values == 80


def test_an_infinite_end_point_is_still_no_echo(tmp_path: Path) -> None:
    """REP 117: a driver may put "no echo" at infinity, even as (+inf, +inf) for a
    transducer facing back and left; that is a reading, not a point behind it."""
    s = load_sensors("pioneer3-dx").table
    xy = np.column_stack((s["x"] + np.cos(s["heading"]), s["y"] + np.sin(s["heading"])))
    xy[13] = np.inf  # transducer 13 (150 degrees): both coordinates at +infinity
    bag = tmp_path / "run.bag"
    with BagWriter(bag, "ros1") as bw:
        for tt in (T0 - 0.05, T0 + 0.05):
            bw.write("/RosAria/pose", "nav_msgs/msg/Odometry", tt, bw.odometry(tt, 0.0, 0.0, 0.0))
        bw.write("/RosAria/sonar", "sensor_msgs/msg/PointCloud", T0, bw.cloud(T0, xy))
    log, summary = read_source(bag, robot="pioneer3-dx")
    r = log.readings
    assert len(r) == 16 and summary.counts.invalid_dropped == 0
    assert (r["flags"][r["tx"] == 13] & FLAG_NO_ECHO).all()
    assert summary.counts.no_echo_flagged == 1

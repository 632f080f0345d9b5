"""Benchmark: importing a 1-hour, 16-sonar bag against rosbags' own iteration of it.

Run with ./scripts/bench. The bag (ROS 1, and ROS 2 sqlite3) holds one hour of a Pioneer
3-DX: 90,000 ``sensor_msgs/Range`` readings on 16 topics (25 per second, a sixth of them
stale repeats), 36,000 ``nav_msgs/Odometry`` poses (10 Hz) and ``/tf_static`` mounts. The
baseline, measured in the same run, is rosbags reading and deserialising the same messages
and doing nothing with them; the ratio is what our decoding, stale detection, pose
interpolation and tof conversion cost on top. Best of 3 each, timed in turns.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from bagbuilders import T0, BagWriter

from sonarlog.sources import load_sensors, read_source

pytestmark = pytest.mark.benchmark

HOUR = 3600.0
RATE = 25.0  # sonar values per second
ODOM_HZ = 10.0


def _write(path: Path, kind: str) -> int:
    rng = np.random.default_rng(7)
    sensors = load_sensors("pioneer3-dx").table
    n = int(HOUR * RATE)
    t = T0 + np.arange(n) / RATE
    sid = np.arange(n) % 16
    value = rng.uniform(0.2, 5.0, n)
    # A sixth of the values repeat their sensor's previous one (RosAria-style stale).
    repeat = rng.random(n) < 1 / 6
    repeat[:16] = False
    value[repeat] = value[np.flatnonzero(repeat) - 16]
    tp = T0 + np.arange(int(HOUR * ODOM_HZ) + 1) / ODOM_HZ
    heading = np.cumsum(rng.normal(0, 0.02, tp.size))
    x = np.cumsum(0.03 * np.cos(heading))
    y = np.cumsum(0.03 * np.sin(heading))
    with BagWriter(path, kind) as bw:
        mounts = [
            ("base_link", f"sonar_{int(s['id'])}", s["x"], s["y"], s["heading"]) for s in sensors
        ]
        bw.write("/tf_static", "tf2_msgs/msg/TFMessage", T0, bw.tf(T0, mounts))
        k = 0
        for i in range(n):
            while k < tp.size and tp[k] <= t[i]:
                bw.write("/odom", "nav_msgs/msg/Odometry", tp[k],
                         bw.odometry(tp[k], x[k], y[k], heading[k]))  # fmt: skip
                k += 1
            s = sensors[sid[i]]
            bw.write(f"/sonar/sonar_{sid[i]}", "sensor_msgs/msg/Range", t[i],
                     bw.range_msg(t[i], f"sonar_{sid[i]}", s, value[i]))  # fmt: skip
        for j in range(k, tp.size):
            bw.write(
                "/odom", "nav_msgs/msg/Odometry", tp[j], bw.odometry(tp[j], x[j], y[j], heading[j])
            )
    return n


def _raw_iteration(path: Path) -> int:
    from rosbags.highlevel import AnyReader

    count = 0
    with AnyReader([path]) as reader:
        for conn, _, data in reader.messages():
            reader.deserialize(data, conn.msgtype)
            count += 1
    return count


@pytest.mark.parametrize("kind", ["ros1", "sqlite3"])
def test_bench_import_hour_bag(tmp_path: Path, kind: str) -> None:
    bag = tmp_path / ("hour.bag" if kind == "ros1" else "hour")
    t0 = time.perf_counter()
    n = _write(bag, kind)
    t_write = time.perf_counter() - t0
    ours, base = math.inf, math.inf
    summary = None
    for _ in range(3):
        t0 = time.perf_counter()
        msgs = _raw_iteration(bag)
        base = min(base, time.perf_counter() - t0)
        t0 = time.perf_counter()
        _, summary = read_source(bag)
        ours = min(ours, time.perf_counter() - t0)
    assert summary is not None and summary.counts.values == n
    assert summary.counts.stale_dropped > 0
    print(
        f"\nimport {kind} 1 h bag: {n} sonar values, {msgs} messages (written in {t_write:.1f} s); "
        f"read_source {ours:.2f} s, rosbags iterate+deserialise {base:.2f} s, "
        f"ratio {ours / base:.2f}; kept {summary.counts.readings}, "
        f"stale dropped {summary.counts.stale_dropped}"
    )

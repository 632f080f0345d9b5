"""Builders of ROS bags and Player logs from simulated sonar runs, for the import tests.

A :class:`SimRun` is a sonarsim run of a Pioneer-like robot (a shipped preset's mounts):
readings grouped into *stops* (one pose each). The writers turn it into the message layout
a real driver would produce, with stale repeats, and return what an import must give back.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonarlog.sources import load_sensors
from sonarsim import scenario_from_dict, simulate
from sonarsim.shipped import shipped_dir

T0 = 1_700_000_000.0


@dataclass(frozen=True)
class SimRun:
    """Simulated readings (own echoes, first echo only) and the stops they belong to."""

    sensors: np.ndarray  # SENSOR_DTYPE
    readings: np.ndarray  # READING_DTYPE, t from T0
    stop: np.ndarray  # stop index of each reading
    stop_pose: np.ndarray  # (S, 3) x, y, theta
    stop_t: np.ndarray  # (S, 2) first and last firing time of each stop
    speed_of_sound: float


def sim_run(preset: str = "pioneer3-dx", *, stops: int = 6, seed: int = 3) -> SimRun:
    """A robot with ``preset``'s sonars visiting ``stops`` locations x 3 headings in the lab."""
    table = load_sensors(preset).table
    spec = {
        "world": "lab.yaml",
        "array": {
            "type": "explicit",
            "sensors": [
                {"x": float(s["x"]), "y": float(s["y"]),
                 "heading_deg": math.degrees(float(s["heading"])), "id": int(s["id"])}
                for s in table
            ],
        },
        "sensor": {
            "half_beamwidth_deg": math.degrees(float(table["half_beamwidth"][0])),
            "min_range": float(table["min_range"][0]), "max_range": float(table["max_range"][0]),
        },
        "path": {
            "locations": {"start": [-1.0, 0.0], "end": [1.0, 0.5], "count": stops},
            "theta_deg": [0.0, 75.0, 178.0],
        },
        "first_echo_only": True,
        "seed": seed,
        "timing": {"start_time": T0, "firing_interval_s": 0.04},
        "imperfections": {"range_noise_sigma": 0.004},
    }  # fmt: skip
    res = simulate(scenario_from_dict(spec, base_dir=shipped_dir("worlds")))
    r = res.readings
    n = len(table)
    fire = np.round((r["t"] - T0) / 0.04).astype(np.int64)
    stop = fire // n
    n_stops = int(stop.max()) + 1
    pose = np.zeros((n_stops, 3))
    pose[stop] = np.column_stack([r["x"], r["y"], r["theta"]])
    first = T0 + np.arange(n_stops) * n * 0.04
    st = np.column_stack([first, first + (n - 1) * 0.04])
    return SimRun(np.asarray(res.sensors), r, stop, pose, st, res.speed_of_sound)


class BagWriter:
    """Write ROS 1 (``ros1``) or ROS 2 (``sqlite3``, ``mcap``) bags with rosbags' writers."""

    def __init__(self, path: Path, kind: str) -> None:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.kind = kind
        if kind == "ros1":
            from rosbags.rosbag1 import Writer as W1

            self.store = get_typestore(Stores.ROS1_NOETIC)
            self.store.register(get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            ))  # fmt: skip
            self.writer: Any = W1(path)
        else:
            from rosbags.rosbag2 import StoragePlugin
            from rosbags.rosbag2 import Writer as W2

            self.store = get_typestore(Stores.ROS2_HUMBLE)
            plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
            self.writer = W2(path, version=9, storage_plugin=plugin)
        self.T = self.store.types
        self.conns: dict[str, Any] = {}

    def __enter__(self) -> BagWriter:
        self.writer.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.writer.close()

    def write(self, topic: str, msgtype: str, t: float, msg: Any) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.store)
        ser = self.store.serialize_ros1 if self.kind == "ros1" else self.store.serialize_cdr
        self.writer.write(self.conns[topic], round(t * 1e9), ser(msg, msgtype))

    # -- messages ------------------------------------------------------------------

    def header(self, t: float, frame: str) -> Any:
        ns = round(t * 1e9)
        stamp = self.T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        if self.kind == "ros1":
            return self.T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
        return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def quat(self, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)
        )

    def pose(self, x: float, y: float, yaw: float) -> Any:
        pt = self.T["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0)
        return self.T["geometry_msgs/msg/Pose"](position=pt, orientation=self.quat(yaw))

    def range_msg(self, t: float, frame: str, s: np.void, value: float, kind: int = 0) -> Any:
        return self.T["sensor_msgs/msg/Range"](
            header=self.header(t, frame), radiation_type=kind,
            field_of_view=float(2 * s["half_beamwidth"]), min_range=float(s["min_range"]),
            max_range=float(s["max_range"]), range=float(value),
        )  # fmt: skip

    def odometry(self, t: float, x: float, y: float, yaw: float) -> Any:
        T = self.T
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        return T["nav_msgs/msg/Odometry"](
            header=self.header(t, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=self.pose(x, y, yaw), covariance=np.zeros(36)
            ),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                covariance=np.zeros(36),
            ),
        )  # fmt: skip

    def pose_stamped(self, t: float, x: float, y: float, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/PoseStamped"](
            header=self.header(t, "odom"), pose=self.pose(x, y, yaw)
        )

    def tf(self, t: float, items: list[tuple[str, str, float, float, float]]) -> Any:
        T = self.T
        trs = [
            T["geometry_msgs/msg/TransformStamped"](
                header=self.header(t, parent), child_frame_id=child,
                transform=T["geometry_msgs/msg/Transform"](
                    translation=T["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=0.0),
                    rotation=self.quat(yaw),
                ),
            )
            for parent, child, x, y, yaw in items
        ]  # fmt: skip
        return T["tf2_msgs/msg/TFMessage"](transforms=trs)

    def cloud(self, t: float, xy: np.ndarray) -> Any:
        pts = [self.T["geometry_msgs/msg/Point32"](x=float(a), y=float(b), z=0.0) for a, b in xy]
        return self.T["sensor_msgs/msg/PointCloud"](
            header=self.header(t, "base_link"), points=pts, channels=[]
        )

    def cloud2(self, t: float, xy: np.ndarray) -> Any:
        T = self.T
        data = np.zeros(len(xy), dtype=[("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("pad", "<f4")])
        data["x"], data["y"] = xy[:, 0], xy[:, 1]
        fields = [T["sensor_msgs/msg/PointField"](name=n, offset=4 * k, datatype=7, count=1)
                  for k, n in enumerate("xyz")]  # fmt: skip
        return T["sensor_msgs/msg/PointCloud2"](
            header=self.header(t, "base_link"), height=1, width=len(xy), fields=fields,
            is_bigendian=False, point_step=16, row_step=16 * len(xy),
            data=data.view(np.uint8).copy(), is_dense=True,
        )  # fmt: skip


@dataclass(frozen=True)
class Expected:
    """What an import of a built bag must give: readings (t, id, range, flags) and counts."""

    t: np.ndarray
    sensor: np.ndarray
    range: np.ndarray
    flags: np.ndarray
    pose: np.ndarray  # (N, 3) x, y, theta
    stale: int


def _odometry(bw: BagWriter, run: SimRun, odom: str) -> None:
    for k, (x, y, th) in enumerate(run.stop_pose):
        for t in (run.stop_t[k, 0] - 0.002, run.stop_t[k, 1] + 0.005):
            if odom == "odometry":
                bw.write("/odom", "nav_msgs/msg/Odometry", t, bw.odometry(t, x, y, th))
            elif odom == "posestamped":
                bw.write(
                    "/robot_pose", "geometry_msgs/msg/PoseStamped", t, bw.pose_stamped(t, x, y, th)
                )
            else:
                bw.write(
                    "/tf", "tf2_msgs/msg/TFMessage", t, bw.tf(t, [("odom", "base_link", x, y, th)])
                )


def write_range_bag(
    path: Path, kind: str, run: SimRun, *, odom: str = "odometry", stale_every: int = 3,
    one_topic: bool = False,
) -> Expected:  # fmt: skip
    """Range messages (a topic per sonar, or one topic), /tf_static mounts, stale repeats.

    After each stop every ``stale_every``-th sensor that fired republishes its last value.
    """
    r = run.readings
    half = 0.5 * r["tof"] * run.speed_of_sound
    by_id = {int(s["id"]): s for s in run.sensors}
    stale = 0
    with BagWriter(path, kind) as bw:
        mounts = [
            ("base_link", f"sonar_{int(s['id'])}", s["x"], s["y"], s["heading"])
            for s in run.sensors
        ]
        bw.write("/tf_static", "tf2_msgs/msg/TFMessage", T0 - 1.0, bw.tf(T0 - 1.0, mounts))
        _odometry(bw, run, odom)
        for k in range(len(run.stop_pose)):
            idx = np.flatnonzero(run.stop == k)
            for i in idx:
                sid = int(r["rx"][i])
                topic = "/sonar" if one_topic else f"/sonar/sonar_{sid}"
                bw.write(topic, "sensor_msgs/msg/Range", r["t"][i],
                         bw.range_msg(r["t"][i], f"sonar_{sid}", by_id[sid], half[i]))  # fmt: skip
            for j, i in enumerate(idx[::stale_every]):
                sid = int(r["rx"][i])
                t = run.stop_t[k, 1] + 0.001 + 0.0001 * j
                topic = "/sonar" if one_topic else f"/sonar/sonar_{sid}"
                bw.write(topic, "sensor_msgs/msg/Range", t,
                         bw.range_msg(t, f"sonar_{sid}", by_id[sid], half[i]))  # fmt: skip
                stale += 1
    f32 = half.astype(np.float32).astype(np.float64)
    pose = run.stop_pose[run.stop]
    return Expected(r["t"], r["rx"].astype(np.int64), f32, np.zeros(len(r), np.uint16), pose, stale)


def write_cloud_bag(path: Path, kind: str, run: SimRun, *, cloud2: bool = False) -> Expected:
    """One cloud per stop (RosAria style): every sonar each time, unfired ones repeating.

    A sonar with no value yet reports its maximum range (no echo).
    """
    s = run.sensors
    n = len(s)
    r = run.readings
    half = 0.5 * r["tof"] * run.speed_of_sound
    current = np.array(s["max_range"], dtype=np.float64)
    have = np.zeros(n, dtype=bool)
    exp_t: list[float] = []
    exp_s: list[int] = []
    exp_r: list[float] = []
    exp_f: list[int] = []
    exp_p: list[np.ndarray] = []
    stale = 0
    row_of = {int(v): k for k, v in enumerate(s["id"])}
    with BagWriter(path, kind) as bw:
        _odometry(bw, run, "odometry")
        for k in range(len(run.stop_pose)):
            t = float(run.stop_t[k, 1])
            fresh = np.zeros(n, dtype=bool)
            for i in np.flatnonzero(run.stop == k):
                j = row_of[int(r["rx"][i])]
                current[j] = half[i]
                fresh[j] = True
            first = ~have & ~fresh
            xy = np.column_stack([s["x"] + current * np.cos(s["heading"]),
                                  s["y"] + current * np.sin(s["heading"])])  # fmt: skip
            xy32 = xy.astype(np.float32).astype(np.float64)
            rng = np.hypot(xy32[:, 0] - s["x"], xy32[:, 1] - s["y"])
            for j in np.flatnonzero(fresh | first):
                exp_t.append(t)
                exp_s.append(int(s["id"][j]))
                exp_r.append(float(rng[j]))
                exp_f.append(1 if first[j] else 0)
                exp_p.append(run.stop_pose[k])
            stale += int((~fresh & have).sum())
            have |= fresh | first
            msg = bw.cloud2(t, xy) if cloud2 else bw.cloud(t, xy)
            typ = "sensor_msgs/msg/PointCloud2" if cloud2 else "sensor_msgs/msg/PointCloud"
            bw.write("/RosAria/sonar", typ, t, msg)
    return Expected(np.array(exp_t), np.array(exp_s), np.array(exp_r), np.array(exp_f, np.uint16),
                    np.array(exp_p).reshape(-1, 3), stale)  # fmt: skip


def write_player_log(path: Path, run: SimRun) -> Expected:
    """A Player writelog file: geometry, a ranges line per stop (all sonars), odometry."""
    s = run.sensors
    n = len(s)
    r = run.readings
    half = 0.5 * r["tof"] * run.speed_of_sound
    current = np.array(s["max_range"], dtype=np.float64)
    last_written = np.full(n, np.nan)
    lines = ["## Player version 3.0.2 ", "## File version 0.3.0 "]
    geom = " ".join(
        f"{x:+07.3f} {y:+07.3f} {a:+07.4f}"
        for x, y, a in zip(s["x"], s["y"], s["heading"], strict=True)
    )
    lines.append(f"{T0:014.3f} 16777343 6665 sonar 00 004 001 {n} {geom} ")
    exp: list[tuple[float, int, float, int, np.ndarray]] = []
    stale = 0
    row_of = {int(v): k for k, v in enumerate(s["id"])}
    for k, (x, y, th) in enumerate(run.stop_pose):
        for t in (run.stop_t[k, 0] - 0.002, run.stop_t[k, 1] + 0.005):
            lines.append(f"{t:014.3f} 16777343 6665 position2d 00 001 001 "
                         f"{x:+07.3f} {y:+07.3f} {th:+04.3f} +0.000 +0.000 +0.000 0")  # fmt: skip
        t = float(run.stop_t[k, 1])
        for i in np.flatnonzero(run.stop == k):
            current[row_of[int(r["rx"][i])]] = half[i]
        text = [f"{v:.3f}" for v in current]
        vals = np.array([float(v) for v in text])
        for j in range(n):
            if np.isnan(last_written[j]) or vals[j] != last_written[j]:
                flag = 1 if vals[j] >= s["max_range"][j] - 5e-4 else 0
                exp.append((t, int(s["id"][j]), vals[j], flag, np.round(run.stop_pose[k], 3)))
            else:
                stale += 1
        last_written = vals
        lines.append(f"{t:014.3f} 16777343 6665 sonar 00 001 001 {n} {' '.join(text)} ")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    cols = list(zip(*exp, strict=True))
    return Expected(
        np.array(cols[0]),
        np.array(cols[1]),
        np.array(cols[2]),
        np.array(cols[3], np.uint16),
        np.array(cols[4]).reshape(-1, 3),
        stale,
    )

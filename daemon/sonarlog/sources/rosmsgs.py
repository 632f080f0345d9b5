"""Decoders of the ROS messages a sonar import reads, each into flat numpy-ready lists.

Every collector takes deserialised messages (rosbags' dataclasses, ROS 1 or ROS 2 alike)
one at a time and keeps only numbers; :mod:`sonarlog.sources.assemble` does the array work.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog.sources.poses import PoseTrack, yaw_from_quaternion

__all__ = [
    "POSE_TYPES",
    "SONAR_TYPES",
    "TF_TYPES",
    "CloudCollector",
    "PoseCollector",
    "RangeCollector",
    "StaticTransforms",
    "stamp_of",
]

#: Sonar message types and the style name of each.
SONAR_TYPES = {
    "sensor_msgs/msg/Range": "range",
    "sensor_msgs/msg/PointCloud": "pointcloud",
    "sensor_msgs/msg/PointCloud2": "pointcloud2",
}
#: Message types that carry the robot's pose on a topic of their own.
POSE_TYPES = (
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
)
#: Transform message types (ROS 2 / ROS 1 tf2, and ROS 1's older tf).
TF_TYPES = ("tf2_msgs/msg/TFMessage", "tf/msg/tfMessage")

_INFRARED = 1
_PC2_DTYPES = {1: "i1", 2: "u1", 3: "i2", 4: "u2", 5: "i4", 6: "u4", 7: "f4", 8: "f8"}


def stamp_of(header: Any, fallback_ns: int) -> float:
    """A header's stamp in seconds (rosbags names the fields ``sec/nanosec`` for ROS 1 too).

    A zero stamp (a driver that never set it) falls back to the bag's receive time.
    """
    st = header.stamp
    sec, nsec = int(st.sec), int(st.nanosec)
    if sec == 0 and nsec == 0:
        return fallback_ns * 1e-9
    return sec + nsec * 1e-9


def _decimal(value: float) -> float:
    """A float32 field as the shortest decimal that rounds to it (0.1, not 0.100000001)."""
    return float(str(np.float32(value)))


@dataclass
class RangeCollector:
    """``sensor_msgs/Range`` messages: one value each, named by frame and topic."""

    t: list[float] = field(default_factory=list)
    topic: list[str] = field(default_factory=list)
    frame: list[str] = field(default_factory=list)
    range: list[float] = field(default_factory=list)
    infrared: int = 0
    beams: dict[tuple[str, str], tuple[float, float, float]] = field(default_factory=dict)

    def add(self, msg: Any, topic: str, bag_ns: int) -> None:
        """Record one message (infrared rangers are counted and skipped)."""
        if msg.radiation_type == _INFRARED:
            self.infrared += 1
            return
        frame = msg.header.frame_id.lstrip("/")
        self.t.append(stamp_of(msg.header, bag_ns))
        self.topic.append(topic)
        self.frame.append(frame)
        self.range.append(msg.range)
        self.beams.setdefault(
            (topic, frame),
            (_decimal(msg.field_of_view), _decimal(msg.min_range), _decimal(msg.max_range)),
        )


@dataclass
class CloudCollector:
    """``PointCloud`` / ``PointCloud2`` sonar end points (x, y in the robot frame)."""

    t: list[float] = field(default_factory=list)
    xy: list[npt.NDArray[np.float64]] = field(default_factory=list)
    frames: set[str] = field(default_factory=set)

    def add(self, msg: Any, topic: str, bag_ns: int) -> None:
        """Record one cloud's points, in the order the message lists them."""
        self.t.append(stamp_of(msg.header, bag_ns))
        self.frames.add(msg.header.frame_id.lstrip("/"))
        if hasattr(msg, "points"):
            pts = msg.points
            self.xy.append(np.array([(p.x, p.y) for p in pts], dtype=np.float64).reshape(-1, 2))
        else:
            self.xy.append(_cloud2_xy(msg))


def _cloud2_xy(msg: Any) -> npt.NDArray[np.float64]:
    offsets = {f.name: (f.offset, f.datatype) for f in msg.fields}
    if "x" not in offsets or "y" not in offsets:
        raise ValueError("PointCloud2 without x and y fields")
    order = ">" if msg.is_bigendian else "<"
    n = int(msg.width) * int(msg.height)
    names = ["x", "y"]
    dtype = np.dtype(
        {
            "names": names,
            "formats": [order + _PC2_DTYPES[offsets[k][1]] for k in names],
            "offsets": [offsets[k][0] for k in names],
            "itemsize": int(msg.point_step),
        }
    )
    raw = np.frombuffer(bytes(msg.data), dtype=dtype, count=n)
    return np.column_stack([raw["x"], raw["y"]]).astype(np.float64)


@dataclass
class PoseCollector:
    """Robot poses from Odometry, PoseStamped or the dynamic tf (odom -> base)."""

    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    q: list[tuple[float, float, float, float]] = field(default_factory=list)
    child_frame: str = ""
    tf_pairs: dict[tuple[str, str], int] = field(default_factory=dict)
    tf_rows: list[tuple[str, str, float, float, float, tuple[float, float, float, float]]] = field(
        default_factory=list
    )

    def add(self, msg: Any, topic: str, bag_ns: int) -> None:
        """Record one pose message, or every transform of a tf message."""
        if hasattr(msg, "transforms"):
            for tr in msg.transforms:
                pair = (tr.header.frame_id.lstrip("/"), tr.child_frame_id.lstrip("/"))
                self.tf_pairs[pair] = self.tf_pairs.get(pair, 0) + 1
                tl, r = tr.transform.translation, tr.transform.rotation
                self.tf_rows.append(
                    (*pair, stamp_of(tr.header, bag_ns), tl.x, tl.y, (r.x, r.y, r.z, r.w))
                )
            return
        pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
        if not self.child_frame:
            self.child_frame = getattr(msg, "child_frame_id", "").lstrip("/")
        self.t.append(stamp_of(msg.header, bag_ns))
        self.x.append(pose.position.x)
        self.y.append(pose.position.y)
        o = pose.orientation
        self.q.append((o.x, o.y, o.z, o.w))

    def odom_pair(self) -> tuple[str, str] | None:
        """The (parent, child) transform that is the robot's odometry, if the tf has one."""
        cands = [
            p for p in self.tf_pairs if p[0].split("/")[-1].endswith("odom")
            and p[1].split("/")[-1].startswith("base")
        ]  # fmt: skip
        if not cands:
            return None
        return max(cands, key=lambda p: (p[1].endswith("base_link"), self.tf_pairs[p]))

    def track(self) -> PoseTrack:
        """The poses as a track (from the tf's odometry pair when no pose topic was read)."""
        if self.t:
            q = np.array(self.q, dtype=np.float64).reshape(-1, 4)
            yaw = yaw_from_quaternion(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
            return PoseTrack.of(self.t, self.x, self.y, yaw)
        pair = self.odom_pair()
        if pair is None:
            return PoseTrack.of([], [], [], [])
        self.child_frame = pair[1]
        rows = [r for r in self.tf_rows if (r[0], r[1]) == pair]
        q = np.array([r[5] for r in rows], dtype=np.float64).reshape(-1, 4)
        yaw = yaw_from_quaternion(q[:, 0], q[:, 1], q[:, 2], q[:, 3])
        return PoseTrack.of([r[2] for r in rows], [r[3] for r in rows], [r[4] for r in rows], yaw)


@dataclass
class StaticTransforms:
    """``/tf_static``: each child frame's parent and 2-D offset (x, y, yaw)."""

    parent: dict[str, tuple[str, float, float, float]] = field(default_factory=dict)

    def add(self, msg: Any, topic: str, bag_ns: int) -> None:
        """Record every transform of a static tf message."""
        for tr in msg.transforms:
            tl, r = tr.transform.translation, tr.transform.rotation
            yaw = float(yaw_from_quaternion(r.x, r.y, r.z, r.w))
            self.parent[tr.child_frame_id.lstrip("/")] = (
                tr.header.frame_id.lstrip("/"), float(tl.x), float(tl.y), yaw,
            )  # fmt: skip

    def mount(self, frame: str, base: str) -> tuple[float, float, float] | None:
        """Pose ``(x, y, yaw)`` of ``frame`` in ``base`` (or in its tree's root), or None."""
        if frame not in self.parent:
            return None
        x, y, yaw = 0.0, 0.0, 0.0
        node, seen = frame, set()
        while node in self.parent and node != base and node not in seen:
            seen.add(node)
            par, px, py, pyaw = self.parent[node]
            # Compose: the child's pose expressed in the parent's frame.
            c, s = math.cos(pyaw), math.sin(pyaw)
            x, y, yaw = px + c * x - s * y, py + s * x + c * y, pyaw + yaw
            node = par
        return x, y, math.atan2(math.sin(yaw), math.cos(yaw))

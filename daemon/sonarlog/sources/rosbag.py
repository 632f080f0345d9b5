"""ROS 1 bags and ROS 2 bags (sqlite3 or mcap) read with ``rosbags``, no ROS needed.

Which topics are used, unless the caller names them:

* sonar: the ``sensor_msgs/Range`` topics (ultrasonic ones; one transducer per frame, or
  per topic when frames repeat); else the ``PointCloud``/``PointCloud2`` topic with
  ``sonar`` in its name and the most messages (RosAria's ``/RosAria/sonar``);
* poses: the ``nav_msgs/Odometry`` topic (a name with ``odom`` or ``pose`` first), else a
  ``PoseStamped`` topic, else the ``odom -> base_link`` transform on ``/tf``;
* mounts of Range transducers: ``/tf_static`` (frame -> robot base), unless a robot preset
  or sensors file is given. Point clouds carry no mounts: they need a preset or file;
* with a fixed frame (``pose_frame``, e.g. ``map``): the poses of the robot's base frame
  in it, composed along the tf chain (``map -> odom -> base_link``, static links from
  ``/tf_static``; :mod:`sonarlog.sources.tfchain`).
"""

from __future__ import annotations

import fnmatch
import re
import sqlite3
import struct
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sonarlog.schema import SENSOR_DTYPE
from sonarlog.sources.assemble import RawValues
from sonarlog.sources.errors import SourceError
from sonarlog.sources.poses import PoseTrack
from sonarlog.sources.presets import SensorSet
from sonarlog.sources.rosmsgs import (
    POSE_TYPES,
    SONAR_TYPES,
    TF_TYPES,
    CloudCollector,
    PoseCollector,
    RangeCollector,
    StaticTransforms,
)
from sonarlog.sources.stale import value_key
from sonarlog.sources.summary import ImportOptions, TopicRow

__all__ = ["BagContent", "bag_format", "is_ros1_bag", "is_ros2_bag", "list_bag", "read_bag"]

ROS1_MAGIC = b"#ROSBAG V2.0\n"
_TRAILING_INT = re.compile(r"(\d+)$")


def is_ros1_bag(path: Path) -> bool:
    """True for a file that starts with the ROS 1 bag magic."""
    try:
        with path.open("rb") as fh:
            return fh.read(len(ROS1_MAGIC)) == ROS1_MAGIC
    except OSError:
        return False


def _ros2_root(path: Path) -> Path | None:
    if path.is_dir() and (path / "metadata.yaml").is_file():
        return path
    if path.is_file() and (
        path.name == "metadata.yaml" or path.suffix in (".db3", ".mcap")
    ) and (path.parent / "metadata.yaml").is_file():  # fmt: skip
        return path.parent
    return None


def is_ros2_bag(path: Path) -> bool:
    """True for a ROS 2 bag directory (or its ``metadata.yaml``, ``.db3`` or ``.mcap``)."""
    return _ros2_root(path) is not None


def bag_format(path: Path) -> str:
    """``ros1``, ``ros2-sqlite3`` or ``ros2-mcap``."""
    root = _ros2_root(path)
    if root is None:
        return "ros1"
    return "ros2-mcap" if any(root.glob("*.mcap")) else "ros2-sqlite3"


def _first_line(err: BaseException) -> str:
    return (str(err).strip().splitlines() or [type(err).__name__])[0][:200]


_READ_ERRORS: tuple[type[BaseException], ...] = (
    OSError, ValueError, KeyError, IndexError, struct.error, EOFError, sqlite3.Error,
    AssertionError, TypeError, AttributeError,
)  # fmt: skip


def _rosbags_errors() -> tuple[type[BaseException], ...]:
    from rosbags.highlevel import AnyReaderError
    from rosbags.rosbag1 import ReaderError as Reader1Error
    from rosbags.rosbag2 import ReaderError as Reader2Error
    from rosbags.serde import SerdeError

    return (AnyReaderError, Reader1Error, Reader2Error, SerdeError, *_READ_ERRORS)


@contextmanager
def _open(path: Path) -> Iterator[Any]:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    root = _ros2_root(path) or path
    errors = _rosbags_errors()
    try:
        reader = AnyReader([root], default_typestore=get_typestore(Stores.LATEST))
        reader.open()
    except errors as err:
        raise SourceError(f"{path}: truncated or unreadable bag ({_first_line(err)})") from err
    try:
        if reader.message_count == 0:
            raise SourceError(f"{path}: empty bag (it holds no messages)")
        yield reader
    finally:
        reader.close()


@dataclass(frozen=True)
class _Choice:
    sonar: list[str]
    style: str
    odom: str
    odom_kind: str  # "pose" or "tf"
    static: list[str]


def _topics(reader: Any) -> dict[str, tuple[str, int]]:
    return {name: (info.msgtype or "", int(info.msgcount)) for name, info in reader.topics.items()}


def _match(pattern: str, names: list[str]) -> list[str]:
    pats = [p.strip() for p in pattern.split(",") if p.strip()]
    return sorted(n for n in names if any(n == p or fnmatch.fnmatchcase(n, p) for p in pats))


def _choose_sonar(
    path: Path, topics: dict[str, tuple[str, int]], want: str | None
) -> tuple[list[str], str]:
    names = sorted(topics)
    if want:
        chosen = _match(want, names)
        if not chosen:
            raise SourceError(
                f"{path}: no sonar topic matches {want!r} (topics: {', '.join(names)})"
            )
        styles = {SONAR_TYPES.get(topics[n][0]) for n in chosen}
        bad = [n for n in chosen if topics[n][0] not in SONAR_TYPES]
        if bad:
            raise SourceError(
                f"{path}: topic {bad[0]} has message type {topics[bad[0]][0]}, not a sonar type "
                f"({', '.join(SONAR_TYPES)})"
            )
        if len(styles) > 1:
            raise SourceError(f"{path}: the sonar topics {', '.join(chosen)} mix message types")
        return chosen, str(styles.pop())
    ranges = [n for n in names if SONAR_TYPES.get(topics[n][0]) == "range"]
    if ranges:
        return ranges, "range"
    clouds = [
        n for n in names
        if SONAR_TYPES.get(topics[n][0], "").startswith("pointcloud")
        and any(w in n.lower() for w in ("sonar", "ultrasonic", "sonic"))
    ]  # fmt: skip
    if clouds:
        best = max(clouds, key=lambda n: topics[n][1])
        return [best], SONAR_TYPES[topics[best][0]]
    raise SourceError(
        f"{path}: no sonar topic (sensor_msgs/Range, or a PointCloud/PointCloud2 named "
        f"*sonar*); topics: {', '.join(names) or 'none'}"
    )


def _choose_odom(
    path: Path, topics: dict[str, tuple[str, int]], want: str | None
) -> tuple[str, str]:
    if want:
        if want not in topics:
            raise SourceError(
                f"{path}: no odometry topic {want!r} (topics: {', '.join(sorted(topics))})"
            )
        kind = topics[want][0]
        if kind in POSE_TYPES:
            return want, "pose"
        if kind in TF_TYPES:
            return want, "tf"
        raise SourceError(
            f"{path}: topic {want} has message type {kind}, not an odometry type "
            f"({', '.join(POSE_TYPES)} or tf)"
        )
    for kind in POSE_TYPES:
        cands = [n for n, (t, c) in topics.items() if t == kind and c > 0]
        if cands:
            return max(
                cands,
                key=lambda n: (any(w in n.lower() for w in ("odom", "pose")), topics[n][1], n),
            ), "pose"
    tfs = [
        n
        for n, (t, c) in topics.items()
        if t in TF_TYPES and n.rstrip("/").endswith("tf") and c > 0
    ]
    if tfs:
        return sorted(tfs)[0], "tf"
    raise SourceError(
        f"{path}: no odometry (nav_msgs/Odometry, geometry_msgs/PoseStamped, or odom -> "
        f"base_link on /tf); topics: {', '.join(sorted(topics))}"
    )


def _tf_topic(path: Path, topics: dict[str, tuple[str, int]], want: str | None) -> str:
    """The dynamic tf topic a chain is read from (``want``, or the one named ``tf``)."""
    if want is not None:
        if want not in topics or topics[want][0] not in TF_TYPES:
            raise SourceError(f"{path}: --pose-frame reads a tf topic; {want} is not one")
        return want
    tfs = sorted(
        n for n, (t, c) in topics.items()
        if t in TF_TYPES and n.rstrip("/").endswith("tf") and c > 0
    )  # fmt: skip
    if not tfs:
        raise SourceError(f"{path}: --pose-frame needs a /tf topic; topics: {', '.join(topics)}")
    return tfs[0]


def _choose(path: Path, topics: dict[str, tuple[str, int]], opts: ImportOptions) -> _Choice:
    sonar, style = _choose_sonar(path, topics, opts.sonar_topic)
    if opts.pose_frame:
        odom, kind = _tf_topic(path, topics, opts.odom_topic), "chain"
    else:
        odom, kind = _choose_odom(path, topics, opts.odom_topic)
    static = [n for n, (t, _) in topics.items() if t in TF_TYPES and n.endswith("tf_static")]
    # static links: the Range mounts, and any link of a tf chain (base_footprint -> base_link)
    return _Choice(sonar, style, odom, kind, static if style == "range" or opts.pose_frame else [])


def list_bag(path: Path) -> list[TopicRow]:
    """Every topic of a bag with its type, count, and whether an import would use it."""
    with _open(path) as reader:
        topics = _topics(reader)
    roles: dict[str, tuple[str, str]] = {}
    try:
        sonar, style = _choose_sonar(path, topics, None)
        why = (
            "sensor_msgs/Range, one transducer per frame"
            if style == "range"
            else "sonar point cloud"
        )
        roles.update({n: ("sonar", why) for n in sonar})
    except SourceError:
        pass
    try:
        odom, kind = _choose_odom(path, topics, None)
        roles[odom] = ("odometry", "odom -> base transform" if kind == "tf" else topics[odom][0])
    except SourceError:
        pass
    if any(r[0] == "sonar" and topics[n][0].endswith("Range") for n, r in roles.items()):
        for n, (t, _) in topics.items():
            if t in TF_TYPES and n.endswith("tf_static"):
                roles[n] = ("mounts", "base -> sonar frame transforms")
    rows = []
    for name in sorted(topics):
        t, c = topics[name]
        role, why = roles.get(name, ("", ""))
        if not role:
            why = "sonar type, but not named *sonar*" if t in SONAR_TYPES else "not used"
        rows.append(TopicRow(name, t, c, role, why))
    return rows


@dataclass(frozen=True)
class BagContent:
    """What a bag gave: values, poses, sensors and where each came from."""

    raw: RawValues
    track: PoseTrack
    sensors: np.ndarray
    sonar_topics: tuple[str, ...]
    odom_label: str
    style: str
    sensors_from: str
    frames: dict[str, int]
    notes: tuple[str, ...]


def _collect(
    path: Path, opts: ImportOptions
) -> tuple[_Choice, Any, PoseCollector, StaticTransforms]:
    with _open(path) as reader:
        choice = _choose(path, _topics(reader), opts)
        sonar: RangeCollector | CloudCollector = (
            RangeCollector() if choice.style == "range" else CloudCollector()
        )
        poses, static = PoseCollector(), StaticTransforms()
        sinks: dict[str, Any] = {n: sonar for n in choice.sonar}
        sinks[choice.odom] = poses
        sinks.update({n: static for n in choice.static})
        conns = [c for c in reader.connections if c.topic in sinks]
        try:
            for conn, bag_ns, data in reader.messages(connections=conns):
                msg = reader.deserialize(data, conn.msgtype)
                sinks[conn.topic].add(msg, conn.topic, bag_ns)
        except SourceError:
            raise
        except _rosbags_errors() as err:
            raise SourceError(f"{path}: truncated or unreadable bag ({_first_line(err)})") from err
    return choice, sonar, poses, static


def _range_ids(names: list[str], spec: SensorSet | None) -> dict[str, int]:
    if spec is not None and spec.frames and all(n in spec.frames for n in names):
        return {n: spec.frames[n] for n in names}
    ints = [_TRAILING_INT.search(n) for n in names]
    if all(ints) and len({int(m.group(1)) for m in ints if m}) == len(names):
        return {n: int(m.group(1)) for n, m in zip(names, ints, strict=True) if m}
    return {n: k for k, n in enumerate(sorted(names))}


def _tf_table(
    path: Path,
    col: RangeCollector,
    static: StaticTransforms,
    base: str,
    ids: dict[str, int],
    name_of: dict[tuple[str, str], str],
    frame_of: dict[str, str],
) -> np.ndarray:
    table = np.zeros(len(ids), dtype=SENSOR_DTYPE)
    for k, (name, sid) in enumerate(sorted(ids.items(), key=lambda kv: kv[1])):
        mount = static.mount(frame_of[name], base)
        if mount is None:
            raise SourceError(
                f"{path}: no mount for sonar frame {frame_of[name] or name} (no /tf_static "
                f"transform to it); give a robot preset or a sensors file"
            )
        fov, lo, hi = next(b for p, b in col.beams.items() if name_of[p] == name)
        table[k] = (sid, mount[0], mount[1], mount[2], fov / 2.0, lo, hi)
    return table


def _from_ranges(
    path: Path, col: RangeCollector, static: StaticTransforms, base: str, spec: SensorSet | None
) -> tuple[RawValues, np.ndarray, dict[str, int], str]:
    if not col.t:
        raise SourceError(f"{path}: the sonar topics hold no ultrasonic Range messages")
    pairs = sorted(set(zip(col.topic, col.frame, strict=True)))
    by_frame = len({f for _, f in pairs}) == len(pairs) and all(f for _, f in pairs)
    name_of = {p: (p[1] if by_frame else p[0]) for p in pairs}
    frame_of = {name_of[p]: p[1] for p in pairs}
    ids = _range_ids(sorted(frame_of), spec)
    if spec is not None:
        known = {int(i) for i in spec.table["id"]}
        for name, sid in sorted(ids.items()):
            if sid not in known:
                raise SourceError(f"{path}: frame {name} is transducer {sid}, not in {spec.source}")
        table = spec.table
    else:
        table = _tf_table(path, col, static, base, ids, name_of, frame_of)
    lookup = {p: ids[name_of[p]] for p in pairs}
    sensor = np.array([lookup[p] for p in zip(col.topic, col.frame, strict=True)], dtype=np.int64)
    rng = np.asarray(col.range, dtype=np.float64)
    raw = RawValues(np.asarray(col.t), sensor, rng, value_key(rng), len(col.t))
    source = spec.source if spec is not None else "/tf_static"
    return raw, table, ids, source


def _behind(xy: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """True where a cloud point lies at or behind its transducer's face.

    A transducer hears only what is in front of it, so an echo's end point is ahead of
    the transducer along its heading. RosAria leaves a transducer that never fired (the
    absent rear ring of a Pioneer 3-DX set up with sixteen sonars) at the cloud frame's
    origin, the robot's centre, which is behind every transducer of the ring; such a
    point is no reading. Points with a non-finite coordinate are left to the range
    checks (an infinite end point means no echo).
    """
    finite = np.isfinite(xy).all(axis=1)
    dx, dy = xy[:, 0] - rows["x"], xy[:, 1] - rows["y"]
    with np.errstate(invalid="ignore"):  # inf - inf at a non-finite point: not used
        ahead = dx * np.cos(rows["heading"]) + dy * np.sin(rows["heading"])
    return np.asarray(finite & ~(ahead > 0.0))


def _from_cloud(
    path: Path, col: CloudCollector, spec: SensorSet | None
) -> tuple[RawValues, np.ndarray, str]:
    if spec is None:
        raise SourceError(
            f"{path}: a sonar point cloud carries no mounts; give a robot preset "
            f"(pioneer3-dx, ...) or a sensors file"
        )
    table = spec.table
    counts = np.array([len(p) for p in col.xy], dtype=np.int64)
    if counts.size and counts.max() > len(table):
        raise SourceError(
            f"{path}: a sonar cloud has {counts.max()} points but {spec.source} has "
            f"{len(table)} transducers"
        )
    xy = np.concatenate(col.xy) if col.xy else np.zeros((0, 2))
    # Points map to transducers by order: the k-th point of a cloud is the k-th row.
    idx = np.arange(xy.shape[0]) - np.repeat(np.cumsum(counts) - counts, counts)
    rows = table[idx]
    rng = np.hypot(xy[:, 0] - rows["x"], xy[:, 1] - rows["y"])
    rng[_behind(xy, rows)] = np.nan  # not an echo: dropped as invalid
    t = np.repeat(np.asarray(col.t, dtype=np.float64), counts)
    raw = RawValues(t, rows["id"].astype(np.int64), rng, value_key(xy[:, 0], xy[:, 1]), len(col.t))
    return raw, table, spec.source


def read_bag(path: Path, opts: ImportOptions, spec: SensorSet | None) -> BagContent:
    """Decode a bag's sonar values, poses and mounts (see the module docstring)."""
    choice, sonar, poses, static = _collect(path, opts)
    if choice.odom_kind == "chain" and opts.pose_frame:
        from sonarlog.sources.tfchain import chain_track

        pair = poses.odom_pair()
        base = pair[1] if pair else "base_link"
        try:
            track = chain_track(poses.tf_rows, static.parent, opts.pose_frame, base)
        except SourceError as err:
            raise SourceError(f"{path}: {err}") from None
        poses.child_frame = base
    else:
        track = poses.track()
    if len(track) == 0:
        raise SourceError(f"{path}: no odometry: {choice.odom} holds no odom -> base poses")
    notes: list[str] = []
    frames: dict[str, int] = {}
    if isinstance(sonar, RangeCollector):
        base = poses.child_frame or "base_link"
        raw, table, frames, source = _from_ranges(path, sonar, static, base, spec)
        if sonar.infrared:
            notes.append(f"skipped {sonar.infrared} infrared Range message(s)")
    else:
        raw, table, source = _from_cloud(path, sonar, spec)
        odd = sorted(f for f in sonar.frames if f and not f.startswith("base"))
        if odd:
            notes.append(f"cloud frame(s) {', '.join(odd)} taken as the robot base frame")
    pair = poses.odom_pair() if choice.odom_kind == "tf" else None
    label = f"{choice.odom} ({pair[0]} -> {pair[1]})" if pair else choice.odom
    if choice.odom_kind == "chain":
        label = f"{choice.odom} (tf chain {opts.pose_frame} -> {poses.child_frame})"
    return BagContent(
        raw, track, table, tuple(choice.sonar), label, choice.style, source, frames, tuple(notes)
    )

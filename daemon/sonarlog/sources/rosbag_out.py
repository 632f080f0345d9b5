"""A sonarlog as a ROS 2 bag, so RViz or Foxglove can replay a run over its map.

The bag holds, all stamped with the readings' times:

* ``/sonar/sonar_<id>``: ``sensor_msgs/Range`` per reading, in frame ``sonar_<id>``
  (ultrasound, field of view = beam width, a no-echo reading as ``+inf``, REP 117);
* ``/tf``: ``odom -> base_link`` where each pose starts and ends (and ``base_link -> turret``
  when the log has a turret that turns apart from the base);
* ``/tf_static``: ``base_link -> sonar_<id>`` (or ``turret -> sonar_<id>``), offered as
  transient-local so a late subscriber still gets it;
* ``/map/surfaces``: one ``visualization_msgs/MarkerArray`` of ``LINE_STRIP`` markers in
  the ``odom`` frame: the surfaces the caller gives (namespace ``surfaces``) and the log's
  true profile when it has one (namespace ``truth``), and a ``SPHERE_LIST`` per kind of
  point reflector the caller gives (namespaces ``corner`` and ``edge``).

Readings whose transmitter and receiver differ (crosstalk pairs) have no ``Range`` form
and are counted in :attr:`RosbagExport.skipped_bistatic`.
"""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog.reader import SonarLog
from sonarlog.schema import FLAG_NO_ECHO
from sonarlog.sources.errors import OutputExistsError, SourceError

__all__ = [
    "BASE_FRAME",
    "ODOM_FRAME",
    "TURRET_FRAME",
    "RosbagExport",
    "sonar_frame",
    "write_rosbag2",
]

ODOM_FRAME = "odom"
BASE_FRAME = "base_link"
TURRET_FRAME = "turret"
SURFACES_TOPIC = "/map/surfaces"
#: Point reflectors' marker namespaces and colours (RGBA): corners red, edges magenta.
POINT_NAMESPACES = {"corner": (0.84, 0.15, 0.16, 1.0), "edge": (0.8, 0.2, 0.8, 1.0)}
#: Diameter (m) of a point reflector's sphere.
POINT_SIZE_M = 0.08


def sonar_frame(sensor_id: int) -> str:
    """The frame (and topic suffix) of a transducer: ``sonar_<id>``."""
    return f"sonar_{int(sensor_id)}"


@dataclass(frozen=True)
class RosbagExport:
    """What :func:`write_rosbag2` wrote."""

    path: Path
    storage: str
    messages: dict[str, int] = field(default_factory=dict)
    skipped_bistatic: int = 0
    markers: int = 0


class _Msgs:
    """Message builders over one typestore."""

    def __init__(self) -> None:
        from rosbags.typesys import Stores, get_typestore

        self.store = get_typestore(Stores.ROS2_HUMBLE)
        self.T = self.store.types

    def time(self, t: float) -> Any:
        ns = round(t * 1e9)
        return self.T["builtin_interfaces/msg/Time"](
            sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000
        )

    def header(self, t: float, frame: str) -> Any:
        return self.T["std_msgs/msg/Header"](stamp=self.time(t), frame_id=frame)

    def transform(self, t: float, parent: str, child: str, x: float, y: float, yaw: float) -> Any:
        T = self.T
        return T["geometry_msgs/msg/TransformStamped"](
            header=self.header(t, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=0.0),
                rotation=self.quat(yaw),
            ),
        )  # fmt: skip

    def quat(self, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0)
        )

    def tf(self, transforms: list[Any]) -> Any:
        return self.T["tf2_msgs/msg/TFMessage"](transforms=transforms)

    def line_strip(
        self, t: float, ns: str, mid: int, pts: npt.NDArray[np.float64], rgba: tuple[float, ...]
    ) -> Any:
        # a LINE_STRIP (type 4) for a surface; a SPHERE_LIST (type 7) for point reflectors
        T = self.T
        points = ns in POINT_NAMESPACES
        size = POINT_SIZE_M if points else 0.02
        return T["visualization_msgs/msg/Marker"](
            header=self.header(t, ODOM_FRAME), ns=ns, id=mid, type=7 if points else 4, action=0,
            pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                orientation=self.quat(0.0),
            ),
            scale=T["geometry_msgs/msg/Vector3"](x=size, y=size if points else 0.0,
                                                 z=size if points else 0.0),
            color=T["std_msgs/msg/ColorRGBA"](r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
            lifetime=T["builtin_interfaces/msg/Duration"](sec=0, nanosec=0), frame_locked=False,
            points=[T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=0.0) for p in pts],
            colors=[], texture_resource="",
            texture=T["sensor_msgs/msg/CompressedImage"](
                header=self.header(t, ""), format="", data=np.zeros(0, dtype=np.uint8)
            ),
            uv_coordinates=[], text="", mesh_resource="",
            mesh_file=T["visualization_msgs/msg/MeshFile"](
                filename="", data=np.zeros(0, dtype=np.uint8)
            ),
            mesh_use_embedded_materials=False,
        )  # fmt: skip


def _latched() -> list[Any]:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    zero = QosTime(0, 0)
    return [
        Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
            zero, zero, QosLiveliness.AUTOMATIC, zero, False)
    ]  # fmt: skip


def _polylines(arr: npt.ArrayLike) -> list[npt.NDArray[np.float64]]:
    """Split an (N, 2) array at rows of NaN into polylines of at least two points."""
    a = np.asarray(arr, dtype=np.float64).reshape(-1, 2)
    gap = ~np.all(np.isfinite(a), axis=1)
    parts = np.split(a, np.flatnonzero(gap))
    return [
        p[~np.any(~np.isfinite(p), axis=1)] for p in parts if np.isfinite(p).all(axis=1).sum() >= 2
    ]


def _prepare(out: Path, force: bool) -> None:
    if not out.exists():
        return
    if not force:
        raise OutputExistsError(f"{out}: exists already; pass force=True (--force) to overwrite")
    # Only ever remove what is plainly a bag (or an empty folder), never an arbitrary tree.
    if out.is_dir() and ((out / "metadata.yaml").is_file() or not any(out.iterdir())):
        shutil.rmtree(out)
    else:
        raise OutputExistsError(f"{out}: exists and is not a ROS 2 bag; will not overwrite it")


def write_rosbag2(
    log: SonarLog,
    out: str | os.PathLike[str],
    *,
    surfaces: Sequence[npt.ArrayLike] = (),
    points: Mapping[str, npt.ArrayLike] | None = None,
    storage: str = "sqlite3",
    force: bool = False,
) -> RosbagExport:
    """Write ``log`` as a ROS 2 bag directory (see the module docstring for its topics).

    Parameters
    ----------
    log : SonarLog
        The readings, sensors and (optional) truth to write.
    out : path-like
        The bag directory to create.
    surfaces : sequence of array_like, each (N, 2)
        Surfaces in the world (odom) frame, one ``LINE_STRIP`` each.
    points : mapping of str to array_like (N, 2), optional
        Point reflectors by kind (``corner``, ``edge``), one ``SPHERE_LIST`` per kind
        (its namespace the kind, spheres of :data:`POINT_SIZE_M`).
    storage : {"sqlite3", "mcap"}
        The rosbag2 storage plugin.
    force : bool
        Replace an existing bag at ``out``.

    Returns
    -------
    RosbagExport

    Raises
    ------
    OutputExistsError
        ``out`` exists and ``force`` is False, or it is not a bag.
    SourceError
        ``storage`` is not ``sqlite3`` or ``mcap``.
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugins = {"sqlite3": StoragePlugin.SQLITE3, "mcap": StoragePlugin.MCAP}
    if storage not in plugins:
        raise SourceError(f"storage must be sqlite3 or mcap, got {storage!r}")
    dest = Path(out)
    _prepare(dest, force)
    m = _Msgs()
    r = log.readings
    own = r["tx"] == r["rx"]
    rows = r[own]
    c = log.speed_of_sound
    t0 = float(rows["t"][0]) if len(rows) else 0.0
    sensors = {int(s["id"]): s for s in log.sensors}
    has_turret = bool(np.any(np.abs(np.angle(np.exp(1j * (r["turret"] - r["theta"])))) > 1e-9))
    mount_parent = TURRET_FRAME if has_turret else BASE_FRAME
    counts: dict[str, int] = {}

    def put(conn: Any, t: float, msg: Any, typ: str) -> None:
        w.write(conn, round(t * 1e9), m.store.serialize_cdr(msg, typ))
        counts[conn.topic] = counts.get(conn.topic, 0) + 1

    with Writer(dest, version=Writer.VERSION_LATEST, storage_plugin=plugins[storage]) as w:
        w.set_custom_data("sonarlog.speed_of_sound", repr(c))
        w.set_custom_data("sonarlog.robot", str(log.attrs.get("robot", "")))
        tf_type, range_type = "tf2_msgs/msg/TFMessage", "sensor_msgs/msg/Range"
        static = w.add_connection(
            "/tf_static", tf_type, typestore=m.store, offered_qos_profiles=_latched()
        )
        dyn = w.add_connection("/tf", tf_type, typestore=m.store)
        put(static, t0, m.tf([
            m.transform(t0, mount_parent, sonar_frame(i), s["x"], s["y"], s["heading"])
            for i, s in sorted(sensors.items())
        ]), tf_type)  # fmt: skip

        marks = [("surfaces", p, (0.1, 0.4, 1.0, 1.0)) for s in surfaces for p in _polylines(s)]
        for kind, xy in sorted((points or {}).items()):
            pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
            if kind in POINT_NAMESPACES and pts.size:
                marks.append((kind, pts, POINT_NAMESPACES[kind]))
        if log.truth is not None:
            marks += [("truth", p, (0.1, 0.8, 0.1, 1.0)) for p in _polylines(log.truth)]
        if marks:
            mconn = w.add_connection(
                SURFACES_TOPIC, "visualization_msgs/msg/MarkerArray",
                typestore=m.store, offered_qos_profiles=_latched(),
            )  # fmt: skip
            arr = m.T["visualization_msgs/msg/MarkerArray"](
                markers=[m.line_strip(t0, ns, k, p, rgba) for k, (ns, p, rgba) in enumerate(marks)]
            )
            put(mconn, t0, arr, "visualization_msgs/msg/MarkerArray")

        # A /tf message where the pose starts and where it ends being the same: readings
        # of one firing cycle share a pose, and a reader interpolating the tf between the
        # two gets it back exactly.
        pose = np.column_stack([rows["x"], rows["y"], rows["theta"], rows["turret"]])
        edge = np.ones(len(rows), dtype=bool)
        change = np.any(pose[1:] != pose[:-1], axis=1)
        edge[1:] = change
        edge[:-1] |= change
        if len(rows):
            edge[-1] = True
        for j in np.flatnonzero(edge):
            t = float(rows["t"][j])
            x, y, th, tu = (float(v) for v in pose[j])
            trs = [m.transform(t, ODOM_FRAME, BASE_FRAME, x, y, th)]
            if has_turret:
                trs.append(m.transform(t, BASE_FRAME, TURRET_FRAME, 0.0, 0.0, tu - th))
            put(dyn, t, m.tf(trs), tf_type)

        conns = {
            i: w.add_connection(f"/sonar/{sonar_frame(i)}", range_type, typestore=m.store)
            for i in sorted({int(v) for v in rows["rx"]})
        }
        half = 0.5 * rows["tof"] * c
        no_echo = ((rows["flags"] & FLAG_NO_ECHO) != 0) | ~np.isfinite(half)
        rng = np.where(no_echo, np.inf, half)
        Range = m.T[range_type]
        for k in range(len(rows)):  # one Range message each: no array form exists
            i = int(rows["rx"][k])
            s = sensors[i]
            t = float(rows["t"][k])
            msg = Range(
                header=m.header(t, sonar_frame(i)), radiation_type=0,
                field_of_view=float(2.0 * s["half_beamwidth"]), min_range=float(s["min_range"]),
                max_range=float(s["max_range"]), range=float(rng[k]),
            )  # fmt: skip
            put(conns[i], t, msg, range_type)
    return RosbagExport(dest, storage, counts, int((~own).sum()), len(marks))

"""A log's rows as Foxglove messages: beams, pose, path, frame transforms, raw readings.

Both ``sonard --foxglove`` (live, from the acquisition process) and ``sonarproc`` (watch,
run and the MCAP export) publish the robot's side of the picture with this module, so a
recording and a live view look the same. It needs the optional ``foxglove-sdk`` package
(``pip install sonarmorph[live]``), imported when a :class:`RobotPublisher` is made.

Topics and frames
-----------------
* ``/sonar/readings`` (``foxglove.SceneUpdate``): one message per reading, the beam as a
  wedge (transmitter, the echo's arc across the receiver's beam, back), in ``map``. Entity
  ``beam/<tx>-<rx>`` replaces that pair's previous beam; it expires after
  :data:`BEAM_LIFETIME_S`. Metadata: ``t``, ``tx``, ``rx``, ``range_m``, ``flags``.
* ``/sonar/raw`` (JSON): one message per reading, its sonarlog fields plus ``range_m``
  (the Table panel shows it).
* ``/robot/pose`` (``foxglove.PoseInFrame``) and ``/robot/path`` (``foxglove.PosesInFrame``)
  in ``odom``; the path keeps a pose every :data:`PATH_STEP_M` of travel or
  :data:`PATH_TURN_RAD` of turn.
* ``/tf`` (``foxglove.FrameTransforms``): ``map`` → ``odom`` (identity: the log's poses are
  odometry and nothing corrects them yet), ``odom`` → ``base_link`` (the robot's pose), and
  ``base_link`` → ``sonar_<id>`` for every transducer (its mount on the turret, turned by
  the turret's heading relative to the base).

Every message's log time is the reading's own firing time (UNIX ns), so a recording
replays at the pace of the run and a live client can measure its delay.
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from sonarlog.foxglove_server import json_channel
from sonarlog.schema import FLAG_CROSSTALK, FLAG_NO_ECHO

if TYPE_CHECKING:
    import foxglove

__all__ = [
    "BEAM_LIFETIME_S",
    "FRAME_BASE",
    "FRAME_MAP",
    "FRAME_ODOM",
    "PATH_STEP_M",
    "PATH_TURN_RAD",
    "ROBOT_TOPICS",
    "RobotPublisher",
    "beam_outline",
    "parse_endpoint",
    "sonar_frame",
    "timestamp_of",
]

FRAME_MAP, FRAME_ODOM, FRAME_BASE = "map", "odom", "base_link"
TOPIC_READINGS, TOPIC_RAW = "/sonar/readings", "/sonar/raw"
TOPIC_POSE, TOPIC_PATH, TOPIC_TF = "/robot/pose", "/robot/path", "/tf"
ROBOT_TOPICS = (TOPIC_READINGS, TOPIC_RAW, TOPIC_POSE, TOPIC_PATH, TOPIC_TF)

#: A beam stays on screen this long: a full ring of 16 sonars fires in well under a
#: second, so each sensor's last beam is shown until it fires again.
BEAM_LIFETIME_S = 1.0
#: Path decimation: a pose every centimetre of travel (the finest map cell used) or
#: every degree of turn; a stop-and-fire run repeats its pose for every firing.
PATH_STEP_M = 0.01
PATH_TURN_RAD = math.radians(1.0)
#: Pose and transforms at most this often (s of log time): 20 Hz looks smooth in a viewer.
POSE_PERIOD_S = 0.05
#: Points along a beam's arc (the arc spans at most 25 degrees: 3 degrees a segment).
ARC_POINTS = 9
_NS = 1_000_000_000
_NUMBER = {"type": "number"}
#: JSON schema of ``/sonar/raw``: a sonarlog reading row (SI units) and its range.
RAW_SCHEMA: dict[str, Any] = {
    "title": "sonarmorph.Reading",
    "type": "object",
    "properties": {
        "t": {"type": "number", "description": "firing time, UNIX s"},
        "tx": {"type": "integer"},
        "rx": {"type": "integer"},
        "echo": {"type": "integer"},
        "tof": {"type": "number", "description": "round-trip time of flight, s"},
        "x": _NUMBER,
        "y": _NUMBER,
        "theta": _NUMBER,
        "turret": _NUMBER,
        "flags": {"type": "integer"},
        "range_m": {"type": "number", "description": "half the path length, m"},
    },
}


def parse_endpoint(text: str, *, default_host: str = "127.0.0.1") -> tuple[str, int]:
    """``"HOST:PORT"`` or ``"PORT"`` as ``(host, port)``; port 0 means a free port.

    The host defaults to loopback: serving a network is an explicit choice.

    Raises
    ------
    ValueError
        Not a port in 0..65535, or an empty host before ``:``.

    Examples
    --------
    >>> parse_endpoint("8765"), parse_endpoint("0.0.0.0:0"), parse_endpoint("[::1]:9000")
    (('127.0.0.1', 8765), ('0.0.0.0', 0), ('::1', 9000))
    """
    host, sep, port_text = text.strip().rpartition(":")
    host = host.strip("[]") if sep else default_host
    if not host:
        raise ValueError(f"needs a host before ':', got {text!r}")
    try:
        port = int(port_text)
    except ValueError:
        raise ValueError(f"must be [HOST:]PORT with PORT 0..65535, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise ValueError(f"port must be 0..65535 (0: a free one), got {port}")
    return host, port


def sonar_frame(sensor_id: int) -> str:
    """The frame of transducer ``sensor_id`` (``sonar_<id>``)."""
    return f"sonar_{int(sensor_id)}"


def beam_outline(
    tx_xy: np.ndarray, rx_xy: np.ndarray, rx_heading: float, half_beam: float, path_m: float
) -> np.ndarray:
    """The wedge of one echo: transmitter, the echo's arc across the receiver's beam, back.

    A path length ``L`` from transmitter to receiver puts the reflector on the ellipse of
    foci tx and rx with ``|p - tx| + |p - rx| = L``; along a unit direction ``u`` from rx
    the point is at ``d = (L² - |w|²) / (2 (L + u·w))`` with ``w = rx - tx`` (a circle of
    radius ``L/2`` when tx = rx).

    Returns
    -------
    ndarray, shape (ARC_POINTS + 2, 2)

    Examples
    --------
    >>> p = beam_outline(np.zeros(2), np.zeros(2), 0.0, 0.2, 2.0)
    >>> p.shape, np.round(np.hypot(*p[1:-1].T), 6).tolist() == [1.0] * 9
    ((11, 2), True)
    """
    ang = rx_heading + np.linspace(-half_beam, half_beam, ARC_POINTS)
    u = np.column_stack([np.cos(ang), np.sin(ang)])
    w = np.asarray(rx_xy, dtype=np.float64) - np.asarray(tx_xy, dtype=np.float64)
    denom = np.maximum(2.0 * (path_m + u @ w), 1e-9)
    d = np.maximum((path_m**2 - float(w @ w)) / denom, 0.0)
    arc = rx_xy + u * d[:, None]
    return np.vstack([tx_xy, arc, rx_xy])


def _finite(v: Any) -> Any:
    """JSON has no NaN: a reading without an echo has ``null`` for its tof and range."""
    return None if isinstance(v, float) and not math.isfinite(v) else v


def _yaw(fg: Any, yaw: float) -> Any:
    return fg.Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0))


def timestamp_of(fg: Any, t: float) -> Any:
    """``t`` (UNIX s) as a ``foxglove.Timestamp``, rounded to the nanosecond as log times are."""
    ns = round(t * _NS)
    return fg.Timestamp(ns // _NS, ns % _NS)


class RobotPublisher:
    """Publish readings, pose, path and transforms on a Foxglove context's channels.

    Parameters
    ----------
    sensors : numpy.ndarray
        The ``/sensors`` table (SENSOR_DTYPE).
    speed_of_sound : float
        m/s, to turn times of flight into path lengths.
    context : foxglove.Context, optional
        Where the channels live (a server's or an MCAP file's); default the global one.

    Raises
    ------
    ImportError
        ``foxglove-sdk`` is not installed.
    """

    def __init__(
        self,
        sensors: np.ndarray,
        speed_of_sound: float,
        *,
        context: foxglove.Context | None = None,
    ) -> None:
        import foxglove.channels as fc
        import foxglove.messages as fg

        self._fg = fg
        self.sensors = np.asarray(sensors)
        self.speed_of_sound = float(speed_of_sound)
        self._row = {int(s["id"]): i for i, s in enumerate(self.sensors)}
        self.readings_channel = fc.SceneUpdateChannel(TOPIC_READINGS, context=context)
        self.raw_channel = json_channel(TOPIC_RAW, "sonarmorph.Reading", RAW_SCHEMA, context)
        self.pose_channel = fc.PoseInFrameChannel(TOPIC_POSE, context=context)
        self.path_channel = fc.PosesInFrameChannel(TOPIC_PATH, context=context)
        self.tf_channel = fc.FrameTransformsChannel(TOPIC_TF, context=context)
        self._path: list[Any] = []
        self._last_pose: Any = None
        self._last_tf: Any = None
        self._last_pose_t = -math.inf
        self._last_path_pose: tuple[float, float, float] | None = None
        self._lifetime = fg.Duration.from_secs(BEAM_LIFETIME_S)
        self.published = 0

    def resend(self, topics: set[str] | frozenset[str], t: float) -> None:
        """Send the path, the last pose and the last transforms again on ``topics``.

        For a client that just subscribed: the protocol keeps nothing for late
        subscribers, and without the transforms its 3-D view cannot place anything.
        """
        fg = self._fg
        t_ns = round(t * _NS)
        if TOPIC_PATH in topics and self._path:
            msg = fg.PosesInFrame(
                timestamp=timestamp_of(fg, t), frame_id=FRAME_ODOM, poses=self._path
            )
            self.path_channel.log(msg, log_time=t_ns)
        if TOPIC_POSE in topics and self._last_pose is not None:
            self.pose_channel.log(self._last_pose, log_time=t_ns)
        if TOPIC_TF in topics and self._last_tf is not None:
            self.tf_channel.log(self._last_tf, log_time=t_ns)

    # ---- one reading ---------------------------------------------------------------------

    def _place(self, sid: int, r: np.void) -> tuple[np.ndarray, float, float]:
        s = self.sensors[self._row[sid]]
        c, sn = math.cos(r["turret"]), math.sin(r["turret"])
        xy = np.array([r["x"] + c * s["x"] - sn * s["y"], r["y"] + sn * s["x"] + c * s["y"]])
        return xy, float(r["turret"] + s["heading"]), float(s["half_beamwidth"])

    def _beam(self, r: np.void, path_m: float) -> Any:
        fg = self._fg
        tx, rx = int(r["tx"]), int(r["rx"])
        if tx not in self._row or rx not in self._row:
            return None
        tx_xy, _, _ = self._place(tx, r)
        rx_xy, heading, half = self._place(rx, r)
        flags = int(r["flags"])
        outline = beam_outline(tx_xy, rx_xy, heading, half, path_m)
        if flags & FLAG_NO_ECHO:
            color = fg.Color(r=0.6, g=0.6, b=0.6, a=0.5)
        elif flags & FLAG_CROSSTALK:
            color = fg.Color(r=1.0, g=0.5, b=0.0, a=0.8)
        else:
            color = fg.Color(r=0.1, g=0.8, b=1.0, a=0.8)
        line = fg.LinePrimitive(
            type=fg.LinePrimitiveLineType.LineStrip,
            thickness=2.0,
            scale_invariant=True,
            points=[fg.Point3(x=float(x), y=float(y), z=0.0) for x, y in outline],
            color=color,
        )
        meta = {
            "t": repr(float(r["t"])),  # exact: clients match it to the log time
            "tx": str(tx),
            "rx": str(rx),
            "range_m": f"{path_m / 2.0:.4f}",
            "flags": str(flags),
        }
        return fg.SceneUpdate(
            entities=[
                fg.SceneEntity(
                    timestamp=timestamp_of(fg, float(r["t"])),
                    frame_id=FRAME_MAP,
                    id=f"beam/{tx}-{rx}",
                    lifetime=self._lifetime,
                    metadata=[fg.KeyValuePair(key=k, value=v) for k, v in meta.items()],
                    lines=[line],
                )
            ]
        )

    def readings(self, rows: np.ndarray, *, beams: bool = True) -> None:
        """Publish each row's beam and raw fields, then the last row's pose, path and tf.

        ``beams=False`` publishes only the pose, path and transforms (a finished run).
        """
        if len(rows) == 0:
            return
        if not beams:
            self.poses(rows)
            return
        paths = np.asarray(rows["tof"], dtype=np.float64) * self.speed_of_sound
        for r, path_m in zip(rows, paths.tolist(), strict=True):
            t_ns = round(float(r["t"]) * _NS)
            beam = self._beam(r, path_m)
            if beam is not None:
                self.readings_channel.log(beam, log_time=t_ns)
            raw = {name: _finite(r[name].item()) for name in rows.dtype.names or ()}
            raw["range_m"] = _finite(path_m / 2.0)
            self.raw_channel.log(json.dumps(raw).encode(), log_time=t_ns)
            self.published += 1
        self.poses(rows)

    # ---- pose, path, transforms ----------------------------------------------------------

    def poses(self, rows: np.ndarray) -> None:
        """Publish pose and transforms along ``rows`` (fields t, x, y, theta, turret).

        Every row may extend the path (published once, if it grew); the pose and the
        transforms go out at most every :data:`POSE_PERIOD_S` of log time, and at the
        last row.
        """
        if len(rows) == 0:
            return
        fg = self._fg
        grew = False
        last = len(rows) - 1
        for i, r in enumerate(rows):
            grew |= self._extend_path(float(r["x"]), float(r["y"]), float(r["theta"]))
            t = float(r["t"])
            if i == last or t - self._last_pose_t >= POSE_PERIOD_S:
                self._publish_pose(r, t)
        if grew:
            t = float(rows[last]["t"])
            self.path_channel.log(
                fg.PosesInFrame(
                    timestamp=timestamp_of(fg, t), frame_id=FRAME_ODOM, poses=self._path
                ),
                log_time=round(t * _NS),
            )

    def _publish_pose(self, r: np.void, t: float) -> None:
        fg = self._fg
        t_ns, stamp = round(t * _NS), timestamp_of(fg, t)
        pose = self._pose(float(r["x"]), float(r["y"]), float(r["theta"]))
        self._last_pose = fg.PoseInFrame(timestamp=stamp, frame_id=FRAME_ODOM, pose=pose)
        self.pose_channel.log(self._last_pose, log_time=t_ns)
        self._last_tf = self._transforms(r, stamp)
        self.tf_channel.log(self._last_tf, log_time=t_ns)
        self._last_pose_t = t

    def _pose(self, x: float, y: float, theta: float) -> Any:
        fg = self._fg
        return fg.Pose(position=fg.Vector3(x=x, y=y, z=0.0), orientation=_yaw(fg, theta))

    def _extend_path(self, x: float, y: float, theta: float) -> bool:
        last = self._last_path_pose
        if last is not None:
            turn = abs(math.remainder(theta - last[2], math.tau))
            if math.hypot(x - last[0], y - last[1]) < PATH_STEP_M and turn < PATH_TURN_RAD:
                return False
        self._last_path_pose = (x, y, theta)
        self._path.append(self._pose(x, y, theta))
        return True

    def _transforms(self, r: np.void, stamp: Any) -> Any:
        fg = self._fg

        def tf(parent: str, child: str, x: float, y: float, yaw: float) -> Any:
            return fg.FrameTransform(
                timestamp=stamp,
                parent_frame_id=parent,
                child_frame_id=child,
                translation=fg.Vector3(x=x, y=y, z=0.0),
                rotation=_yaw(fg, yaw),
            )

        rel = float(r["turret"] - r["theta"])  # turret heading relative to the base
        c, s = math.cos(rel), math.sin(rel)
        transforms = [
            tf(FRAME_MAP, FRAME_ODOM, 0.0, 0.0, 0.0),
            tf(FRAME_ODOM, FRAME_BASE, float(r["x"]), float(r["y"]), float(r["theta"])),
        ]
        for sn in self.sensors:
            sx, sy = float(sn["x"]), float(sn["y"])
            transforms.append(
                tf(
                    FRAME_BASE,
                    sonar_frame(int(sn["id"])),
                    c * sx - s * sy,
                    s * sx + c * sy,
                    rel + float(sn["heading"]),
                )
            )
        return fg.FrameTransforms(transforms=transforms)

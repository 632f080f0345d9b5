"""What an import did: the source, the topics used and what was kept or dropped.

:class:`ImportSummary` comes back with every :func:`~sonarlog.sources.read_source`;
:class:`TopicRow` is one line of :func:`~sonarlog.sources.list_source`'s table.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

__all__ = ["ImportCounts", "ImportOptions", "ImportSummary", "TopicRow"]


@dataclass(frozen=True)
class TopicRow:
    """One topic (or Player device) of a source.

    Attributes
    ----------
    name : str
        Topic name (``/RosAria/sonar``) or Player device (``sonar:0``).
    msgtype : str
        Message type (``sensor_msgs/msg/Range``) or Player interface.
    count : int
        Messages (or log lines) on it.
    role : str
        ``sonar``, ``odometry``, ``mounts`` when the import would use it, else ``""``.
    reason : str
        Why it would be used, or why not (one short phrase).
    """

    name: str
    msgtype: str
    count: int
    role: str = ""
    reason: str = ""


@dataclass(frozen=True)
class ImportCounts:
    """How many readings went where (every sonar value is counted exactly once).

    ``values = readings + stale_dropped + invalid_dropped + out_of_pose_range_dropped``;
    ``no_echo_flagged`` counts kept readings that carry the no-echo flag.
    """

    messages: int = 0
    values: int = 0
    readings: int = 0
    stale_dropped: int = 0
    invalid_dropped: int = 0
    out_of_pose_range_dropped: int = 0
    no_echo_flagged: int = 0
    poses: int = 0


@dataclass(frozen=True)
class ImportSummary:
    """The report of one import.

    Attributes
    ----------
    source : str
        The path read.
    format : str
        ``ros1``, ``ros2-sqlite3``, ``ros2-mcap``, ``player`` or ``sonarlog``.
    style : str
        How sonar values were carried: ``range`` (``sensor_msgs/Range``), ``pointcloud``,
        ``pointcloud2``, ``player`` or ``sonarlog``.
    sonar_topics : tuple of str
        The topics (or Player devices) the readings came from.
    odom_topic : str
        Where the poses came from (a topic, ``/tf (odom -> base_link)``, a Player device).
    sensors_from : str
        Where the mounts came from (``/tf_static``, ``preset pioneer3-dx``, a YAML path,
        ``player geometry``).
    frames : dict
        Transducer id of each frame or topic name (Range style).
    counts : ImportCounts
    speed_of_sound : float
        m/s used to turn ranges into times of flight.
    notes : tuple of str
        Anything worth a line of its own (a topic ignored, a preset's point count, ...).
    """

    source: str
    format: str
    style: str
    sonar_topics: tuple[str, ...] = ()
    odom_topic: str = ""
    sensors_from: str = ""
    frames: dict[str, int] = field(default_factory=dict)
    counts: ImportCounts = field(default_factory=ImportCounts)
    speed_of_sound: float = 0.0
    notes: tuple[str, ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """A JSON-ready mapping of every field."""
        d = asdict(self)
        d["sonar_topics"] = list(self.sonar_topics)
        d["notes"] = list(self.notes)
        return d

    def lines(self) -> list[str]:
        """Short human-readable lines, for a command line tool to print."""
        c = self.counts
        out = [
            f"source: {self.source} ({self.format}, {self.style})",
            f"sonar: {', '.join(self.sonar_topics) or '-'}; poses: {self.odom_topic or '-'}; "
            f"mounts: {self.sensors_from or '-'}",
            f"readings: {c.readings} kept of {c.values} values in {c.messages} messages; "
            f"stale dropped {c.stale_dropped}, invalid dropped {c.invalid_dropped}, "
            f"outside the pose time span dropped {c.out_of_pose_range_dropped}; "
            f"no echo flagged {c.no_echo_flagged}; poses {c.poses}",
        ]
        out.extend(self.notes)
        return out


@dataclass(frozen=True)
class ImportOptions:
    """The choices a caller can make about an import (all optional).

    Attributes
    ----------
    sonar_topic : str or None
        Topic(s) of the sonar values: a name, a comma-separated list or a shell pattern
        (``/sonar/*``); a Player device (``sonar:0``).
    odom_topic : str or None
        Topic of the poses (Odometry, PoseStamped, or ``/tf``); a Player device.
    robot : str or None
        A preset name (``pioneer3-dx``) giving the mounts.
    sensors : str or None
        A sensors YAML path giving the mounts (wins over ``robot``).
    temperature_c : float or None
        Air temperature; sets the speed of sound.
    drop_stale : bool
        Drop values that repeat their sensor's previous value (default True).
    degrees : bool
        A readings CSV's angle columns (``theta``, ``turret``) are in degrees.
    pose_frame : str or None
        A bag's poses in this fixed frame of its tf tree (``map``: a SLAM's correction
        composed with the odometry, :mod:`sonarlog.sources.tfchain`); None: the odometry.
    """

    sonar_topic: str | None = None
    odom_topic: str | None = None
    robot: str | None = None
    sensors: str | None = None
    temperature_c: float | None = None
    drop_stale: bool = True
    degrees: bool = False
    pose_frame: str | None = None

"""One entry point for every log a robot leaves: a registry of formats keyed by detection.

Each :class:`SourceFormat` says how to recognise a path (``detect``), how to read it into a
:class:`~sonarlog.SonarLog` (``read``) and how to list what it holds (``list``). The
registry is tried in order; :func:`register_format` adds one (a CSV reader, say):

>>> [f.name for f in source_formats()]
['sonarlog', 'ros1', 'ros2', 'player', 'csv']
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sonarlog.reader import SonarLog, read_log
from sonarlog.schema import FLAG_NO_ECHO, REQUIRED_ATTRS
from sonarlog.sources.assemble import assemble, speed_of_sound_for
from sonarlog.sources.errors import OutputExistsError, SourceError
from sonarlog.sources.player import is_player_log, list_player, read_player
from sonarlog.sources.presets import sensors_for
from sonarlog.sources.rosbag import bag_format, is_ros1_bag, is_ros2_bag, list_bag, read_bag
from sonarlog.sources.summary import ImportCounts, ImportOptions, ImportSummary, TopicRow
from sonarlog.writer import LogWriter

__all__ = [
    "SourceFormat",
    "detect_format",
    "import_to_sonarlog",
    "list_source",
    "read_source",
    "register_format",
    "source_formats",
    "write_sonarlog",
]

log = logging.getLogger(__name__)

Reader = Callable[[Path, ImportOptions], tuple[SonarLog, ImportSummary]]
Lister = Callable[[Path], list[TopicRow]]
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"


@dataclass(frozen=True)
class SourceFormat:
    """A kind of log: its name, how to recognise it, read it and list it."""

    name: str
    description: str
    detect: Callable[[Path], bool]
    read: Reader
    list: Lister


def _is_hdf5(path: Path) -> bool:
    try:
        with path.open("rb") as fh:
            return fh.read(8) == _HDF5_MAGIC
    except OSError:
        return False


def _attrs(fmt: str, path: Path, robot: str, temperature_c: float | None) -> dict[str, Any]:
    attrs: dict[str, Any] = {"robot": robot, "source": f"{fmt}:{path.name}"}
    if temperature_c is not None:
        attrs["temperature_c"] = float(temperature_c)
    return attrs


def _read_bag(path: Path, opts: ImportOptions) -> tuple[SonarLog, ImportSummary]:
    spec = sensors_for(opts.sensors, opts.robot)
    content = read_bag(path, opts, spec)
    c = speed_of_sound_for(opts.temperature_c, spec.speed_of_sound if spec else None)
    fmt = bag_format(path)
    built = assemble(
        content.raw, content.track, content.sensors, speed_of_sound=c, path=path,
        attrs=_attrs(fmt, path, spec.robot if spec else "", opts.temperature_c),
        drop_stale=opts.drop_stale,
    )  # fmt: skip
    summary = ImportSummary(
        str(path), fmt, content.style, content.sonar_topics, content.odom_label,
        content.sensors_from, content.frames, built.counts, c, content.notes,
    )  # fmt: skip
    return built.log, summary


def _read_player(path: Path, opts: ImportOptions) -> tuple[SonarLog, ImportSummary]:
    spec = sensors_for(opts.sensors, opts.robot)
    content = read_player(path, opts, spec)
    c = speed_of_sound_for(opts.temperature_c, spec.speed_of_sound if spec else None)
    built = assemble(
        content.raw, content.track, content.sensors, speed_of_sound=c, path=path,
        attrs=_attrs("player", path, spec.robot if spec else "", opts.temperature_c),
        drop_stale=opts.drop_stale,
    )  # fmt: skip
    summary = ImportSummary(
        str(path), "player", "player", (content.sonar,), content.odom, content.sensors_from,
        {}, built.counts, c,
    )  # fmt: skip
    return built.log, summary


def _read_sonarlog(path: Path, opts: ImportOptions) -> tuple[SonarLog, ImportSummary]:
    lg = read_log(path)
    r = lg.readings
    counts = ImportCounts(
        values=len(r), readings=len(r),
        no_echo_flagged=int(((r["flags"] & FLAG_NO_ECHO) != 0).sum()),
        poses=0 if lg.poses is None else len(lg.poses),
    )  # fmt: skip
    summary = ImportSummary(
        str(path), "sonarlog", "sonarlog", ("/readings",), "/readings", "/sensors",
        counts=counts, speed_of_sound=lg.speed_of_sound,
    )  # fmt: skip
    return lg, summary


def _is_csv(path: Path) -> bool:
    return path.is_file() and path.suffix.lower() == ".csv"


def _read_csv(path: Path, opts: ImportOptions) -> tuple[SonarLog, ImportSummary]:
    from sonarlog.csvlog import NO_ECHO_ATTR, read_csv_log

    mounts = opts.sensors if opts.sensors is not None else opts.robot
    if mounts is None:
        raise SourceError(
            f"{path}: a readings CSV needs its mounts: a sensors YAML (--sensors) or a "
            "robot preset (--robot)"
        )
    c = None if opts.temperature_c is None else speed_of_sound_for(opts.temperature_c, None)
    lg = read_csv_log(path, mounts, degrees=opts.degrees, speed_of_sound=c)
    if opts.temperature_c is not None:
        lg.attrs["temperature_c"] = float(opts.temperature_c)
    r = lg.readings
    counts = ImportCounts(
        values=len(r), readings=len(r),
        no_echo_flagged=int(((r["flags"] & FLAG_NO_ECHO) != 0).sum()),
    )  # fmt: skip
    notes = (f"no echo at or beyond max_range: {lg.attrs[NO_ECHO_ATTR]} reading(s) flagged",)
    summary = ImportSummary(
        str(path), "csv", "csv", ("readings",), "readings", str(mounts),
        counts=counts, speed_of_sound=lg.speed_of_sound, notes=notes,
    )  # fmt: skip
    return lg, summary


def _list_csv(path: Path) -> list[TopicRow]:
    from sonarlog.csvlog import CSV_OPTIONAL, CSV_REQUIRED

    with path.open(encoding="utf-8", errors="replace") as fh:
        lines = [ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise SourceError(f"{path}: empty file, expected a header row")
    known = {*CSV_REQUIRED, *CSV_OPTIONAL, "tof", "range"}
    return [
        TopicRow(name, "column", len(lines) - 1, "" if name not in known else "readings",
                 "read" if name in known else "not a readings column")
        for name in (c.strip().lower() for c in lines[0].split(","))
    ]  # fmt: skip


def _list_sonarlog(path: Path) -> list[TopicRow]:
    lg = read_log(path)
    rows = [
        TopicRow("/sensors", "sensors", len(lg.sensors), "mounts", "sonarlog table"),
        TopicRow("/readings", "readings", len(lg.readings), "sonar", "sonarlog table"),
    ]
    if lg.poses is not None:
        rows.append(TopicRow("/poses", "poses", len(lg.poses), "", "pose stream"))
    return rows


_FORMATS: list[SourceFormat] = [
    SourceFormat("sonarlog", "sonarlog v1 (HDF5)", _is_hdf5, _read_sonarlog, _list_sonarlog),
    SourceFormat("ros1", "ROS 1 bag (.bag)", is_ros1_bag, _read_bag, list_bag),
    SourceFormat("ros2", "ROS 2 bag directory (sqlite3 or mcap)", is_ros2_bag, _read_bag, list_bag),
    SourceFormat("player", "Player/Stage text log", is_player_log, _read_player, list_player),
    SourceFormat("csv", "readings CSV (+ a sensors YAML)", _is_csv, _read_csv, _list_csv),
]


def register_format(fmt: SourceFormat, *, before: str | None = None) -> None:
    """Add a format to the registry (at the end, or before the format named ``before``).

    A format of the same name is replaced.
    """
    _FORMATS[:] = [f for f in _FORMATS if f.name != fmt.name]
    names = [f.name for f in _FORMATS]
    pos = names.index(before) if before in names else len(_FORMATS)
    _FORMATS.insert(pos, fmt)


def source_formats() -> tuple[SourceFormat, ...]:
    """The registered formats, in the order they are tried."""
    return tuple(_FORMATS)


def detect_format(path: str | os.PathLike[str]) -> SourceFormat:
    """The format of ``path``.

    Raises
    ------
    FileNotFoundError
        No such file or directory.
    SourceError
        No registered format recognises it (the message lists the formats).
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(2, "no such file or directory", str(p))
    for fmt in _FORMATS:
        if fmt.detect(p):
            return fmt
    kinds = "; ".join(f.description for f in _FORMATS)
    raise SourceError(f"{p}: not a log this tool reads ({kinds})")


def read_source(
    path: str | os.PathLike[str],
    *,
    sonar_topic: str | None = None,
    odom_topic: str | None = None,
    robot: str | None = None,
    sensors: str | os.PathLike[str] | None = None,
    temperature_c: float | None = None,
    drop_stale: bool = True,
    degrees: bool = False,
    truth: str | os.PathLike[str] | None = None,
    pose_frame: str | None = None,
) -> tuple[SonarLog, ImportSummary]:
    """Read any supported log into an in-memory sonarlog.

    Parameters
    ----------
    path : path-like
        A sonarlog ``.h5``, a ROS 1 ``.bag``, a ROS 2 bag directory, a Player log, or a
        readings CSV (which needs ``sensors`` or ``robot``; :mod:`sonarlog.csvlog`).
    sonar_topic, odom_topic : str, optional
        Override the automatic choice (see :mod:`sonarlog.sources.rosbag`); for a Player
        log, devices such as ``sonar:0`` and ``position2d:0``.
    robot : str, optional
        A preset name giving the mounts (``pioneer3-dx``; see
        :func:`~sonarlog.sources.preset_names`).
    sensors : path-like, optional
        A sensors YAML giving the mounts (wins over ``robot``).
    temperature_c : float, optional
        Air temperature (°C) for the speed of sound.
    drop_stale : bool
        Drop values that repeat their sensor's previous value (default).
    degrees : bool
        A readings CSV's ``theta`` and ``turret`` are in degrees.
    truth : path-like, optional
        A truth CSV (:func:`sonarlog.csvlog.read_truth_csv`: one or several polylines)
        replacing the log's ``/truth/profile``.
    pose_frame : str, optional
        A bag's poses in this fixed frame of its tf tree (``map``): the transforms from
        it down to the robot's base frame composed (:mod:`sonarlog.sources.tfchain`).

    Returns
    -------
    (SonarLog, ImportSummary)

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    SourceError
        A log that cannot be imported; one line naming it and what is missing.
    sonarlog.InvalidLogError
        A damaged sonarlog file.
    """
    p = Path(path)
    fmt = detect_format(p)
    opts = ImportOptions(
        sonar_topic, odom_topic, robot, None if sensors is None else str(sensors),
        temperature_c, drop_stale, degrees, pose_frame,
    )  # fmt: skip
    lg, summary = fmt.read(p, opts)
    if truth is not None:
        from sonarlog.csvlog import read_truth_csv

        lg = replace(lg, truth=read_truth_csv(Path(truth)))
    log.info("%s", "; ".join(summary.lines()))
    return lg, summary


def list_source(path: str | os.PathLike[str]) -> list[TopicRow]:
    """The topics (or devices, or tables) of a log, and which an import would use and why.

    Raises
    ------
    FileNotFoundError, SourceError
        As :func:`read_source`.
    """
    p = Path(path)
    return detect_format(p).list(p)


def _writable_attrs(lg: SonarLog) -> dict[str, str | int | float | bool]:
    skip = set(REQUIRED_ATTRS) | {"software"}
    return {
        k: v for k, v in lg.attrs.items()
        if k not in skip and isinstance(v, (str, int, float, bool))
    }  # fmt: skip


def write_sonarlog(
    lg: SonarLog,
    out: str | os.PathLike[str],
    *,
    force: bool = False,
    attrs: dict[str, str | int | float | bool] | None = None,
) -> Path:
    """Write an in-memory log as a sonarlog v1 file.

    The file is written beside ``out`` and renamed into place, so an existing file is only
    replaced by a complete one.

    Raises
    ------
    OutputExistsError
        ``out`` exists and ``force`` is False.
    """
    dest = Path(out)
    if dest.exists() and not force:
        raise OutputExistsError(f"{dest}: exists already; pass force=True (--force) to overwrite")
    if dest.is_dir():
        raise OutputExistsError(f"{dest}: is a directory, not a log file")
    tmp = dest.with_name(f".{dest.name}.part")
    extra = {**_writable_attrs(lg), **(attrs or {})}
    try:
        with LogWriter(
            tmp, lg.sensors, speed_of_sound=lg.speed_of_sound, robot=str(lg.attrs.get("robot", "")),
            attrs=extra, truth=lg.truth, flush_interval=0,
        ) as w:  # fmt: skip
            w.append(lg.readings)
            if lg.poses is not None:
                w.append_poses(lg.poses)
            if lg.events is not None:
                w.append_events(lg.events)
        os.replace(tmp, dest)
    finally:
        if tmp.exists():
            tmp.unlink()
    return dest


def import_to_sonarlog(
    path: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    force: bool = False,
    **options: Any,
) -> ImportSummary:
    """Read ``path`` (see :func:`read_source`, whose keywords ``options`` are) and write ``out``.

    The import summary is stored in the log as the root attribute ``import_summary`` (JSON).

    Raises
    ------
    OutputExistsError
        ``out`` exists and ``force`` is False (checked before reading).
    FileNotFoundError, SourceError
        As :func:`read_source`.
    """
    dest = Path(out)
    if dest.exists() and not force:
        raise OutputExistsError(f"{dest}: exists already; pass force=True (--force) to overwrite")
    lg, summary = read_source(path, **options)
    write_sonarlog(lg, dest, force=force, attrs={"import_summary": json.dumps(summary.as_dict())})
    return summary

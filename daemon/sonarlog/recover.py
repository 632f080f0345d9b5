"""Write a clean copy of a damaged or crashed sonarlog."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from sonarlog.errors import InvalidLogError
from sonarlog.reader import read_log
from sonarlog.state import CRASHED_ATTR
from sonarlog.writer import AttrValue, LogWriter

_WRITER_OWNED = {"format", "format_version", "speed_of_sound", "robot"}


@dataclass(frozen=True)
class RecoveryReport:
    """What :func:`recover_log` kept and dropped."""

    source: Path
    destination: Path
    readings: int
    dropped_rows: int
    poses: int
    events: int


def default_recovered_path(source: str | os.PathLike[str]) -> Path:
    """``LOG.h5`` -> ``LOG.recovered.h5`` beside it."""
    src = Path(source)
    return src.with_name(f"{src.stem}.recovered{src.suffix or '.h5'}")


def recover_log(
    source: str | os.PathLike[str],
    destination: str | os.PathLike[str] | None = None,
    *,
    force: bool = False,
) -> RecoveryReport:
    """Copy the intact part of ``source`` into a new, cleanly closed sonarlog v1 file.

    Parameters
    ----------
    source : path-like
        A sonarlog that may have been cut, or left open by a killed writer.
    destination : path-like, optional
        Where to write; default ``<stem>.recovered.h5`` beside ``source``.
    force : bool
        Replace ``destination`` if it exists (it is refused otherwise).

    Returns
    -------
    RecoveryReport

    Raises
    ------
    InvalidLogError
        If nothing of ``source`` can be read as a sonarlog.
    InvalidLogError
        If ``destination`` is the same file as ``source``, or exists and ``force`` is
        False, or its folder does not exist.
    """
    src = Path(source)
    dst = Path(destination) if destination is not None else default_recovered_path(src)
    if not src.exists():
        raise FileNotFoundError(2, "no such file", str(src))
    if dst.exists() and dst.resolve() == src.resolve():
        raise InvalidLogError(f"{dst}: the recovered copy must not overwrite the source log")
    if dst.exists() and not force:
        raise InvalidLogError(f"{dst}: exists already; pass force=True (--force) to overwrite")
    if not dst.resolve().parent.is_dir():
        raise InvalidLogError(f"{dst}: its folder {dst.resolve().parent} does not exist")
    return _copy_intact(src, dst, {})


def finalise_crashed_log(path: str | os.PathLike[str]) -> RecoveryReport:
    """Rewrite a log whose writer crashed as a cleanly closed file, in place.

    Every intact reading, pose and event is kept; torn rows are dropped and counted in the
    root attribute ``recovered_dropped_rows``. The result carries ``crashed_run = True``,
    so :func:`sonarlog.read_log` still reports ``log_state == "crashed"``, while plain HDF5
    tools (``h5py.File(path, "r")``, h5dump) open it. The original is replaced atomically
    only once the copy is complete; a crash during finalisation leaves the original.

    Parameters
    ----------
    path : path-like
        The crashed log (the caller makes sure no live writer holds it).

    Returns
    -------
    RecoveryReport
        ``destination`` is ``path`` itself.

    Raises
    ------
    InvalidLogError
        If nothing of ``path`` can be read as a sonarlog.
    """
    p = Path(path)
    return _copy_intact(p, p, {CRASHED_ATTR: True})


def _copy_intact(src: Path, dst: Path, more: dict[str, AttrValue]) -> RecoveryReport:
    log = read_log(src)
    extra = {k: v for k, v in log.attrs.items() if k not in _WRITER_OWNED}
    extra["recovered_from"] = str(src)
    extra["recovered_dropped_rows"] = int(log.dropped_rows)
    extra.update(more)
    tmp = dst.with_name(dst.name + ".partial")
    with LogWriter(
        tmp,
        log.sensors,
        speed_of_sound=log.speed_of_sound,
        robot=str(log.attrs.get("robot", "")),
        attrs=extra,
        truth=log.truth,
        flush_interval=0,
    ) as writer:
        writer.append(log.readings)
        if log.poses is not None:
            writer.append_poses(log.poses)
        if log.events is not None:
            writer.append_events(log.events)
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, dst)
    return RecoveryReport(
        source=src,
        destination=dst,
        readings=len(log.readings),
        dropped_rows=log.dropped_rows,
        poses=0 if log.poses is None else len(log.poses),
        events=0 if log.events is None else len(log.events),
    )

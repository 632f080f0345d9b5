"""Finalise the logs of crashed sonard runs, so every log in the directory opens anywhere.

A sonard killed mid-run (SIGKILL, power loss, OOM) leaves its log flagged "open for SWMR
write": :func:`sonarlog.read_log` reads it, plain HDF5 tools refuse it. When sonard starts
it looks at the ``*.h5`` files of its output directory (the service's ``StateDirectory``)
and rewrites each crashed sonard log in place with :func:`sonarlog.finalise_crashed_log`:
every intact reading is kept, the torn tail is dropped and counted, and the file keeps the
mark ``crashed_run`` so readers still report it. A log whose ``flock`` is held belongs to
a live sonard and is left alone; a crashed log without a single reading is removed (a run
that failed before its first reading leaves no log), and so is an unreadable stub smaller
than :data:`STUB_BYTES` (a sonard killed between creating the file and writing its layout).
The space reserves killed sonards left beside their logs (:mod:`sonarlog.space`) are
deleted first, so the finalising copies have room.
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from sonarlog import InvalidLogError, finalise_crashed_log, read_log, read_superblock

__all__ = ["Finalised", "finalise_crashed_logs"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Finalised:
    """What the start-up scan did to one log."""

    path: Path
    action: Literal["finalised", "removed", "unreadable"]
    readings: int = 0
    dropped_rows: int = 0
    detail: str = ""


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[bool]:
    """Hold an exclusive flock on ``path`` for the block; yield False if someone has it."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        yield False
        return
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            yield False
            return
        yield True
    finally:
        os.close(fd)


#: a sonard log holds its layout (about 25 KiB) once created; an unreadable file smaller
#: than this that no one holds is a sonard killed while creating it
STUB_BYTES = 64 * 1024


def _needs_finalising(path: Path) -> bool:
    try:
        info = read_superblock(path)
        size = path.stat().st_size
    except OSError:
        return False
    if info is None:
        return size < STUB_BYTES  # empty or half-written header
    return info.open_for_write or info.cut


def finalise_crashed_logs(directory: Path, *, skip: Path | None = None) -> list[Finalised]:
    """Finalise every crashed sonard log in ``directory`` that no live sonard holds.

    Parameters
    ----------
    directory : Path
        The output directory.
    skip : Path, optional
        The log this sonard is about to write.

    Returns
    -------
    list of Finalised
        One entry per log acted on (finalised, removed, or found unreadable).
    """
    _remove_stale_reserves(directory, skip)
    done: list[Finalised] = []
    for path in sorted(directory.glob("*.h5")):
        if skip is not None and path.resolve() == skip.resolve():
            continue
        if not _needs_finalising(path):
            continue
        with _locked(path) as mine:
            if not mine:
                log.debug("%s: held by a live sonard; left alone", path)
                continue
            result = _finalise_one(path)
        if result is not None:
            done.append(result)
    return done


def _remove_stale_reserves(directory: Path, skip: Path | None) -> None:
    """Delete the space reserves (:mod:`sonarlog.space`) that killed sonards left behind."""
    for reserve in sorted(directory.glob(".*.h5.reserve")):
        owner = reserve.with_name(reserve.name[1 : -len(".reserve")])
        if skip is not None and owner.resolve() == skip.resolve():
            continue
        if owner.exists():
            with _locked(owner) as mine:
                if not mine:
                    continue  # a live sonard's
                reserve.unlink(missing_ok=True)
        else:
            reserve.unlink(missing_ok=True)
        log.info("removed the stale space reserve %s", reserve)


def _finalise_one(path: Path) -> Finalised | None:
    try:
        content = read_log(path)
    except InvalidLogError as err:
        size = path.stat().st_size
        if size < STUB_BYTES:
            path.unlink()
            log.warning(
                "removed %s (%d bytes): its sonard was killed while creating it", path, size
            )
            return Finalised(path, "removed", detail=str(err))
        log.warning("crashed log %s cannot be finalised: %s", path, err)
        return Finalised(path, "unreadable", detail=str(err))
    if content.attrs.get("acquired_by") != "sonard":
        return None  # not ours: sonarproc recover is the tool for other writers' logs
    if len(content.readings) == 0:
        path.unlink()
        log.warning("removed %s: its sonard crashed before the first reading", path)
        return Finalised(path, "removed", dropped_rows=content.dropped_rows)
    try:
        report = finalise_crashed_log(path)
    except (InvalidLogError, OSError) as err:
        log.warning("crashed log %s cannot be finalised: %s", path, err)
        return Finalised(path, "unreadable", detail=str(err))
    log.warning(
        "finalised crashed log %s: kept %d readings, dropped %d torn rows",
        path,
        report.readings,
        report.dropped_rows,
    )
    return Finalised(path, "finalised", report.readings, report.dropped_rows)

"""How a sonarlog ended: closed by its writer, left open by a crash, or cut short.

The answer comes from the HDF5 superblock (version 2 or 3, what :class:`sonarlog.LogWriter`
writes), read as plain bytes so that it works on files HDF5 itself refuses:

* the **status flags** byte says whether a writer still has the file open (bit 0, write
  access; bit 2, SWMR write access). A writer that closed the file cleared them; one that
  was killed did not;
* the **end-of-file address** says how long the file must be. A file shorter than that was
  cut (a copy that stopped early, a full disk).

Layout (HDF5 file format specification, superblock v2/v3): signature (8 bytes), version
(1), size of offsets (1), size of lengths (1), status flags (1), base address, superblock
extension address, end-of-file address, root object header address, checksum.

``sonard`` finalises the logs of its own crashed runs in place; the copy it writes carries
the root attribute :data:`CRASHED_ATTR` so that readers still know the run did not end
cleanly.
"""

from __future__ import annotations

import fcntl
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

__all__ = [
    "CRASHED_ATTR",
    "LogState",
    "SuperblockInfo",
    "flock_held",
    "integrity_warning",
    "read_superblock",
    "writer_closed",
]

#: ``"closed"``: the writer closed the file; ``"crashed"``: the writer died with the file
#: open (or sonard finalised such a file); ``"cut"``: the file is shorter than HDF5 says.
LogState = Literal["closed", "crashed", "cut"]

#: Root attribute (bool) of a log that sonard finalised after its writer crashed.
CRASHED_ATTR = "crashed_run"

_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_WRITE_OPEN = 0x01
_SWMR_WRITE = 0x04


@dataclass(frozen=True)
class SuperblockInfo:
    """What the superblock of a v2/v3 HDF5 file says about how the file ended.

    Attributes
    ----------
    open_for_write : bool
        A writer had the file open and never closed it (or still has it open).
    stored_eof : int
        The end-of-file address: how many bytes the file must hold.
    size : int
        How many bytes it holds.
    """

    open_for_write: bool
    stored_eof: int
    size: int

    @property
    def cut(self) -> bool:
        """Whether the file is shorter than its recorded end of file."""
        return self.size < self.stored_eof


def read_superblock(path: str | os.PathLike[str]) -> SuperblockInfo | None:
    """Read the status flags and end-of-file address of a v2/v3 superblock.

    Returns
    -------
    SuperblockInfo or None
        None when the file is not HDF5 with a version 2 or 3 superblock at offset 0.
    """
    p = Path(path)
    with open(p, "rb") as fh:
        head = fh.read(12)
        if len(head) < 12 or head[:8] != _SIGNATURE or head[8] not in (2, 3):
            return None
        size = head[9]
        if size not in (2, 4, 8):
            return None
        fh.seek(12 + 2 * size)
        raw = fh.read(size)
    if len(raw) != size:
        return None
    return SuperblockInfo(
        open_for_write=bool(head[11] & (_WRITE_OPEN | _SWMR_WRITE)),
        stored_eof=int.from_bytes(raw, "little"),
        size=p.stat().st_size,
    )


def integrity_warning(
    path: str | os.PathLike[str],
    state: LogState,
    *,
    intact: int,
    dropped: int,
    finalised: bool = False,
) -> str | None:
    """The one-line warning for a log that did not end cleanly (None for a closed log).

    Parameters
    ----------
    path : path-like
        The log, named in the message and in the ``sonarproc recover`` hint.
    state : {"closed", "crashed", "cut"}
        From :attr:`sonarlog.SonarLog.log_state`.
    intact, dropped : int
        Readings kept, and torn rows dropped at the end of ``/readings``.
    finalised : bool
        sonard already rewrote the crashed log as a clean file: no recovery hint.

    Examples
    --------
    >>> print(integrity_warning("run.h5", "cut", intact=257, dropped=922).replace("; ", ";\\n"))
    run.h5: log is cut short: 257 intact readings, 922 torn rows dropped;
    to write a clean copy: sonarproc recover run.h5
    >>> integrity_warning("run.h5", "closed", intact=10, dropped=0) is None
    True
    """
    if state == "closed":
        return None
    what = "log is cut short" if state == "cut" else "its writer crashed"
    counts = f"{intact} intact readings, {dropped} torn rows dropped"
    if finalised:
        return f"{path}: {what}: {counts} (sonard finalised it)"
    return f"{path}: {what}: {counts}; to write a clean copy: sonarproc recover {path}"


def writer_closed(path: str | os.PathLike[str]) -> bool:
    """Whether the HDF5 file's writer has closed it (superblock flags cleared).

    A live writer, or one that was killed, leaves the "open for write" flags set; files
    with older superblocks carry no such flags and count as closed.
    """
    info = read_superblock(path)
    return info is None or not info.open_for_write


def flock_held(path: str | os.PathLike[str]) -> bool:
    """Whether some process holds an exclusive ``flock`` on ``path`` right now (a live writer)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    except OSError:
        return False
    finally:
        os.close(fd)  # closing drops the shared lock if we took it
    return False

"""Disk space for a log that must close cleanly even when its file system fills up.

HDF5 does not survive a write that fails half-way: after ``ENOSPC`` inside a dataset
write the library's caches no longer match the file, closing it may fail or crash the
process, and the log is lost. :class:`SpaceGuard` keeps that from happening:

* before every batch the writer asks :meth:`SpaceGuard.check` whether the file system has
  room for it (whole chunks, since HDF5 allocates chunk by chunk, plus a margin for the
  metadata); when it has not, the batch is refused with ``OSError(ENOSPC)`` before HDF5
  writes a byte, so the file stays as it was after the last good batch;
* a reserve file (``.NAME.reserve`` beside the log, allocated up front) holds the space
  that closing the file needs; :meth:`SpaceGuard.release` frees it once a batch was
  refused, so the close succeeds even when another program filled the disk to the last
  block.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
from pathlib import Path

__all__ = ["METADATA_MARGIN", "RESERVE_BYTES", "SpaceGuard", "reserve_path"]

log = logging.getLogger(__name__)

#: space kept for closing the log: the pending rows of the last flush interval (a second of
#: a 16-sonar ring is under 1 kB) can still need a fresh chunk of each dataset (about
#: 320 kB in all), and HDF5 rewrites its metadata on close; 1 MiB covers both threefold
RESERVE_BYTES = 1 << 20
#: free space a batch must leave besides its chunks: HDF5's chunk index and object
#: headers grow with the datasets (a few kB per batch)
METADATA_MARGIN = 64 << 10


def reserve_path(log_path: str | os.PathLike[str]) -> Path:
    """The reserve file kept beside ``log_path`` (hidden, so log listings skip it)."""
    p = Path(log_path)
    return p.with_name(f".{p.name}.reserve")


class SpaceGuard:
    """Refuse writes the file system has no room for, and keep room to close the log.

    Parameters
    ----------
    log_path : path-like
        The log; the reserve file goes beside it.
    reserve_bytes : int
        Size of the reserve file (0: no reserve, only the free-space check).
    """

    def __init__(self, log_path: str | os.PathLike[str], reserve_bytes: int = RESERVE_BYTES):
        self.log_path = Path(log_path)
        self.reserve = reserve_path(log_path) if reserve_bytes > 0 else None
        self.refused: OSError | None = None
        if self.reserve is not None:
            self._allocate(reserve_bytes)

    def _allocate(self, nbytes: int) -> None:
        assert self.reserve is not None
        fd = os.open(self.reserve, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, 0o600)
        try:
            os.posix_fallocate(fd, 0, nbytes)
        except OSError as exc:
            os.close(fd)
            with contextlib.suppress(OSError):
                os.unlink(self.reserve)
            if exc.errno == errno.ENOSPC:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.log_path)) from exc
            # a file system without fallocate (some network ones): only the check applies
            log.debug("no reserve for %s: %s", self.log_path, exc)
            self.reserve = None
            return
        os.close(fd)

    def free_bytes(self) -> int:
        """Bytes an unprivileged writer may still allocate on the log's file system."""
        st = os.statvfs(self.log_path.parent)
        return st.f_bavail * st.f_frsize

    def check(self, needed: int) -> None:
        """Raise ``OSError(ENOSPC)`` unless ``needed`` bytes plus the margin are free.

        Once refused, every later check is refused too: the file is kept as it was.
        """
        if self.refused is not None:
            raise self.refused
        free = self.free_bytes()
        if free < needed + METADATA_MARGIN:
            log.debug("%s: %d bytes free, a batch needs %d", self.log_path, free, needed)
            self.refused = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.log_path))
            raise self.refused

    def release(self) -> None:
        """Free the reserve (idempotent): the space closing the log needs."""
        if self.reserve is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self.reserve)
            self.reserve = None

"""One sonard per log file: an exclusive ``flock`` held from creation to close.

The lock is taken on the file sonard is about to create, before the robot hears a byte.
A second sonard given the same ``--out`` finds it held and learns the holder's PID from
``/proc/locks``; a crashed sonard's lock vanishes with its process, which is how the
start-up scan (:mod:`sonard.crashed_logs`) tells a crashed log from a live one.

The file is created with ``O_EXCL``, so of two sonards racing for a new name exactly one
creates it; the other finds it locked (waiting a moment for the winner to take the lock)
and names the winner, or finds an unlocked file and refuses to overwrite it. Never two
writers truncating each other.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import time
from pathlib import Path
from types import TracebackType

from sonarlog.state import flock_held as is_locked

__all__ = ["LockBusy", "LogExists", "LogLock", "flock_holders", "is_locked"]


#: how long an existing, unlocked log may still be a sonard's that is about to lock it (s)
CREATE_GRACE_S = 0.3


class LockBusy(BlockingIOError):
    """Another process holds a lock sonard needs; ``holders`` are its PIDs (maybe empty)."""

    def __init__(self, message: str, holders: tuple[int, ...] = ()) -> None:
        super().__init__(message)
        self.holders = holders


class LogExists(FileExistsError):
    """The log file already holds data: sonard never overwrites a log."""


def flock_holders(path: str | os.PathLike[str]) -> tuple[int, ...]:
    """PIDs holding an ``flock`` on ``path``, from ``/proc/locks`` (empty if unknown).

    Each line reads ``N: FLOCK ADVISORY WRITE PID MAJ:MIN:INODE START END``; waiters are
    marked ``->`` and skipped.
    """
    try:
        st = os.stat(path)
        text = Path("/proc/locks").read_text(encoding="ascii", errors="replace")
    except OSError:
        return ()
    want = (os.major(st.st_dev), os.minor(st.st_dev), st.st_ino)
    pids: list[int] = []
    for line in text.splitlines():
        parts = line.split()
        if "->" in parts or len(parts) < 6 or parts[1] != "FLOCK":
            continue
        try:
            maj, mnr, ino = parts[5].split(":")
            key = (int(maj, 16), int(mnr, 16), int(ino))
            pid = int(parts[4])
        except ValueError:
            continue
        if key == want and pid not in pids:
            pids.append(pid)
    return tuple(pids)


class LogLock:
    """Create ``path`` and hold an exclusive ``flock`` on it until :meth:`release`.

    Parameters
    ----------
    path : path-like
        The log file sonard will write.

    Raises
    ------
    LockBusy
        Another process (another sonard) holds the file; the message names its PID.
    LogExists
        The file exists and holds data.
    OSError
        The file cannot be created (directory missing, no permission).
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o640)
        except FileExistsError as err:
            holders = self._wait_for_holder()
            if holders is None:
                raise LogExists(f"{self.path} exists; refusing to overwrite") from err
            who = f"PID {', '.join(map(str, holders))}" if holders else "another process"
            raise LockBusy(
                f"{self.path} is being written by {who} (another sonard on the same log)",
                holders,
            ) from err
        # the file is new and ours: a sonard that lost the race to create it waits for this
        fcntl.flock(fd, fcntl.LOCK_EX)
        self._fd: int | None = fd

    def _wait_for_holder(self) -> tuple[int, ...] | None:
        """The PIDs holding the existing file's lock, or None when no one does.

        A sonard that has just created the file takes its lock a moment later, so an
        unlocked file is looked at again for up to :data:`CREATE_GRACE_S`.
        """
        deadline = time.monotonic() + CREATE_GRACE_S
        while True:
            if is_locked(self.path):
                return flock_holders(self.path)
            if time.monotonic() > deadline:
                return None
            time.sleep(0.01)

    def release(self, *, remove: bool = False) -> None:
        """Drop the lock (idempotent); with ``remove``, delete the file first.

        Removing before unlocking means no other process can lock the name in between and
        then lose its file to our unlink.
        """
        if self._fd is None:
            return
        if remove:
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> LogLock:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.release()

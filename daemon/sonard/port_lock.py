"""One program per robot port: the UUCP lock file and the tty's exclusive mode.

Two mechanisms, because programs honour different ones:

* the **lock file** ``LCK..<device>`` in ``/run/lock`` (FHS, the UUCP convention followed
  by minicom, picocom, ModemManager): it holds the owner's PID as ten ASCII digits and a
  newline. A lock file whose PID is dead is stale and taken over. Its directory is
  ``$SONARD_LOCK_DIR`` when set (tests), else the first writable of ``/run/lock`` and
  ``/var/lock``; when none is writable (a hardened service) this part is skipped. A live
  PID is not enough to keep a lock file: PIDs are reused (Linux wraps at ``pid_max``, 32768
  by default), so a process that started after the lock file was written, and does not
  have the device open, is another program under a recycled PID, and the file is stale;
* **TIOCEXCL** on the tty: once set, the kernel refuses every further ``open`` of the
  device (EBUSY) whatever the program, except for root. The flag lasts until the last
  handle on the tty closes: an emulator keeping its own handle on a pty keeps it set after
  a crashed sonard, which then blocks a non-root restart;
* the ``flock`` pyserial takes with ``exclusive=True`` (sonard's own client does) is
  checked too, so a pyserial program holding the port is named even for root.

:meth:`PortLock.acquire` checks both before sonard opens the port (so a refused sonard
never sends a byte), and :meth:`PortLock.hold_exclusive` sets TIOCEXCL once sonard's own
client has the port open. Reopening after a link fault lifts exclusive mode for the
moment of the open (:class:`ExclusiveClient`). pyserial URLs (``nomad://...``) have no
device and get no port lock.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import logging
import os
import termios
from pathlib import Path
from typing import Any

from sonard.log_lock import LockBusy, flock_holders

__all__ = [
    "ExclusiveClient",
    "PortLock",
    "PortUnavailable",
    "device_holders",
    "lock_dir",
    "pid_recycled",
    "process_start_time",
]

log = logging.getLogger(__name__)

LOCK_DIRS = ("/run/lock", "/var/lock")
LOCK_DIR_ENV = "SONARD_LOCK_DIR"


class PortUnavailable(OSError):
    """The robot port cannot be opened at all (missing device, no permission)."""


def lock_dir(env: dict[str, str] | None = None) -> Path | None:
    """The directory for UUCP lock files, or None when none is writable."""
    env = dict(os.environ) if env is None else env
    if env.get(LOCK_DIR_ENV):
        return Path(env[LOCK_DIR_ENV])
    for d in LOCK_DIRS:
        if os.access(d, os.W_OK | os.X_OK):
            return Path(d)
    return None


def _pid_alive(pid: int) -> bool:
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # alive, owned by someone else
    return True


#: How much later than the lock file a process must have started to be judged a newcomer
#: under a recycled PID: ``/proc/stat``'s boot time is whole seconds and file times may be
#: as coarse, so closer calls are left to the owner.
START_AFTER_LOCK_SLACK_S = 2.0


def process_start_time(pid: int) -> float | None:
    """When process ``pid`` started, in seconds of the epoch (None without ``/proc``).

    Field 22 of ``/proc/PID/stat`` counts clock ticks from boot; ``btime`` in
    ``/proc/stat`` is the boot's wall time.
    """
    try:
        stat = Path(f"/proc/{pid}/stat").read_text(encoding="ascii", errors="replace")
        boot = next(
            int(line.split()[1])
            for line in Path("/proc/stat").read_text(encoding="ascii").splitlines()
            if line.startswith("btime ")
        )
    except (OSError, StopIteration, ValueError, IndexError):
        return None
    # the command name (field 2) may hold spaces and parentheses: split after its last ')'
    fields = stat[stat.rfind(")") + 2 :].split()
    try:
        ticks = int(fields[19])
    except (IndexError, ValueError):
        return None
    return boot + ticks / os.sysconf("SC_CLK_TCK")


def _holds_device(pid: int, device: str) -> bool:
    fd_dir = Path(f"/proc/{pid}/fd")
    with contextlib.suppress(OSError):
        for fd in fd_dir.iterdir():
            with contextlib.suppress(OSError):
                if os.readlink(fd) == device:
                    return True
    return False


def pid_recycled(pid: int, lock_file: Path, device: str) -> bool:
    """Whether live ``pid`` is a newcomer that cannot be the lock file's writer.

    The writer was running when it wrote the file, so a process that started after the
    file's last change is another program under a recycled PID. Only judged so when it
    does not have ``device`` open either: an owner that has it open is the owner whatever
    the clocks say (a wall-clock step forward moves the computed start time later).
    """
    started = process_start_time(pid)
    if started is None:
        return False
    try:
        written = lock_file.stat().st_mtime
    except OSError:
        return False
    return started > written + START_AFTER_LOCK_SLACK_S and not _holds_device(pid, device)


def device_holders(device: str | os.PathLike[str]) -> tuple[int, ...]:
    """PIDs of other processes with ``device`` open (a scan of ``/proc/*/fd``)."""
    target = os.path.realpath(device)
    me = os.getpid()
    pids: list[int] = []
    for proc in Path("/proc").iterdir():
        if proc.name.isdigit() and int(proc.name) != me and _holds_device(int(proc.name), target):
            pids.append(int(proc.name))
    return tuple(sorted(pids))


class PortLock:
    """The lock file and exclusive mode of one serial device.

    Parameters
    ----------
    port : str
        A device path (symlinks are followed) or a pyserial URL (then nothing is locked).
    directory : Path, optional
        Where lock files live; default :func:`lock_dir`.
    """

    def __init__(self, port: str, directory: Path | None = None) -> None:
        self.port = port
        self.device: str | None = None if "://" in port else os.path.realpath(port)
        self.directory = directory if directory is not None else lock_dir()
        self.lock_file: Path | None = None
        self._guard: int | None = None

    @property
    def lock_name(self) -> str:
        """``LCK..ttyUSB0`` for ``/dev/ttyUSB0``; ``LCK..pts_3`` for ``/dev/pts/3``."""
        dev = self.device or self.port
        rel = dev[len("/dev/") :] if dev.startswith("/dev/") else dev.lstrip("/")
        return "LCK.." + rel.replace("/", "_")

    def acquire(self) -> None:
        """Take the lock file and check that no one holds the device exclusively.

        Raises
        ------
        LockBusy
            A live process owns the lock file or holds the device; the message names it.
        PortUnavailable
            The device does not exist or cannot be opened.
        """
        if self.device is None:
            return
        # the lock file first: its PID names the holder exactly, a /proc scan cannot (the
        # emulator of a pty holds the device too)
        if self.directory is not None:
            self._take_lock_file(self.directory / self.lock_name)
        try:
            self._probe()
        except BaseException:
            self.release()
            raise

    def _probe(self) -> None:
        """Open the device once: EBUSY means exclusive mode, a held flock a pyserial owner."""
        assert self.device is not None
        try:
            fd = os.open(self.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK | os.O_CLOEXEC)
        except OSError as err:
            if err.errno == errno.EBUSY:
                raise self._busy("is held exclusively by", device_holders(self.device)) from err
            failure = PortUnavailable(f"cannot open robot port {self.port}: {err.strerror or err}")
            failure.errno = err.errno
            raise failure from err
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as err:
            holders = flock_holders(self.device) or device_holders(self.device)
            raise self._busy("is locked by", holders) from err
        finally:
            os.close(fd)

    def _busy(self, what: str, holders: tuple[int, ...]) -> LockBusy:
        who = f"PID {', '.join(map(str, holders))}" if holders else "another process"
        return LockBusy(f"{self.port} {what} {who}", holders)

    def _take_lock_file(self, path: Path) -> None:
        me = os.getpid()
        tmp = path.with_name(f"{path.name}.{me}.tmp")
        try:
            tmp.write_text(f"{me:10d}\n", encoding="ascii")
        except OSError as err:
            log.debug("no lock file in %s: %s", path.parent, err)
            return
        try:
            for _ in range(3):
                try:
                    os.link(tmp, path)
                except FileExistsError:
                    pid = self._read_pid(path)
                    if pid == me:
                        break
                    assert self.device is not None
                    if _pid_alive(pid) and not pid_recycled(pid, path, self.device):
                        raise LockBusy(
                            f"{self.port} is in use by PID {pid} (lock file {path})", (pid,)
                        ) from None
                    log.info(
                        "taking over stale lock file %s (PID %d is gone or started after it)",
                        path,
                        pid,
                    )
                    with contextlib.suppress(FileNotFoundError):
                        path.unlink()
                    continue
                break
            else:
                raise LockBusy(f"{self.port}: lock file {path} keeps changing")
            self.lock_file = path
        finally:
            with contextlib.suppress(FileNotFoundError):
                tmp.unlink()

    @staticmethod
    def _read_pid(path: Path) -> int:
        try:
            text = path.read_bytes()[:64]
        except FileNotFoundError:
            return 0
        try:
            return int(text.split()[0]) if text.split() else 0
        except ValueError:  # binary PIDs (old UUCP) or garbage: treat as stale
            return 0

    def hold_exclusive(self) -> None:
        """Set TIOCEXCL (the caller's client has the port open): others get EBUSY."""
        if self.device is None or self._guard is not None:
            return
        # a replugged adapter may come back under another name behind the same symlink
        self.device = os.path.realpath(self.port)
        try:
            fd = os.open(self.device, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK | os.O_CLOEXEC)
        except OSError as err:
            log.debug("cannot hold %s exclusively: %s", self.device, err)
            return
        try:
            fcntl.ioctl(fd, termios.TIOCEXCL)
        except OSError as err:
            log.debug("TIOCEXCL on %s failed: %s", self.device, err)
        self._guard = fd

    def release_exclusive(self) -> None:
        """Clear TIOCEXCL so the device can be opened again (by our own reconnect)."""
        if self._guard is None:
            return
        with contextlib.suppress(OSError):
            fcntl.ioctl(self._guard, termios.TIOCNXCL)
        with contextlib.suppress(OSError):
            os.close(self._guard)
        self._guard = None

    def release(self) -> None:
        """Clear exclusive mode and remove our lock file (idempotent)."""
        self.release_exclusive()
        if self.lock_file is not None:
            if self._read_pid(self.lock_file) == os.getpid():
                with contextlib.suppress(FileNotFoundError):
                    self.lock_file.unlink()
            self.lock_file = None


class ExclusiveClient:
    """A client whose port stays exclusive: :meth:`open` sets TIOCEXCL after opening.

    Everything else is passed through to the wrapped :class:`nomad200.Client`.
    """

    def __init__(self, client: Any, lock: PortLock) -> None:
        self._client = client
        self._lock = lock

    def open(self) -> None:
        """Lift exclusive mode, open the port, set exclusive mode again."""
        self._lock.release_exclusive()
        try:
            self._client.open()
        finally:
            if self._client.is_open:
                self._lock.hold_exclusive()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._client, name)

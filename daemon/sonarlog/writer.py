"""The crash-safe sonarlog v1 writer.

Why SWMR, and what it guarantees
--------------------------------
HDF5 keeps its metadata (B-trees, dataspace extents, the free-space map) in caches and
writes it back in no particular order, so a process killed mid-flush can leave a plain HDF5
file that no longer opens. In SWMR (single-writer/multiple-reader) mode the library orders
its metadata writes so that the file on disk is a valid file at every moment: that is the
property we need, and it costs nothing on the hot path. On top of it:

* rows are buffered in memory and appended in batches (one resize + one write per batch);
* a background thread pushes the buffer to the file and calls ``H5Fflush`` every
  ``flush_interval`` seconds (0.5 s by default, at a fixed rate), so a reading handed to
  :meth:`LogWriter.append` is in the file, safe from a killed process, within about that;
* a second thread calls ``fsync`` after each push, so the reading is on stable storage,
  safe from power loss, one fsync later. A slow disk (an fsync can take seconds on a
  busy one) delays neither the next push nor :meth:`LogWriter.append`;
* each row carries ``seq`` and ``check`` (:mod:`sonarlog.integrity`) so a reader can drop
  rows whose extent reached the disk before their data did.

SWMR needs the v110 file format, and we pin it as the upper bound too (``libver=("v110",
"v110")``) so that HDF5 1.10, 1.12 and 1.14 readers open our files whatever newer library
wrote them. SWMR also forbids creating objects or attributes once it starts, so every
dataset (readings, poses, events, truth) and every root attribute is created up front.

A file left by a killed writer still has its "open for SWMR write" flag set; plain HDF5
readers refuse it, :func:`sonarlog.read_log` opens it in SWMR-read mode, and
``sonarproc recover`` writes a clean copy.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import logging
import os
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING

import numpy as np

from sonarlog.integrity import seal
from sonarlog.schema import (
    DEFAULT_SPEED_OF_SOUND,
    EVENT_DTYPE,
    FORMAT,
    FORMAT_VERSION,
    POSE_DTYPE,
    READING_DTYPE,
    STORED_READING_DTYPE,
    as_sensor_table,
)
from sonarlog.space import SpaceGuard

if TYPE_CHECKING:  # imported as a log is created (readers of CSV and bag logs never need it)
    import h5py

log = logging.getLogger(__name__)

LIBVER = ("v110", "v110")
_CHUNK_ROWS = 4096
_BATCH_ROWS = 8192  # write through without waiting for the timer once this many are pending

AttrValue = str | int | float | bool


def _software_version() -> str:
    try:
        from importlib.metadata import version

        return version("sonarmorph")
    except Exception:  # pragma: no cover - not installed
        return "unknown"


def _nan_fill(dtype: np.dtype) -> np.ndarray:
    fill = np.zeros((), dtype=dtype)
    fill["t"] = np.nan
    return fill


class LogWriter:
    """Append pose-tagged sonar readings to a new sonarlog v1 file, crash-safely.

    Parameters
    ----------
    path : path-like
        The file to create (an existing file is replaced).
    sensors : numpy.ndarray
        The transducer table, fields of :data:`sonarlog.SENSOR_DTYPE` (turret frame, SI).
    speed_of_sound : float, optional
        m/s, stored as the root attribute ``speed_of_sound``.
    robot : str, optional
        What produced the readings (robot name, ``"sonarsim"``, ...).
    attrs : mapping, optional
        Further root attributes (plan text, baud rate, ...); they must be known up front.
    truth : numpy.ndarray, optional
        The true surface as an ``(N, 2)`` array of x, y, stored as ``/truth/profile``.
    flush_interval : float, optional
        Seconds between background pushes to the file (each followed by an fsync in a
        thread of its own); 0 disables both threads (call :meth:`flush` yourself).
    reserve_bytes : int, optional
        Space held in a reserve file beside the log for closing it when the file system
        fills up (see :mod:`sonarlog.space`); 0 keeps none. Every batch is checked against
        the free space either way: one that does not fit is refused with
        ``OSError(ENOSPC)`` before HDF5 writes a byte, and the file closes cleanly with
        the rows written before it.

    Notes
    -----
    All methods are thread-safe. Readings reach the file in batches, at most about
    ``flush_interval`` after :meth:`append` returns, and stable storage one fsync later.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> from sonarlog import LogWriter, read_log, SENSOR_DTYPE, READING_DTYPE
    >>> sensors = np.zeros(1, SENSOR_DTYPE)
    >>> path = os.path.join(tempfile.mkdtemp(), "log.h5")
    >>> with LogWriter(path, sensors, robot="doc") as w:
    ...     w.append(np.zeros(3, READING_DTYPE))
    >>> len(read_log(path).readings)
    3
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        sensors: np.ndarray,
        *,
        speed_of_sound: float = DEFAULT_SPEED_OF_SOUND,
        robot: str = "",
        attrs: Mapping[str, AttrValue] | None = None,
        truth: np.ndarray | None = None,
        flush_interval: float = 0.5,
        reserve_bytes: int = 0,
    ) -> None:
        if not np.isfinite(speed_of_sound) or speed_of_sound <= 0:
            raise ValueError(f"speed_of_sound must be a positive number, got {speed_of_sound}")
        self.path = Path(path)
        table = as_sensor_table(sensors)
        self._lock = threading.RLock()
        self._pending: list[np.ndarray] = []
        self._pending_rows = 0
        self._pending_poses: list[np.ndarray] = []
        self._pending_events: list[np.ndarray] = []
        self._n_written = 0
        self._closed = False
        #: the first write failure (disk full, I/O error); later writes are not attempted
        self.error: OSError | None = None
        #: rows refused for want of space and never written (counted on close)
        self.dropped_on_close = 0

        import h5py

        # HDF5's own file lock would clash with the flock sonard holds on the log for the
        # whole run (flock locks belong to open files, not processes): the owner locks.
        self._file = h5py.File(self.path, "w", libver=LIBVER, locking=False)
        try:
            self._create_layout(table, speed_of_sound, robot, attrs or {}, truth)
            self._file.swmr_mode = True
        except BaseException:
            self._file.close()
            raise
        self._fd = os.open(self.path, os.O_RDONLY)
        self._file.flush()
        os.fsync(self._fd)
        try:
            self._space = SpaceGuard(self.path, reserve_bytes)
        except BaseException:
            self._file.close()
            os.close(self._fd)
            raise

        self._stop = threading.Event()
        self._sync_wanted = threading.Event()
        self._threads: list[threading.Thread] = []
        if flush_interval > 0:
            self._threads = [
                threading.Thread(
                    target=self._push_loop, args=(flush_interval,), name="sonarlog-push",
                    daemon=True,
                ),
                threading.Thread(target=self._sync_loop, name="sonarlog-fsync", daemon=True),
            ]  # fmt: skip
            for thread in self._threads:
                thread.start()

    def _create_layout(
        self,
        sensors: np.ndarray,
        speed_of_sound: float,
        robot: str,
        attrs: Mapping[str, AttrValue],
        truth: np.ndarray | None,
    ) -> None:
        f = self._file
        f.attrs["format"] = FORMAT
        f.attrs["format_version"] = np.int64(FORMAT_VERSION)
        f.attrs["speed_of_sound"] = float(speed_of_sound)
        f.attrs["robot"] = robot
        f.attrs["created"] = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        f.attrs["software"] = f"sonarmorph {_software_version()}"
        for key, value in attrs.items():
            f.attrs[key] = value
        f.create_dataset("sensors", data=sensors)
        f.create_dataset(
            "readings",
            shape=(0,),
            maxshape=(None,),
            dtype=STORED_READING_DTYPE,
            chunks=(_CHUNK_ROWS,),
            fillvalue=_nan_fill(STORED_READING_DTYPE),
        )
        f.create_dataset(
            "poses",
            shape=(0,),
            maxshape=(None,),
            dtype=POSE_DTYPE,
            chunks=(1024,),
            fillvalue=_nan_fill(POSE_DTYPE),
        )
        f.create_dataset(
            "events",
            shape=(0,),
            maxshape=(None,),
            dtype=EVENT_DTYPE,
            chunks=(64,),
            fillvalue=_nan_fill(EVENT_DTYPE),
        )
        if truth is not None:
            profile = np.asarray(truth, dtype=np.float64)
            if profile.ndim != 2 or profile.shape[1] != 2:
                raise ValueError(f"truth profile must have shape (N, 2), got {profile.shape}")
            f.create_dataset("truth/profile", data=profile)

    # -- appending -------------------------------------------------------------------

    def append(self, readings: np.ndarray) -> None:
        """Queue readings (fields of :data:`READING_DTYPE`) for the next batch write."""
        if len(readings) == 0:
            return
        missing = [n for n in READING_DTYPE.names or () if n not in (readings.dtype.names or ())]
        if missing:
            raise ValueError(f"readings lack field(s) {', '.join(missing)}")
        with self._lock:
            self._check_open()
            self._pending.append(np.array(readings, copy=True))
            self._pending_rows += len(readings)
            if self._pending_rows >= _BATCH_ROWS:
                self._write_pending()

    def append_poses(self, poses: np.ndarray) -> None:
        """Queue pose-stream rows (fields of :data:`POSE_DTYPE`)."""
        if len(poses) == 0:
            return
        rows = np.zeros(len(poses), dtype=POSE_DTYPE)
        for name in POSE_DTYPE.names or ():
            rows[name] = poses[name]
        with self._lock:
            self._check_open()
            self._pending_poses.append(rows)

    def event(self, kind: str, detail: str = "", t: float | None = None) -> None:
        """Record an event (``start``, ``stop``, ``reconnect``, ``error``, ...) at time ``t``."""
        row = np.zeros(1, dtype=EVENT_DTYPE)
        row["t"] = time.time() if t is None else t
        row["kind"] = kind.encode("utf-8")[:32]
        row["detail"] = detail.encode("utf-8")[:224]
        with self._lock:
            self._check_open()
            self._pending_events.append(row)

    def append_events(self, events: np.ndarray) -> None:
        """Queue ready-made event rows (fields of :data:`EVENT_DTYPE`), e.g. when copying a log."""
        if len(events) == 0:
            return
        rows = np.zeros(len(events), dtype=EVENT_DTYPE)
        for name in EVENT_DTYPE.names or ():
            rows[name] = events[name]
        with self._lock:
            self._check_open()
            self._pending_events.append(rows)

    @property
    def n_readings(self) -> int:
        """Readings accepted so far (written or pending)."""
        with self._lock:
            return self._n_written + self._pending_rows

    # -- durability ------------------------------------------------------------------

    def flush(self) -> None:
        """Write every pending row, flush HDF5's caches and fsync the file."""
        with self._lock:
            if self._closed:
                return
            self._push()
            os.fsync(self._fd)

    def _write_pending(self) -> None:
        if self.error is not None:
            raise self.error
        try:
            self._space.check(self._bytes_needed())
        except OSError as exc:
            self.error = exc
            raise
        # events first: a kill between two datasets then leaves an event (a gap, say)
        # without the readings after it, never readings whose gap event is lost
        if self._pending_events:
            self._extend(self._file["events"], np.concatenate(self._pending_events))
            self._pending_events.clear()
        if self._pending:
            batch = seal(np.concatenate(self._pending), self._n_written + 1)
            self._pending.clear()
            self._pending_rows = 0
            self._extend(self._file["readings"], batch)
            self._n_written += len(batch)
        if self._pending_poses:
            self._extend(self._file["poses"], np.concatenate(self._pending_poses))
            self._pending_poses.clear()

    def _bytes_needed(self) -> int:
        """File space the pending rows take: HDF5 allocates whole chunks as datasets grow."""
        need = 0
        for name, parts in (
            ("readings", self._pending),
            ("poses", self._pending_poses),
            ("events", self._pending_events),
        ):
            n_new = sum(len(p) for p in parts)
            if not n_new:
                continue
            ds = self._file[name]
            chunk = int((ds.chunks or (1,))[0])
            before = int(ds.shape[0])
            new_chunks = -(-(before + n_new) // chunk) - (-(-before // chunk))
            need += new_chunks * chunk * ds.dtype.itemsize
        return need

    @staticmethod
    def _extend(dataset: h5py.Dataset, rows: np.ndarray) -> None:
        start = dataset.shape[0]
        dataset.resize((start + len(rows),))
        dataset[start:] = rows
        dataset.flush()

    def _push(self) -> None:
        """Write every pending row and flush HDF5's caches (no fsync)."""
        with self._lock:
            if self._closed:
                return
            self._write_pending()
            self._file.flush()

    def _push_loop(self, interval: float) -> None:
        # a fixed rate: a push that starts late (a busy machine) does not delay the next
        due = time.monotonic() + interval
        while not self._stop.wait(max(0.0, due - time.monotonic())):
            due = max(due + interval, time.monotonic())
            try:
                self._push()
            except OSError as exc:  # disk full: the file stays as it was; close reports it
                if self.error is None:
                    self.error = exc
                    log.error("sonarlog: cannot write %s: %s", self.path, exc.strerror or exc)
            except Exception:  # keep pushing later; the next append or close reports it
                log.exception("sonarlog: background flush of %s failed", self.path)
            self._sync_wanted.set()

    def _sync_loop(self) -> None:
        while True:
            self._sync_wanted.wait()
            if self._stop.is_set():
                return
            self._sync_wanted.clear()
            try:
                os.fsync(self._fd)
            except OSError:  # the next push asks again; close reports a lasting failure
                log.exception("sonarlog: background fsync of %s failed", self.path)

    def _check_open(self) -> None:
        if self._closed:
            raise ValueError(f"{self.path}: log writer is closed")

    def close(self) -> None:
        """Flush everything and close the file (idempotent).

        After a write failure (:attr:`error`) the reserve is freed first and the rows still
        pending are written if they fit, else dropped and counted in
        :attr:`dropped_on_close`; the file is closed cleanly either way and the failure
        raised.
        """
        if self._threads:
            self._stop.set()
            self._sync_wanted.set()
            for thread in self._threads:
                thread.join()
            self._threads = []
        with self._lock:
            if self._closed:
                return
            failure = self.error
            try:
                if failure is None:
                    self.flush()
                else:
                    self._close_after_failure()
            finally:
                self._closed = True
                self._space.release()
                self._file.close()
                os.fsync(self._fd)
                os.close(self._fd)
            if failure is not None:
                raise failure

    def _close_after_failure(self) -> None:
        """Free the reserve and write what still fits (events first: they explain the end)."""
        self._space.release()
        self._space.refused = self.error = None
        try:
            self._write_pending()
        except OSError:  # still no room: keep the events, drop the rows
            self._space.refused = self.error = None
            self.dropped_on_close = self._pending_rows
            self._pending, self._pending_poses, self._pending_rows = [], [], 0
            with contextlib.suppress(OSError):
                self._write_pending()
        self._pending_events.clear()
        self._file.flush()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

"""The validating sonarlog v1 reader."""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sonarlog.errors import InvalidLogError
from sonarlog.integrity import intact_prefix
from sonarlog.opening import open_log_file
from sonarlog.schema import (
    EVENT_DTYPE,
    FORMAT,
    FORMAT_VERSION,
    POSE_DTYPE,
    READING_DTYPE,
    REQUIRED_ATTRS,
    REQUIRED_READING_FIELDS,
    REQUIRED_SENSOR_FIELDS,
    SENSOR_DTYPE,
    sensor_table_problem,
)
from sonarlog.state import CRASHED_ATTR, LogState, flock_held, integrity_warning, read_superblock

if TYPE_CHECKING:  # h5py loads as a log is opened: a CSV or bag log never needs it
    import h5py

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class TransducerPoses:
    """World poses of the transmitter and receiver of each reading (SI units).

    Attributes
    ----------
    tx_xy, rx_xy : numpy.ndarray
        ``(N, 2)`` positions in the world frame (m).
    tx_heading, rx_heading : numpy.ndarray
        ``(N,)`` lines of sight in the world frame (rad).
    tx_half_beamwidth, rx_half_beamwidth : numpy.ndarray
        ``(N,)`` half beam widths (rad).
    min_range, max_range : numpy.ndarray
        ``(N,)`` usable range of the receiver (m).
    """

    tx_xy: np.ndarray
    tx_heading: np.ndarray
    rx_xy: np.ndarray
    rx_heading: np.ndarray
    tx_half_beamwidth: np.ndarray
    rx_half_beamwidth: np.ndarray
    min_range: np.ndarray
    max_range: np.ndarray


@dataclass(frozen=True)
class SonarLog:
    """A sonarlog v1 file held in memory.

    Attributes
    ----------
    path : pathlib.Path
        Where it was read from.
    attrs : dict
        Root attributes (``format``, ``speed_of_sound``, ``robot``, ...).
    sensors : numpy.ndarray
        :data:`SENSOR_DTYPE` rows.
    readings : numpy.ndarray
        :data:`READING_DTYPE` rows, the intact prefix of the file's readings.
    truth : numpy.ndarray or None
        ``(N, 2)`` true surface profile, when the file has one.
    poses, events : numpy.ndarray or None
        The optional pose stream and event list.
    dropped_rows : int
        Torn rows at the end of ``/readings`` that were dropped (0 for a closed log).
    log_state : {"closed", "crashed", "cut"}
        How the file ended: ``"closed"`` by its writer; ``"crashed"`` when the writer died
        with the file open (still flagged open, or finalised by sonard afterwards, root
        attribute ``crashed_run``); ``"cut"`` when the file is shorter than HDF5 recorded
        (a copy that stopped early, a full disk). A log a live sonard is still writing
        reads as ``"crashed"`` with :attr:`live` set.
    live : bool
        A sonard holds the file's lock: it is being written now, the tail will grow.
    backward_steps : int
        How many times ``t`` goes back from one reading to the next (0 in a log that keeps
        the contract's non-decreasing order).

    Notes
    -----
    Callers that process a log (``sonarproc run``) should print :meth:`integrity_warning`
    when it is not None and store it with :attr:`intact_rows` and :attr:`dropped_rows` in
    their report: a crashed or cut log is read, but silently processing it would hide that
    readings are missing.
    """

    path: Path
    attrs: dict[str, Any]
    sensors: np.ndarray
    readings: np.ndarray
    truth: np.ndarray | None = None
    poses: np.ndarray | None = None
    events: np.ndarray | None = None
    dropped_rows: int = 0
    log_state: LogState = "closed"
    live: bool = False
    backward_steps: int = 0

    @property
    def intact_rows(self) -> int:
        """Readings kept: the intact prefix of ``/readings`` (``len(self.readings)``)."""
        return len(self.readings)

    @property
    def time_ordered(self) -> bool:
        """Whether ``t`` never goes back from one reading to the next."""
        return self.backward_steps == 0

    def integrity_warning(self) -> str | None:
        """One line for a crashed or cut log, None for a closed one.

        It names the file, the intact and dropped row counts and, unless sonard already
        finalised the log, the repair command ``sonarproc recover LOG``.

        Examples
        --------
        >>> import numpy as np
        >>> from sonarlog import READING_DTYPE, SENSOR_DTYPE
        >>> log = SonarLog(Path("run.h5"), {}, np.zeros(1, SENSOR_DTYPE),
        ...                np.zeros(5, READING_DTYPE), dropped_rows=2, log_state="crashed")
        >>> print(log.integrity_warning().replace("; ", ";\\n"))
        run.h5: its writer crashed: 5 intact readings, 2 torn rows dropped;
        to write a clean copy: sonarproc recover run.h5
        """
        if self.live:
            return f"{self.path}: still being written by sonard: {self.intact_rows} readings so far"
        return integrity_warning(
            self.path,
            self.log_state,
            intact=self.intact_rows,
            dropped=self.dropped_rows,
            finalised=bool(self.attrs.get(CRASHED_ATTR, False)),
        )

    @property
    def speed_of_sound(self) -> float:
        """Speed of sound (m/s) the times of flight were taken with."""
        return float(self.attrs["speed_of_sound"])

    def path_lengths(self, readings: np.ndarray | None = None) -> np.ndarray:
        """Return each reading's acoustic path length ``tof * speed_of_sound`` (m)."""
        r = self.readings if readings is None else readings
        return np.asarray(r["tof"], dtype=np.float64) * self.speed_of_sound

    def sensor_rows(self, ids: np.ndarray) -> np.ndarray:
        """Return the row in :attr:`sensors` of each transducer id in ``ids``.

        Raises
        ------
        InvalidLogError
            If an id has no ``/sensors`` row; the message lists the unknown ids.
        """
        ids = np.asarray(ids)
        order = np.argsort(self.sensors["id"], kind="stable")
        sorted_ids = self.sensors["id"][order]
        pos = np.searchsorted(sorted_ids, ids)
        pos_clipped = np.minimum(pos, max(len(sorted_ids) - 1, 0))
        known = (pos < len(sorted_ids)) & (
            sorted_ids[pos_clipped] == ids if len(sorted_ids) else False
        )
        if not np.all(known):
            unknown = sorted({int(i) for i in np.unique(ids[~known])})
            shown = ", ".join(str(i) for i in unknown[:10])
            raise InvalidLogError(
                f"{self.path}: reading(s) refer to sensor id(s) {shown} with no /sensors row"
            )
        return np.asarray(order[pos_clipped])

    def transducer_poses(self, readings: np.ndarray | None = None) -> TransducerPoses:
        """World poses of every reading's transmitter and receiver, in one vectorised pass.

        A sensor mounted at ``(sx, sy)`` with heading ``h`` in the turret frame is, for a
        reading with base position ``(x, y)`` and world turret heading ``turret``, at
        ``(x, y) + R(turret) (sx, sy)`` looking along ``turret + h``.
        """
        r = self.readings if readings is None else readings
        tx = self.sensors[self.sensor_rows(r["tx"])]
        rx = self.sensors[self.sensor_rows(r["rx"])]
        base = np.column_stack([r["x"], r["y"]]).astype(np.float64)
        cos_t, sin_t = np.cos(r["turret"]), np.sin(r["turret"])

        def place(s: np.ndarray) -> np.ndarray:
            return base + np.column_stack(
                [cos_t * s["x"] - sin_t * s["y"], sin_t * s["x"] + cos_t * s["y"]]
            )

        return TransducerPoses(
            tx_xy=place(tx),
            tx_heading=np.asarray(r["turret"] + tx["heading"], dtype=np.float64),
            rx_xy=place(rx),
            rx_heading=np.asarray(r["turret"] + rx["heading"], dtype=np.float64),
            tx_half_beamwidth=np.asarray(tx["half_beamwidth"], dtype=np.float64),
            rx_half_beamwidth=np.asarray(rx["half_beamwidth"], dtype=np.float64),
            min_range=np.asarray(rx["min_range"], dtype=np.float64),
            max_range=np.asarray(rx["max_range"], dtype=np.float64),
        )


def _attr(value: Any) -> Any:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.generic):
        return value.item()
    return value


def _check_attrs(path: Path, attrs: dict[str, Any]) -> None:
    fmt = attrs.get("format")
    if fmt != FORMAT:
        raise InvalidLogError(f"{path}: format is {fmt!r}, expected {FORMAT!r}")
    missing = [a for a in REQUIRED_ATTRS if a not in attrs]
    if missing:
        raise InvalidLogError(f"{path}: missing required attribute(s) {', '.join(missing)}")
    version = attrs["format_version"]
    if not isinstance(version, int) or isinstance(version, bool):
        raise InvalidLogError(f"{path}: format_version must be an integer, got {version!r}")
    if version > FORMAT_VERSION:
        raise InvalidLogError(
            f"{path}: format_version {version} is newer than this reader supports "
            f"({FORMAT_VERSION}); upgrade sonarmorph"
        )
    if version < 1:
        raise InvalidLogError(f"{path}: format_version {version} is not valid (must be 1)")
    c = attrs["speed_of_sound"]
    if not isinstance(c, (int, float)) or not np.isfinite(c) or c <= 0:
        raise InvalidLogError(f"{path}: speed_of_sound must be a positive number, got {c!r}")


def _dataset(path: Path, f: h5py.File, name: str, fields: tuple[str, ...]) -> h5py.Dataset:
    import h5py

    if name not in f or not isinstance(f[name], h5py.Dataset):
        raise InvalidLogError(f"{path}: missing required dataset /{name}")
    ds = f[name]
    have = ds.dtype.names or ()
    missing = [fld for fld in fields if fld not in have]
    if missing:
        raise InvalidLogError(f"{path}: missing required field {name}.{missing[0]}")
    for fld in fields:
        if not _numeric(ds.dtype[fld]):
            raise InvalidLogError(
                f"{path}: field {name}.{fld} must be a number, got type {ds.dtype[fld]}"
            )
    return ds


def _numeric(dtype: np.dtype) -> bool:
    """A scalar number (bool, integer or float): what every field of the contract is."""
    return dtype.shape == () and dtype.kind in "biuf"


def _read_prefix(ds: h5py.Dataset) -> np.ndarray:
    """Read a 1-D dataset; when part of it is unreadable, return the readable prefix."""
    try:
        return np.asarray(ds[()])
    except (OSError, RuntimeError, ValueError):
        pass
    step = ds.chunks[0] if ds.chunks else 1024
    parts: list[np.ndarray] = []
    for start in range(0, ds.shape[0], step):
        try:
            parts.append(np.asarray(ds[start : start + step]))
        except (OSError, RuntimeError, ValueError):
            break
    return np.concatenate(parts) if parts else np.zeros(0, dtype=ds.dtype)


def _project(rows: np.ndarray, dtype: np.dtype) -> np.ndarray:
    out = np.zeros(len(rows), dtype=dtype)
    for name in dtype.names or ():
        out[name] = rows[name]
    return out


def _valid_prefix(rows: np.ndarray) -> int:
    """Rows the disk fully received: checked rows when the writer sealed them, else finite t."""
    names = rows.dtype.names or ()
    if "seq" in names and "check" in names:
        n = intact_prefix(rows)
    else:
        bad = np.flatnonzero(~np.isfinite(rows["t"]))
        n = int(bad[0]) if len(bad) else len(rows)
    return n


def _optional_rows(f: h5py.File, name: str, dtype: np.dtype) -> np.ndarray | None:
    import h5py

    if name not in f or not isinstance(f[name], h5py.Dataset):
        return None
    rows = _read_prefix(f[name])
    if not set(dtype.names or ()) <= set(rows.dtype.names or ()) or rows.ndim != 1:
        return None
    wanted = dtype.names or ()
    if not all(_numeric(rows.dtype[n]) or dtype[n].kind == "S" for n in wanted):
        return None  # an optional table of the wrong types is ignored, like a missing one
    good = np.isfinite(rows["t"])
    return _project(rows[: int(np.argmin(good)) if not good.all() else len(rows)], dtype)


def read_log(path: str | os.PathLike[str]) -> SonarLog:
    """Read and validate a sonarlog v1 file.

    The reader accepts files holding only the contract's required fields, files whose
    writer was killed or is still writing (SWMR), and cut copies; it keeps the intact
    prefix of ``/readings`` and reports the dropped tail in :attr:`SonarLog.dropped_rows`.

    Parameters
    ----------
    path : path-like
        The ``.h5`` file.

    Returns
    -------
    SonarLog

    Raises
    ------
    InvalidLogError
        With a one-line message naming the file: not HDF5, wrong ``format``, newer
        ``format_version``, missing attribute, dataset or field.
    """
    p = Path(path)
    state, live = _state_before_opening(p)
    with open_log_file(p) as f:
        try:
            attrs = {k: _attr(v) for k, v in f.attrs.items()}
            _check_attrs(p, attrs)
            sensors_ds = _dataset(p, f, "sensors", REQUIRED_SENSOR_FIELDS)
            readings_ds = _dataset(p, f, "readings", REQUIRED_READING_FIELDS)
            if readings_ds.ndim != 1 or sensors_ds.ndim != 1:
                raise InvalidLogError(f"{p}: /sensors and /readings must be 1-D tables")
            sensors = _project(np.asarray(sensors_ds[()]), SENSOR_DTYPE)
            problem = sensor_table_problem(sensors)
            if problem is not None:
                raise InvalidLogError(f"{p}: /sensors.{problem}")
            raw = _read_prefix(readings_ds)
            keep = _valid_prefix(raw)
            dropped = readings_ds.shape[0] - keep
            readings = _project(raw[:keep], READING_DTYPE)
            truth = None
            if "truth/profile" in f:
                truth = np.asarray(f["truth/profile"][()], dtype=np.float64)
                if truth.ndim != 2 or truth.shape[1] != 2:
                    raise InvalidLogError(f"{p}: /truth/profile must have shape (N, 2)")
            poses = _optional_rows(f, "poses", POSE_DTYPE)
            events = _optional_rows(f, "events", EVENT_DTYPE)
        except InvalidLogError:
            raise
        except (OSError, RuntimeError, KeyError, TypeError) as err:
            first = (str(err).strip().splitlines() or [type(err).__name__])[0]
            raise InvalidLogError(f"{p}: unreadable sonarlog ({first})") from err
    if state == "cut":
        # the cut file was salvaged through a clean copy, which counted what it dropped
        attrs.pop("recovered_from", None)
        dropped += int(attrs.pop("recovered_dropped_rows", 0))
    elif attrs.get(CRASHED_ATTR):
        state = "crashed"  # finalised by sonard: the clean copy counted what it dropped
        dropped += int(attrs.get("recovered_dropped_rows", 0))
    if dropped:
        log.warning("%s: dropped %d torn row(s) at the end of /readings", p, dropped)
    backward = int(np.count_nonzero(np.diff(readings["t"]) < 0))
    if backward:
        log.warning("%s: t goes back %d time(s): readings are not in time order", p, backward)
    return SonarLog(
        path=p,
        attrs=attrs,
        sensors=sensors,
        readings=readings,
        truth=truth,
        poses=poses,
        events=events,
        dropped_rows=int(dropped),
        log_state=state,
        live=live,
        backward_steps=backward,
    )


def _state_before_opening(path: Path) -> tuple[LogState, bool]:
    """(state from the superblock, whether a live sonard holds the file's lock)."""
    try:
        info = read_superblock(path)
    except OSError:
        return "closed", False  # open_log_file reports the file itself
    if info is None:
        return "closed", False
    if info.cut:
        return "cut", False
    if not info.open_for_write:
        return "closed", False
    return "crashed", flock_held(path)

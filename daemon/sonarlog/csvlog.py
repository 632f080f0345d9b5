"""Logs from any robot: a readings CSV plus a sensors YAML, read into a :class:`SonarLog`.

The CSV has a header row naming its columns (any order, extra columns ignored):

=========  ========  =====================================================================
column     unit      meaning
=========  ========  =====================================================================
t          s         time of firing (any epoch)
tx, rx     --        transmitting and receiving transducer ids (integers, in the YAML)
tof        s         round-trip time of flight; **or** ``range`` (m), half the path length
x, y       m         robot base position in the world at firing
theta      rad       robot base heading in the world (degrees with ``degrees=True``)
turret     rad       optional: turret heading in the world (default: ``theta``, a robot
                     without a turret)
echo       --        optional: 0 for a firing's first echo, 1 for the second, ... (default 0)
flags      --        optional: bit 0 out of range / no echo, bit 1 crosstalk (default 0)
=========  ========  =====================================================================

A range at or beyond the receiver's ``max_range`` (or ``+inf``) is "no echo", as in bags
(:func:`sonarlog.sources.assemble.no_echo_mask`): the reading gets flag bit 0 and is
counted in the root attribute ``no_echo_at_max_range``. Angles must lie within +-2 pi; a
heading column of whole numbers reaching beyond pi is refused as degrees (see
:func:`check_angles`).

The sensors YAML holds the same fields as sonarlog's ``/sensors`` table, SI units::

    robot: my-robot          # optional
    speed_of_sound: 343.3    # m/s, optional
    sensors:
      - {id: 0, x: 0.22, y: 0.0, heading: 0.0, half_beamwidth: 0.2182,
         min_range: 0.15, max_range: 10.7}
"""

from __future__ import annotations

import csv
import math
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import DEFAULT_SPEED_OF_SOUND, FLAG_NO_ECHO, READING_DTYPE, SonarLog
from sonarlog.errors import InvalidLogError
from sonarlog.sources.assemble import no_echo_mask
from sonarlog.sources.presets import SensorSet, load_sensors

__all__ = [
    "CSV_ANGLES",
    "CSV_OPTIONAL",
    "CSV_REQUIRED",
    "check_angles",
    "load_sensors_yaml",
    "read_csv_log",
    "read_truth_csv",
]

#: Columns every readings CSV must have (plus exactly one of ``tof`` and ``range``).
CSV_REQUIRED = ("t", "tx", "rx", "x", "y", "theta")
#: Columns a readings CSV may have (``turret`` defaults to ``theta``).
CSV_OPTIONAL = ("turret", "echo", "flags")
#: The angle columns, in radians (or degrees with ``degrees=True``).
CSV_ANGLES = ("theta", "turret")
#: Root attribute counting the readings flagged no echo because of their range.
NO_ECHO_ATTR = "no_echo_at_max_range"


def load_sensors_yaml(path: str | Path) -> SensorSet:
    """Read and validate a sensors YAML file (or a shipped preset, by name).

    The format is the one of :func:`sonarlog.sources.load_sensors`: ``robot``, optional
    ``speed_of_sound`` and a ``sensors`` list of mounts in the turret frame (m, rad).

    Raises
    ------
    InvalidLogError (a ValueError)
        One line naming the file, the field and the problem.
    """
    return load_sensors(path)


def _header(path: Path) -> tuple[list[str], int]:
    """The column names (lower case) and how many lines precede the data."""
    with path.open(newline="", encoding="utf-8") as fh:
        for line_no, row in enumerate(csv.reader(fh)):
            if row and not row[0].lstrip().startswith("#"):
                return [c.strip().lower() for c in row], line_no + 1
    raise InvalidLogError(f"{path}: empty file, expected a header row")


def _load_numbers(path: Path, ncols: int, skip: int) -> npt.NDArray[np.float64]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "input contained no data"
        try:
            data = np.loadtxt(
                path, delimiter=",", skiprows=skip, comments="#", ndmin=2, dtype=np.float64
            )
        except ValueError as err:
            raise InvalidLogError(f"{path}: {str(err).splitlines()[0]}") from err
    if data.size == 0:
        return np.zeros((0, ncols))
    if data.shape[1] != ncols:
        raise InvalidLogError(f"{path}: rows have {data.shape[1]} values, header has {ncols}")
    return data


def _integral(path: Path, name: str, col: npt.NDArray[np.float64], lo: int, hi: int) -> None:
    bad = ~np.isfinite(col) | (col != np.round(col)) | (col < lo) | (col > hi)
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        raise InvalidLogError(
            f"{path}: column {name!r} must hold integers {lo}..{hi} (data row {row + 1})"
        )


def check_angles(
    path: str | Path, name: str, values: npt.ArrayLike, *, degrees: bool = False
) -> npt.NDArray[np.float64]:
    """An angle column in radians, refused when it cannot be radians.

    Two tests, each with a physical reason:

    * any ``|value| > 2 pi`` (360 degrees with ``degrees=True``): a heading is an angle
      on the circle, so a larger value is either another unit or an unwrapped odometry
      total that the map would still read correctly only by luck;
    * (radians only) every value a whole number and the largest ``|value|`` beyond pi: a
      heading measured in radians is a whole number only by accident (odometry
      integrates wheel turns; pi/2, pi are not whole), while a log in degrees holds
      whole degrees from 0 up; a column of 0 to 6 degrees would pass the first test.

    Parameters
    ----------
    path : path-like
        The file, for the message.
    name : str
        The column, for the message.
    values : array_like
        The column as read.
    degrees : bool
        The column holds degrees (``--degrees``); it is converted.

    Returns
    -------
    numpy.ndarray
        The angles in radians.

    Raises
    ------
    InvalidLogError (a ValueError)
        One line naming the file, the column and what to do.

    Examples
    --------
    >>> check_angles("r.csv", "theta", [0.0, 1.5708]).round(4).tolist()
    [0.0, 1.5708]
    >>> check_angles("r.csv", "theta", [0.0, 90.0], degrees=True).round(4).tolist()
    [0.0, 1.5708]
    >>> check_angles("r.csv", "theta", [0.0, 4.0])
    Traceback (most recent call last):
    ...
    sonarlog.errors.InvalidLogError: r.csv: column 'theta' looks like degrees (...)...
    """
    a = np.asarray(values, dtype=np.float64)
    rad = np.radians(a) if degrees else a
    if a.size == 0:
        return rad
    finite = np.isfinite(rad)
    big = finite & (np.abs(rad) > 2.0 * np.pi + 1e-9)
    if np.any(big):
        row = int(np.flatnonzero(big)[0])
        limit = "+-360 degrees" if degrees else "+-2 pi rad"
        hint = "" if degrees else "; degrees? pass --degrees"
        raise InvalidLogError(
            f"{path}: column {name!r} holds {a[row]:g} at data row {row + 1}, outside {limit}{hint}"
        )
    top = float(np.max(np.abs(a[finite]), initial=0.0))
    if not degrees and top > np.pi and np.all(a[finite] == np.round(a[finite])):
        raise InvalidLogError(
            f"{path}: column {name!r} looks like degrees (whole numbers up to {top:g}, "
            "beyond pi); pass --degrees, or convert it to radians"
        )
    return rad


def _flag_no_echo(
    readings: np.ndarray, range_m: npt.NDArray[np.float64], sensors: np.ndarray
) -> int:
    """Flag readings at or beyond their receiver's ``max_range``; how many were new."""
    by_id = sensors[np.argsort(sensors["id"], kind="stable")]  # a sensors file has >= 1 row
    pos = np.minimum(np.searchsorted(by_id["id"], readings["rx"]), by_id.size - 1)
    # an unknown receiver is left for the run to name (it refuses the log)
    max_range = np.where(by_id["id"][pos] == readings["rx"], by_id["max_range"][pos], np.inf)
    new = no_echo_mask(range_m, max_range) & ((readings["flags"] & FLAG_NO_ECHO) == 0)
    readings["flags"][new] |= FLAG_NO_ECHO
    return int(new.sum())


def read_csv_log(
    path: str | Path,
    sensors: str | Path,
    *,
    truth: npt.ArrayLike | None = None,
    degrees: bool = False,
    speed_of_sound: float | None = None,
) -> SonarLog:
    """Read a readings CSV and a sensors YAML into an in-memory :class:`sonarlog.SonarLog`.

    Parameters
    ----------
    path : path-like
        The readings CSV (columns in the module docstring).
    sensors : path-like
        The sensors YAML.
    truth : array_like, shape (N, 2), optional
        A true profile to compare against (see :func:`read_truth_csv`).
    degrees : bool
        ``theta`` and ``turret`` are in degrees.
    speed_of_sound : float, optional
        m/s, replacing the sensors YAML's (default :data:`sonarlog.DEFAULT_SPEED_OF_SOUND`);
        a ``range`` column is converted to times of flight with it.

    Returns
    -------
    SonarLog
        Readings at or beyond their receiver's ``max_range`` carry the no-echo flag; the
        root attribute ``no_echo_at_max_range`` says how many the reader flagged.

    Raises
    ------
    InvalidLogError (a ValueError)
        One line naming the file and the problem (missing column, non-number, an angle
        column outside +-2 pi or in degrees, ...).
    """
    p = Path(path)
    spec = load_sensors_yaml(sensors)
    names, skip = _header(p)
    if len(set(names)) != len(names):
        raise InvalidLogError(f"{p}: header repeats a column name")
    missing = [c for c in CSV_REQUIRED if c not in names]
    if missing:
        raise InvalidLogError(f"{p}: missing required column(s) {', '.join(missing)}")
    has_tof, has_range = "tof" in names, "range" in names
    if has_tof == has_range:
        raise InvalidLogError(f"{p}: needs exactly one of the columns 'tof' (s) and 'range' (m)")
    data = _load_numbers(p, len(names), skip)
    col = {n: data[:, i] for i, n in enumerate(names)}
    readings = np.zeros(data.shape[0], dtype=READING_DTYPE)
    for name in ("t", "x", "y", *(a for a in CSV_ANGLES if a in col)):
        if not np.all(np.isfinite(col[name])):
            row = int(np.flatnonzero(~np.isfinite(col[name]))[0])
            raise InvalidLogError(f"{p}: column {name!r} is not finite (data row {row + 1})")
        angle = name in CSV_ANGLES
        readings[name] = check_angles(p, name, col[name], degrees=degrees) if angle else col[name]
    if "turret" not in col:
        readings["turret"] = readings["theta"]
    for name in ("tx", "rx"):
        _integral(p, name, col[name], -32768, 32767)
        readings[name] = col[name]
    if "echo" in col:
        _integral(p, "echo", col["echo"], 0, 255)
        readings["echo"] = col["echo"]
    if "flags" in col:
        _integral(p, "flags", col["flags"], 0, 65535)
        readings["flags"] = col["flags"]
    c = next(v for v in (speed_of_sound, spec.speed_of_sound, DEFAULT_SPEED_OF_SOUND) if v)
    # a time or range too large to convert (1e308) overflows to inf: beyond every
    # max_range, so the reading is flagged no-echo below, like any other out-of-range one
    with np.errstate(over="ignore"):
        readings["tof"] = col["tof"] if has_tof else 2.0 * col["range"] / c
        range_m = 0.5 * c * col["tof"] if has_tof else col["range"]
    no_echo = _flag_no_echo(readings, range_m, spec.table)
    t = None if truth is None else np.asarray(truth, dtype=np.float64)
    attrs: dict[str, Any] = {
        "format": "sonarlog",
        "format_version": 1,
        "speed_of_sound": c,
        "robot": spec.robot,
        "created": "",
        "source": f"csv:{p.name}",
        NO_ECHO_ATTR: no_echo,
    }
    return SonarLog(path=p, attrs=attrs, sensors=spec.table, readings=readings, truth=t)


def _truth_rows(path: Path, ncols: int, skip: int) -> list[list[float] | None]:
    """The data rows as numbers, ``None`` for a separator (a blank line)."""
    rows: list[list[float] | None] = []
    with path.open(newline="", encoding="utf-8") as fh:
        for line_no, row in enumerate(csv.reader(fh), start=1):
            if line_no <= skip or (row and row[0].lstrip().startswith("#")):
                continue
            if not row or all(not v.strip() for v in row):
                rows.append(None)
                continue
            if len(row) != ncols:
                raise InvalidLogError(
                    f"{path}: line {line_no} has {len(row)} values, header has {ncols}"
                )
            try:
                rows.append([float(v) for v in row])
            except ValueError:
                raise InvalidLogError(
                    f"{path}: line {line_no} holds a value that is not a number"
                ) from None
    return rows


def read_truth_csv(path: str | Path) -> npt.NDArray[np.float64]:
    r"""Read a true profile: one or several polylines from a CSV with header ``x,y`` (m).

    Polylines are separated by a blank line or by a row of NaN (``nan,nan``); each needs
    at least 2 points. Several polylines come back as one array with a NaN row between
    them, the layout of sonarlog's ``/truth/profile`` (format v1.1).

    Returns
    -------
    numpy.ndarray, shape (N, 2)

    Raises
    ------
    InvalidLogError (a ValueError)
        One line naming the file and the problem.

    Examples
    --------
    >>> import tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = Path(d) / "truth.csv"
    ...     _ = p.write_text("x,y\n0,1\n1,1\n\n2,0\n2,1\nnan,nan\n3,0\n4,0\n")
    ...     read_truth_csv(p).tolist()
    [[0.0, 1.0], [1.0, 1.0], [nan, nan], [2.0, 0.0], [2.0, 1.0], [nan, nan], [3.0, 0.0], [4.0, 0.0]]
    """
    p = Path(path)
    names, skip = _header(p)
    if "x" not in names or "y" not in names:
        raise InvalidLogError(f"{p}: a truth profile CSV needs columns x and y")
    ix, iy = names.index("x"), names.index("y")
    pieces: list[list[tuple[float, float]]] = [[]]
    for row in _truth_rows(p, len(names), skip):
        xy = None if row is None else (row[ix], row[iy])
        if xy is None or (math.isnan(xy[0]) and math.isnan(xy[1])):
            pieces.append([])  # a separator; several in a row, or at an end, are harmless
            continue
        if not (math.isfinite(xy[0]) and math.isfinite(xy[1])):
            raise InvalidLogError(
                f"{p}: x and y must both be finite, or both nan to separate polylines "
                f"(got {xy[0]:g}, {xy[1]:g})"
            )
        pieces[-1].append(xy)
    lines = [np.asarray(piece, dtype=np.float64) for piece in pieces if piece]
    if not lines or any(len(line) < 2 for line in lines):
        raise InvalidLogError(f"{p}: a truth profile needs polylines of at least 2 finite points")
    gap = np.full((1, 2), np.nan)
    out = [lines[0]]
    for line in lines[1:]:
        out += [gap, line]
    return np.concatenate(out)

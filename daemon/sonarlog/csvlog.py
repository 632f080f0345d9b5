"""Logs from any robot: a readings CSV plus a sensors YAML, read into a :class:`SonarLog`.

The CSV has a header row naming its columns (any order, extra columns ignored):

=========  ========  =====================================================================
column     unit      meaning
=========  ========  =====================================================================
t          s         time of firing (any epoch)
tx, rx     --        transmitting and receiving transducer ids (integers, in the YAML)
tof        s         round-trip time of flight; **or** ``range`` (m), half the path length
x, y       m         robot base position in the world at firing
theta      rad       robot base heading in the world
turret     rad       turret heading in the world (equal to theta for a robot without one)
echo       --        optional: 0 for a firing's first echo, 1 for the second, ... (default 0)
flags      --        optional: bit 0 out of range / no echo, bit 1 crosstalk (default 0)
=========  ========  =====================================================================

The sensors YAML holds the same fields as sonarlog's ``/sensors`` table, SI units::

    robot: my-robot          # optional
    speed_of_sound: 343.3    # m/s, optional
    sensors:
      - {id: 0, x: 0.22, y: 0.0, heading: 0.0, half_beamwidth: 0.2182,
         min_range: 0.15, max_range: 10.7}
"""

from __future__ import annotations

import csv
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import DEFAULT_SPEED_OF_SOUND, READING_DTYPE, SonarLog
from sonarlog.errors import InvalidLogError
from sonarlog.sources.presets import SensorSet, load_sensors

__all__ = [
    "CSV_OPTIONAL",
    "CSV_REQUIRED",
    "load_sensors_yaml",
    "read_csv_log",
    "read_truth_csv",
]

#: Columns every readings CSV must have (plus exactly one of ``tof`` and ``range``).
CSV_REQUIRED = ("t", "tx", "rx", "x", "y", "theta", "turret")
#: Columns a readings CSV may have.
CSV_OPTIONAL = ("echo", "flags")


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


def read_csv_log(
    path: str | Path, sensors: str | Path, *, truth: npt.ArrayLike | None = None
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

    Raises
    ------
    InvalidLogError (a ValueError)
        One line naming the file and the problem (missing column, non-number, ...).
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
    for name in ("t", "x", "y", "theta", "turret"):
        readings[name] = col[name]
    for name in ("tx", "rx"):
        _integral(p, name, col[name], -32768, 32767)
        readings[name] = col[name]
    if "echo" in col:
        _integral(p, "echo", col["echo"], 0, 255)
        readings["echo"] = col["echo"]
    if "flags" in col:
        _integral(p, "flags", col["flags"], 0, 65535)
        readings["flags"] = col["flags"]
    c = spec.speed_of_sound if spec.speed_of_sound is not None else DEFAULT_SPEED_OF_SOUND
    readings["tof"] = col["tof"] if has_tof else 2.0 * col["range"] / c
    for name in ("t", "x", "y", "theta", "turret"):
        if not np.all(np.isfinite(readings[name])):
            row = int(np.flatnonzero(~np.isfinite(readings[name]))[0])
            raise InvalidLogError(f"{p}: column {name!r} is not finite (data row {row + 1})")
    t = None if truth is None else np.asarray(truth, dtype=np.float64)
    attrs: dict[str, Any] = {
        "format": "sonarlog",
        "format_version": 1,
        "speed_of_sound": c,
        "robot": spec.robot,
        "created": "",
        "source": f"csv:{p.name}",
    }
    return SonarLog(path=p, attrs=attrs, sensors=spec.table, readings=readings, truth=t)


def read_truth_csv(path: str | Path) -> npt.NDArray[np.float64]:
    """Read a true profile from a CSV with header ``x,y`` (m); returns an ``(N, 2)`` array."""
    p = Path(path)
    names, skip = _header(p)
    if "x" not in names or "y" not in names:
        raise InvalidLogError(f"{p}: a truth profile CSV needs columns x and y")
    data = _load_numbers(p, len(names), skip)
    out = np.column_stack((data[:, names.index("x")], data[:, names.index("y")]))
    if out.shape[0] < 2 or not np.all(np.isfinite(out)):
        raise InvalidLogError(f"{p}: a truth profile needs at least 2 finite points")
    return out

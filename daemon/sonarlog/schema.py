"""sonarlog v1 schema: the record layouts and attribute names (docs/formats.md).

All quantities are SI (m, s, rad). The required fields are fixed by the contract; this
writer adds two integrity fields to every reading, ``seq`` and ``check``, which readers use
to find the torn tail of a log whose writer was killed (see :mod:`sonarlog.integrity`).
"""

from __future__ import annotations

import numpy as np

FORMAT = "sonarlog"
FORMAT_VERSION = 1

#: Root attributes every sonarlog v1 file must carry.
REQUIRED_ATTRS = ("format", "format_version", "speed_of_sound", "robot", "created")

#: Bit 0 of ``flags``: out of range, no echo.
FLAG_NO_ECHO = 1
#: Bit 1 of ``flags``: suspected crosstalk.
FLAG_CROSSTALK = 2

#: Speed of sound in air at room temperature used by the paper (m/s).
DEFAULT_SPEED_OF_SOUND = 343.3

SENSOR_DTYPE = np.dtype(
    [
        ("id", "<i2"),
        ("x", "<f8"),
        ("y", "<f8"),
        ("heading", "<f8"),
        ("half_beamwidth", "<f8"),
        ("min_range", "<f8"),
        ("max_range", "<f8"),
    ]
)

READING_DTYPE = np.dtype(
    [
        ("t", "<f8"),
        ("tx", "<i2"),
        ("rx", "<i2"),
        ("echo", "u1"),
        ("tof", "<f8"),
        ("x", "<f8"),
        ("y", "<f8"),
        ("theta", "<f8"),
        ("turret", "<f8"),
        ("flags", "<u2"),
    ]
)

#: What this writer stores on disk: the contract's fields plus the integrity fields.
STORED_READING_DTYPE = np.dtype([*READING_DTYPE.descr, ("seq", "<u4"), ("check", "<u4")])

POSE_DTYPE = np.dtype(
    [("t", "<f8"), ("x", "<f8"), ("y", "<f8"), ("theta", "<f8"), ("turret", "<f8")]
)

#: Events are short fixed-width UTF-8 strings: variable-length strings live in the global
#: heap, which SWMR appends do not handle as robustly as fixed-size rows.
EVENT_DTYPE = np.dtype([("t", "<f8"), ("kind", "S32"), ("detail", "S224")])

REQUIRED_SENSOR_FIELDS = SENSOR_DTYPE.names or ()
REQUIRED_READING_FIELDS = READING_DTYPE.names or ()


def empty_readings(n: int = 0) -> np.ndarray:
    """Return ``n`` zeroed readings of :data:`READING_DTYPE`.

    Examples
    --------
    >>> empty_readings(2).dtype.names[:3]
    ('t', 'tx', 'rx')
    """
    return np.zeros(n, dtype=READING_DTYPE)


def as_sensor_table(sensors: np.ndarray) -> np.ndarray:
    """Return ``sensors`` as a :data:`SENSOR_DTYPE` array, checking fields and unique ids.

    Raises
    ------
    ValueError
        If a required field is missing or an id repeats.
    """
    missing = [f for f in REQUIRED_SENSOR_FIELDS if f not in (sensors.dtype.names or ())]
    if missing:
        raise ValueError(f"sensor table lacks field(s) {', '.join(missing)}")
    table = np.empty(len(sensors), dtype=SENSOR_DTYPE)
    for name in REQUIRED_SENSOR_FIELDS:
        table[name] = sensors[name]
    if len(np.unique(table["id"])) != len(table):
        raise ValueError("sensor ids must be unique")
    return table


#: Largest ``max_range`` a sensor table may hold (m). An ultrasonic ranger in air hears at
#: most about 11 m (the Polaroid 6500's 10.7 m); a kilometre leaves room for any sonar in
#: air, and a larger value is a corrupt table, not a sensor.
MAX_RANGE_LIMIT_M = 1000.0


def sensor_table_problem(sensors: np.ndarray) -> str | None:
    """What makes a sensor table unusable, as ``"field: problem"``, or ``None``.

    A reading names its transducer by id, so ids are unique; mounts are finite; a half
    beamwidth lies in [0, pi] rad and ranges in [0, :data:`MAX_RANGE_LIMIT_M`] m (a zero
    is a table that leaves the value unset, which the readers of older logs accept).

    Examples
    --------
    >>> t = np.zeros(2, SENSOR_DTYPE)
    >>> t["id"], t["half_beamwidth"], t["max_range"] = [0, 1], 0.2, 10.7
    >>> sensor_table_problem(t) is None
    True
    >>> t["max_range"] = 1e308
    >>> sensor_table_problem(t)
    'max_range: must be in [0, 1000] m'
    """
    if np.unique(sensors["id"]).size != sensors.size:
        return "id: must be unique (a transducer per id)"
    for name in ("x", "y", "heading"):
        if not np.all(np.isfinite(sensors[name])):
            return f"{name}: must be finite"
    hbw = sensors["half_beamwidth"]
    if not np.all((hbw >= 0.0) & (hbw <= np.pi)):
        return "half_beamwidth: must be in [0, pi] rad"
    for name in ("min_range", "max_range"):
        v = sensors[name]
        if not np.all((v >= 0.0) & (v <= MAX_RANGE_LIMIT_M)):
            return f"{name}: must be in [0, {MAX_RANGE_LIMIT_M:g}] m"
    return None

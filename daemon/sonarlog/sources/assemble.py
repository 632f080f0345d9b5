"""From decoded sonar values and a pose track to an in-memory :class:`sonarlog.SonarLog`.

Every reader (ROS bags, Player logs) decodes its messages into :class:`RawValues` (one row
per sonar value, in message order) and a :class:`~sonarlog.sources.poses.PoseTrack`; this
module does the rest with numpy: stale repeats, invalid values, the no-echo flag, poses
interpolated at each stamp, ranges turned into times of flight.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog.acoustics import speed_of_sound_at
from sonarlog.reader import SonarLog
from sonarlog.schema import (
    DEFAULT_SPEED_OF_SOUND,
    FLAG_NO_ECHO,
    FORMAT,
    FORMAT_VERSION,
    READING_DTYPE,
)
from sonarlog.sources.errors import SourceError
from sonarlog.sources.poses import PoseTrack
from sonarlog.sources.stale import refired_mask, stale_mask
from sonarlog.sources.summary import ImportCounts

__all__ = [
    "NO_ECHO_TOLERANCE",
    "Assembled",
    "RawValues",
    "assemble",
    "no_echo_mask",
    "speed_of_sound_for",
]

#: A value within this of ``max_range`` (m) counts as no echo: drivers that report the
#: maximum as an end point lose a little of it to float32 rounding.
NO_ECHO_TOLERANCE = 5e-4


def no_echo_mask(range_m: npt.ArrayLike, max_range: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """True where a range means "no echo": at or beyond its sensor's ``max_range``.

    Drivers (RosAria, p2os, most CSV exports) write the maximum range, or ``+inf``
    (REP 117), when the receiver heard nothing before it stopped listening; a real echo
    from exactly the end of the listening window cannot be told apart from that, so it is
    treated the same way. Within :data:`NO_ECHO_TOLERANCE` of the maximum counts too
    (float32 rounding). NaN is not "no echo" (it is an invalid value).

    >>> no_echo_mask([1.0, 3.9999, 4.0, 7.0, np.inf, np.nan], 4.0).tolist()
    [False, True, True, True, True, False]
    """
    r = np.asarray(range_m, dtype=np.float64)
    return np.asarray(r >= np.asarray(max_range, dtype=np.float64) - NO_ECHO_TOLERANCE)


@dataclass(frozen=True)
class RawValues:
    """Decoded sonar values, one row per value, in the order the messages came.

    Attributes
    ----------
    t : numpy.ndarray
        Stamp of each value (s).
    sensor : numpy.ndarray
        Transducer id.
    range : numpy.ndarray
        Range (m): half the acoustic path. ``+inf`` means no echo (REP 117).
    key : numpy.ndarray
        The value's exact bits, for stale detection.
    messages : int
        How many messages the values came from.
    """

    t: npt.NDArray[np.float64]
    sensor: npt.NDArray[np.int64]
    range: npt.NDArray[np.float64]
    key: npt.NDArray[np.int64]
    messages: int


@dataclass(frozen=True)
class Assembled:
    """What :func:`assemble` returns: the log and its counts."""

    log: SonarLog
    counts: ImportCounts


def assemble(
    raw: RawValues,
    track: PoseTrack,
    sensors: np.ndarray,
    *,
    speed_of_sound: float,
    path: Path,
    attrs: dict[str, Any],
    drop_stale: bool = True,
) -> Assembled:
    """Build the log: drop stale and invalid values, flag no echo, add poses and tof.

    A value is *invalid* when it is NaN, negative or ``-inf`` (REP 117: too close). A value
    at or beyond its sensor's ``max_range`` (or ``+inf``) is kept with the no-echo flag and
    the time of flight of ``max_range``. Values outside the pose track's time span are
    dropped. Readings come out sorted by time (stable, so a message's order is kept).
    """
    rows = np.searchsorted(np.sort(sensors["id"]), raw.sensor)
    by_id = sensors[np.argsort(sensors["id"], kind="stable")]
    max_range = by_id["max_range"][np.minimum(rows, max(len(by_id) - 1, 0))]

    stale = np.zeros(raw.t.size, dtype=bool)
    if drop_stale:
        stale = stale_mask(raw.sensor, raw.key)
        stale &= ~refired_mask(raw.sensor, raw.t, stale)
    invalid = ~stale & (np.isnan(raw.range) | (raw.range < 0) | ~np.isfinite(raw.t))
    keep = ~stale & ~invalid
    x, y, theta, inside = track.at(np.where(keep, raw.t, np.nan))
    outside = keep & ~inside
    keep &= inside

    rng = raw.range[keep]
    no_echo = no_echo_mask(rng, max_range[keep])
    rng = np.where(no_echo, max_range[keep], rng)
    out = np.zeros(int(keep.sum()), dtype=READING_DTYPE)
    out["t"] = raw.t[keep]
    out["tx"] = out["rx"] = raw.sensor[keep]
    out["tof"] = 2.0 * rng / speed_of_sound
    out["x"], out["y"], out["theta"] = x[keep], y[keep], theta[keep]
    out["turret"] = theta[keep]
    out["flags"] = np.where(no_echo, FLAG_NO_ECHO, 0)
    out = out[np.argsort(out["t"], kind="stable")]

    full_attrs: dict[str, Any] = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "speed_of_sound": float(speed_of_sound),
        "robot": "",
        "created": "",
        **attrs,
    }
    log = SonarLog(
        path=path, attrs=full_attrs, sensors=sensors, readings=out, poses=track.records()
    )
    counts = ImportCounts(
        messages=raw.messages,
        values=int(raw.t.size),
        readings=int(out.size),
        stale_dropped=int(stale.sum()),
        invalid_dropped=int(invalid.sum()),
        out_of_pose_range_dropped=int(outside.sum()),
        no_echo_flagged=int(no_echo.sum()),
        poses=len(track),
    )
    return Assembled(log, counts)


def speed_of_sound_for(temperature_c: float | None, given: float | None) -> float:
    """The speed of sound: from the temperature, else the sensors file's, else the default.

    Raises
    ------
    SourceError
        The temperature is outside the range the transducers work in.
    """
    if temperature_c is not None:
        try:
            return speed_of_sound_at(float(temperature_c))
        except ValueError as err:
            raise SourceError(f"temperature: {err}") from err
    return float(given) if given is not None else DEFAULT_SPEED_OF_SOUND

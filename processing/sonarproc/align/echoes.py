"""Line-of-sight echo points of readings, for poses that move.

Drift correction must associate echoes *before* any surface is known, so it cannot use
:func:`sonarproc.surfaces.echo_points` (which needs the surfaces, to put each echo at the
foot of the perpendicular from its sensor). It uses the line-of-sight point instead: the
sensor's position plus the range along its heading. For a wall seen at an angle phi off
its normal (at most the half beam width), that point lies d (1 - cos phi) in front of the
wall (at most 2.4 % of the range for a 12.5 degree half beam, 3.4 % for 15 degrees),
and along the wall by d sin phi; both errors are the same wherever the same wall is seen
from the same distance, so echoes of one wall from different times still agree.

The residuals, once a local line is known, use the specular model instead (see
:mod:`sonarproc.align.graph`): a reading echoes from a wall whose normal lies in its beam,
and its range is its sensor's distance from the wall.

Only monostatic readings (a sensor's own echo) with an echo inside their sensor's usable
range take part; the others are corrected but do not constrain the correction.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarlog import FLAG_NO_ECHO

__all__ = ["EchoRays", "echo_rays"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True, eq=False)
class EchoRays:
    """The readings that constrain a correction: mounts and ranges, poses apart."""

    #: index of each ray's reading in the time-ordered track (E,)
    reading: IntArray
    #: sensor mount in the turret frame (E, 2), m
    mount: FloatArray
    #: turret heading minus base heading at firing (E,), rad
    turret_offset: FloatArray
    #: sensor heading in the turret frame (E,), rad
    heading: FloatArray
    #: range, half the acoustic path (E,), m
    range_m: FloatArray
    #: half beam width (E,), rad
    half_beam: FloatArray

    @property
    def size(self) -> int:
        """Number of rays."""
        return int(self.reading.size)

    def subset(self, keep: npt.NDArray[np.bool_] | IntArray) -> EchoRays:
        """The rays selected by ``keep`` (a mask or indices)."""
        return EchoRays(self.reading[keep], self.mount[keep], self.turret_offset[keep],
                        self.heading[keep], self.range_m[keep], self.half_beam[keep])  # fmt: skip

    def sensors(
        self, x: FloatArray, y: FloatArray, theta: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """Sensor positions (E, 2) and lines of sight (E,) for base poses per ray (E,)."""
        turret = theta + self.turret_offset
        c, s = np.cos(turret), np.sin(turret)
        mx, my = self.mount[:, 0], self.mount[:, 1]
        return np.column_stack((x + c * mx - s * my, y + s * mx + c * my)), turret + self.heading

    def points(self, x: FloatArray, y: FloatArray, theta: FloatArray) -> FloatArray:
        """Line-of-sight echo points (E, 2) for base poses given per ray (E,)."""
        xy, look = self.sensors(x, y, theta)
        return xy + self.range_m[:, None] * np.column_stack((np.cos(look), np.sin(look)))


def echo_rays(
    readings: np.ndarray, sensors: np.ndarray, order: IntArray, *, speed_of_sound: float
) -> EchoRays:
    """The usable readings of a log as rays, indexed in time order.

    Parameters
    ----------
    readings : ndarray of sonarlog.READING_DTYPE
        The log's readings.
    sensors : ndarray of sonarlog.SENSOR_DTYPE
        The log's sensors.
    order : ndarray of int
        The readings' time order (``readings[order]`` is the track).
    speed_of_sound : float
        m/s.

    Returns
    -------
    EchoRays
        Monostatic readings with an echo inside their sensor's usable range.
    """
    r = readings[order]
    ids = np.asarray(sensors["id"])
    if ids.size == 0:
        raise ValueError("sensors: the table is empty; a log needs at least one sensor")
    sort = np.argsort(ids, kind="stable")
    pos = np.clip(np.searchsorted(ids[sort], r["tx"]), 0, ids.size - 1)
    known = ids[sort][pos] == r["tx"]
    row = sort[pos]
    s = sensors[row]
    # a time of flight too large to convert (1e308 s) overflows to inf: not finite, dropped
    with np.errstate(over="ignore", invalid="ignore"):
        rng = 0.5 * np.asarray(r["tof"], dtype=np.float64) * speed_of_sound
        ok = (
            known
            & (r["tx"] == r["rx"])
            & ((r["flags"] & FLAG_NO_ECHO) == 0)
            & np.isfinite(rng)
            & (rng >= s["min_range"])
            & (rng <= s["max_range"])
        )
    idx = np.flatnonzero(ok).astype(np.intp)
    return EchoRays(
        idx,
        np.column_stack((s["x"][idx], s["y"][idx])).astype(np.float64),
        np.asarray(r["turret"][idx] - r["theta"][idx], dtype=np.float64),
        np.asarray(s["heading"][idx], dtype=np.float64),
        rng[idx],
        np.asarray(s["half_beamwidth"][idx], dtype=np.float64),
    )

"""Sensor arrays: mounts in the array (turret) frame plus beam and range limits.

A :class:`SensorArray` holds one row per transducer. Where the array stands and which way
it faces is a pose (see :mod:`sonarsim.paths`); a sensor's world pose is
``position = (x, y) + R(turret) @ (mount_x, mount_y)`` and
``heading = turret + mount_heading`` (the sonarlog v1 convention). An array that never moves
uses pose ``(0, 0, 0, 0)``, so its mounts are world coordinates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from nomad200 import ring
from sonarsim.geometry import FloatArray, rotate, wrap_angle
from sonarsim.records import SENSOR_DTYPE
from sonarsim.search import HALF_BEAMWIDTH, MAX_RANGE, MIN_RANGE
from sonarsim.specular import Sensors

NOMAD_RING_COUNT = ring.N_SONARS
"""Sonars on the Nomad 200 ring."""
NOMAD_RING_RADIUS = ring.RADIUS
"""Ring radius (m)."""
NOMAD_FRONT_FIVE = (14, 15, 0, 1, 2)
"""The five sonars facing forward (-45 .. +45 degrees), as used in the paper."""


@dataclass(frozen=True)
class SensorArray:
    """Transducers of one array, mounts in the array frame (m, rad).

    Attributes
    ----------
    ids : ndarray of int16
        Transducer numbers.
    x, y, heading : ndarray
        Mount positions and lines of sight relative to the array frame.
    half_beamwidth, min_range, max_range : ndarray
        Beam half angle (rad) and usable range (m) of each transducer.
    """

    ids: NDArray[np.int16]
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    half_beamwidth: FloatArray
    min_range: FloatArray
    max_range: FloatArray

    def __post_init__(self) -> None:
        n = np.asarray(self.ids).size
        for name in ("x", "y", "heading", "half_beamwidth", "min_range", "max_range"):
            v = np.broadcast_to(np.asarray(getattr(self, name), dtype=np.float64), (n,))
            object.__setattr__(self, name, v.copy())
        ids = np.asarray(self.ids)
        if np.any(ids < np.iinfo(np.int16).min) or np.any(ids > np.iinfo(np.int16).max):
            raise ValueError("sensor ids must fit in int16")
        object.__setattr__(self, "ids", ids.astype(np.int16))
        if len(np.unique(self.ids)) != n:
            raise ValueError("sensor ids must be unique")
        if np.any(self.half_beamwidth <= 0) or np.any(self.half_beamwidth >= np.pi / 2):
            raise ValueError("half beam width must be in (0, 90) degrees")
        if np.any(self.min_range < 0) or np.any(self.max_range <= self.min_range):
            raise ValueError("range limits need 0 <= min_range < max_range")

    def __len__(self) -> int:
        return int(self.ids.size)

    def take(self, idx: ArrayLike) -> SensorArray:
        """The rows ``idx`` (in that order)."""
        i = np.asarray(idx, dtype=np.intp)
        return SensorArray(
            self.ids[i], self.x[i], self.y[i], self.heading[i], self.half_beamwidth[i],
            self.min_range[i], self.max_range[i],
        )  # fmt: skip

    def select(self, ids: Sequence[int]) -> SensorArray:
        """The transducers with these ids, in the order given."""
        pos = {int(v): k for k, v in enumerate(self.ids)}
        missing = [i for i in ids if int(i) not in pos]
        if missing:
            raise ValueError(f"no sensor with id {missing[0]} (ids: {sorted(pos)})")
        return self.take([pos[int(i)] for i in ids])

    def records(self) -> NDArray[np.void]:
        """The array as a ``SENSOR_DTYPE`` table (sonarlog ``/sensors``)."""
        out = np.zeros(len(self), dtype=SENSOR_DTYPE)
        out["id"] = self.ids
        out["x"] = self.x
        out["y"] = self.y
        out["heading"] = self.heading
        out["half_beamwidth"] = self.half_beamwidth
        out["min_range"] = self.min_range
        out["max_range"] = self.max_range
        return out

    def world(self, x: ArrayLike, y: ArrayLike, turret: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """World positions ``(P, N, 2)`` and headings ``(P, N)`` at P poses."""
        px = np.atleast_1d(np.asarray(x, dtype=np.float64))
        py = np.atleast_1d(np.asarray(y, dtype=np.float64))
        tu = np.atleast_1d(np.asarray(turret, dtype=np.float64))
        mounts = np.stack([self.x, self.y], axis=1)
        xy = rotate(mounts[None, :, :], tu[:, None]) + np.stack([px, py], axis=1)[:, None, :]
        return xy, tu[:, None] + self.heading[None, :]

    def sensors_at(self, x: ArrayLike, y: ArrayLike, turret: ArrayLike) -> Sensors:
        """The echo search's flat sensor table for P poses (row ``p * N + i``)."""
        xy, heading = self.world(x, y, turret)
        p = xy.shape[0]
        return Sensors(
            xy.reshape(-1, 2), heading.reshape(-1), np.tile(self.half_beamwidth, p),
            np.tile(self.min_range, p), np.tile(self.max_range, p),
        )  # fmt: skip


def make_array(
    x: ArrayLike,
    y: ArrayLike,
    heading: ArrayLike,
    *,
    ids: ArrayLike | None = None,
    half_beamwidth: float = HALF_BEAMWIDTH,
    min_range: float = MIN_RANGE,
    max_range: float = MAX_RANGE,
) -> SensorArray:
    """An array from mount coordinates (broadcast together), ids default ``0..N-1``."""
    xx, yy, hh = np.broadcast_arrays(
        np.atleast_1d(np.asarray(x, dtype=np.float64)),
        np.atleast_1d(np.asarray(y, dtype=np.float64)),
        np.atleast_1d(np.asarray(heading, dtype=np.float64)),
    )
    n = xx.size
    idv = np.arange(n) if ids is None else np.asarray(ids)
    return SensorArray(
        idv.astype(np.int16), xx, yy, hh, np.full(n, half_beamwidth), np.full(n, min_range),
        np.full(n, max_range),
    )  # fmt: skip


def linear_array(
    count: int,
    spacing: float,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    direction: float = 0.0,
    heading: float = np.pi / 2,
    **limits: float,
) -> SensorArray:
    """``count`` sensors ``spacing`` apart from ``origin`` along ``direction``.

    Parameters
    ----------
    count : int
        Number of sensors (>= 1).
    spacing : float
        Distance between neighbours (m).
    origin : (float, float)
        Position of sensor 0 (m).
    direction : float
        Direction in which the array extends (rad).
    heading : float
        Line of sight of every sensor (rad).
    **limits
        ``half_beamwidth``, ``min_range``, ``max_range`` overrides.

    Examples
    --------
    >>> a = linear_array(3, 0.5)
    >>> a.x.tolist(), a.heading.round(4).tolist()
    ([0.0, 0.5, 1.0], [1.5708, 1.5708, 1.5708])
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    k = np.arange(count) * spacing
    return make_array(
        origin[0] + k * np.cos(direction), origin[1] + k * np.sin(direction), heading, **limits
    )


def circular_array(
    count: int = NOMAD_RING_COUNT,
    radius: float = NOMAD_RING_RADIUS,
    *,
    step: float | None = None,
    **limits: float,
) -> SensorArray:
    """A ring: sensor ``i`` at ``i * step`` CCW from the array heading, looking outward.

    Defaults give the Nomad 200 ring: 16 sonars 22.5 degrees apart on a 0.22 m radius,
    sonar 0 looking along the turret heading. Headings are wrapped to [-180, 180) degrees.

    Examples
    --------
    >>> r = circular_array()
    >>> len(r), round(float(np.rad2deg(r.heading[4])), 6), round(float(r.y[4]), 6)
    (16, 90.0, 0.22)
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    st = 2.0 * np.pi / count if step is None else step
    ang = np.arange(count) * st
    return make_array(radius * np.cos(ang), radius * np.sin(ang), wrap_angle(ang), **limits)


def random_array(
    count: int,
    x_range: tuple[float, float],
    y_range: tuple[float, float],
    heading_range: tuple[float, float],
    rng: np.random.Generator,
    **limits: float,
) -> SensorArray:
    """Sensors at uniformly random positions and headings (paper Sec. 3.3.3).

    Draws x, then y, then heading, each ``count`` values, from ``rng``.
    """
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    x = rng.uniform(x_range[0], x_range[1], count)
    y = rng.uniform(y_range[0], y_range[1], count)
    h = rng.uniform(heading_range[0], heading_range[1], count)
    return make_array(x, y, h, **limits)

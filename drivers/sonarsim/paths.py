"""Paths of poses: where an array stands and which way it faces at each stop.

A pose is ``(x, y, theta, turret)``: the base position and heading, and the turret
heading in the world (what sonarlog readings store). Moving an array along a path of
poses forms a synthetic array, as with the robot in the paper's Figs. 2, 8 and 16.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from sonarsim.geometry import FloatArray


@dataclass(frozen=True)
class Poses:
    """P poses (m, m, rad, rad); ``turret`` is the turret heading in the world."""

    x: FloatArray
    y: FloatArray
    theta: FloatArray
    turret: FloatArray

    def __post_init__(self) -> None:
        arrays = np.broadcast_arrays(
            *(np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in
              (self.x, self.y, self.theta, self.turret))
        )  # fmt: skip
        for name, v in zip(("x", "y", "theta", "turret"), arrays, strict=True):
            if v.ndim != 1 or not np.all(np.isfinite(v)):
                raise ValueError(f"pose {name} must be a finite 1-D array")
            object.__setattr__(self, name, np.array(v))

    def __len__(self) -> int:
        return int(self.x.size)

    @staticmethod
    def still() -> Poses:
        """A single pose at the origin: mounts are world coordinates."""
        z = np.zeros(1)
        return Poses(z, z, z, z)


def sweep(start: float, stop: float, step: float) -> FloatArray:
    """``start, start + step, ...`` up to and including ``stop`` (within 1e-9).

    Examples
    --------
    >>> np.rad2deg(sweep(*np.deg2rad([45.0, 135.0, 15.0]))).round(6).tolist()
    [45.0, 60.0, 75.0, 90.0, 105.0, 120.0, 135.0]
    """
    if step == 0.0:
        raise ValueError("sweep step must not be zero")
    n = int(np.floor((stop - start) / step + 1e-9)) + 1
    if n < 1:
        raise ValueError(f"sweep from {start} to {stop} by {step} is empty")
    return np.asarray(start + step * np.arange(n), dtype=np.float64)


def line_locations(
    start: ArrayLike, end: ArrayLike, *, count: int | None = None, step: float | None = None
) -> FloatArray:
    """Points from ``start`` to ``end`` inclusive: ``count`` of them, or ``step`` apart.

    Examples
    --------
    >>> line_locations((-0.75, 0.0), (0.75, 0.0), step=0.025).shape
    (61, 2)
    """
    a = np.asarray(start, dtype=np.float64)
    b = np.asarray(end, dtype=np.float64)
    if (count is None) == (step is None):
        raise ValueError("give exactly one of count and step")
    if count is None:
        assert step is not None
        length = float(np.hypot(*(b - a)))
        if step <= 0:
            raise ValueError(f"step must be > 0, got {step}")
        count = int(np.floor(length / step + 1e-9)) + 1
    if count < 1:
        raise ValueError(f"count must be >= 1, got {count}")
    f = np.linspace(0.0, 1.0, count) if count > 1 else np.zeros(1)
    return np.asarray(a + (b - a) * f[:, None], dtype=np.float64)


def route_poses(waypoints: ArrayLike, *, step: float) -> Poses:
    """Stops every ``step`` metres along a polyline of waypoints, facing along the route.

    The base (and the turret with it) heads along the piece of route the stop lies on;
    at a waypoint the robot has already turned to the next piece (it turns on the spot,
    as a synchro-drive robot does).

    Examples
    --------
    >>> p = route_poses([(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)], step=0.5)
    >>> p.x.tolist(), p.y.tolist(), np.rad2deg(p.theta).round(3).tolist()
    ([0.0, 0.5, 1.0, 1.0, 1.0], [0.0, 0.0, 0.0, 0.5, 1.0], [0.0, 0.0, 90.0, 90.0, 90.0])
    """
    w = np.asarray(waypoints, dtype=np.float64)
    if w.ndim != 2 or w.shape[1] != 2 or w.shape[0] < 2:
        raise ValueError("a route needs at least two waypoints [x, y]")
    if not step > 0:
        raise ValueError(f"step must be > 0, got {step}")
    seg = np.diff(w, axis=0)
    length = np.hypot(seg[:, 0], seg[:, 1])
    if np.any(length <= 0):
        raise ValueError("route waypoints must differ from the one before")
    s_way = np.concatenate(([0.0], np.cumsum(length)))
    n = int(np.floor(s_way[-1] / step + 1e-9)) + 1
    s = step * np.arange(n)
    piece = np.clip(np.searchsorted(s_way, s + 1e-9, side="right") - 1, 0, len(length) - 1)
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    x = np.interp(s, s_way, w[:, 0])
    y = np.interp(s, s_way, w[:, 1])
    theta = heading[piece]
    return Poses(x, y, theta, theta)


def grid_poses(
    locations: ArrayLike,
    *,
    theta: Sequence[float] | FloatArray = (0.0,),
    turret: Sequence[float] | FloatArray | None = None,
) -> Poses:
    """Every location x base heading x turret heading (locations outermost).

    Parameters
    ----------
    locations : array_like, shape (L, 2)
        Base positions (m).
    theta : sequence of float
        Base headings to visit at each location (rad); rotating the base turns the turret
        with it unless ``turret`` is given.
    turret : sequence of float, optional
        Turret headings in the world to sweep at each location and base heading (rad);
        default: the turret faces the base heading.

    Returns
    -------
    Poses
        ``L * len(theta) * len(turret)`` poses.
    """
    loc = np.atleast_2d(np.asarray(locations, dtype=np.float64))
    th = np.atleast_1d(np.asarray(theta, dtype=np.float64))
    n_tu = 1 if turret is None else len(turret)
    grid = np.meshgrid(np.arange(len(loc)), np.arange(th.size), np.arange(n_tu), indexing="ij")
    li, ti, ui = (g.ravel() for g in grid)
    base = th[ti]
    tur = base if turret is None else np.asarray(turret, dtype=np.float64)[ui]
    return Poses(loc[li, 0], loc[li, 1], base, tur)

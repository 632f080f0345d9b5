"""Odometry drift injected into a simulated log's poses, for tests where truth is known.

The logged poses of a simulation are exact. A drifting odometry integrates the robot's
own motion with a scale error on distance and a heading error growing with distance:
``drift_fraction`` of every step's length added along it, and ``heading_rate`` radians
per metre added to the heading. The signs come from a seeded generator.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import yaml

if TYPE_CHECKING:
    from sonarsim import SimResult

FloatArray = npt.NDArray[np.float64]


def drift_poses(
    x: FloatArray, y: FloatArray, theta: FloatArray, *, drift_fraction: float,
    heading_rate: float, seed: int,
) -> tuple[FloatArray, FloatArray, FloatArray]:  # fmt: skip
    """Integrate a time-ordered track's steps again with drift (see the module notes)."""
    rng = np.random.default_rng(seed)
    scale_sign, heading_sign = rng.choice([-1.0, 1.0], size=2)
    dx, dy = np.diff(x), np.diff(y)
    dist = np.hypot(dx, dy)
    th0 = theta[:-1]
    # each step in the robot frame at its start, as odometry measures it
    fwd = np.cos(th0) * dx + np.sin(th0) * dy
    side = -np.sin(th0) * dx + np.cos(th0) * dy
    dth = (np.diff(theta) + np.pi) % (2 * np.pi) - np.pi
    scale = 1.0 + scale_sign * drift_fraction
    err_th = np.concatenate(([0.0], np.cumsum(heading_sign * heading_rate * dist)))
    th_d = theta[0] + np.concatenate(([0.0], np.cumsum(dth))) + err_th
    c, s = np.cos(th_d[:-1]), np.sin(th_d[:-1])
    xd = x[0] + np.concatenate(([0.0], np.cumsum(scale * (c * fwd - s * side))))
    yd = y[0] + np.concatenate(([0.0], np.cumsum(scale * (s * fwd + c * side))))
    return xd, yd, (th_d + np.pi) % (2 * np.pi) - np.pi


def drifted_readings(
    readings: np.ndarray, *, drift_fraction: float = 0.02,
    heading_rate: float = np.radians(2.0) / 10.0, seed: int = 0,
) -> np.ndarray:  # fmt: skip
    """A copy of time-ordered ``readings`` whose poses drift (turret turns with theta)."""
    out = readings.copy()
    x, y, th = (np.asarray(readings[k], dtype=np.float64) for k in ("x", "y", "theta"))
    xd, yd, thd = drift_poses(x, y, th, drift_fraction=drift_fraction,
                              heading_rate=heading_rate, seed=seed)  # fmt: skip
    out["x"], out["y"], out["theta"] = xd, yd, thd
    out["turret"] = readings["turret"] + (thd - th)
    return out


def pose_error_rms(readings: np.ndarray, x: FloatArray, y: FloatArray) -> float:
    """RMS over readings of the distance between their true and given positions."""
    return float(np.sqrt(np.mean((readings["x"] - x) ** 2 + (readings["y"] - y) ** 2)))


def scenario_path(name: str) -> Path:
    """A shipped scenario's file, or a test scenario's (``tests/data/scenarios/NAME.yaml``)."""
    from sonarsim.shipped import resolve_shipped, shipped_names

    if name in shipped_names("scenarios"):
        return Path(resolve_shipped(name, kind="scenarios"))
    path = Path(__file__).resolve().parents[1] / "data" / "scenarios" / f"{name}.yaml"
    if not path.is_file():
        raise ValueError(f"{name}: neither a shipped scenario nor one in tests/data/scenarios")
    return path


def looped_scenario(name: str, loops: int, *, seed: int | None = None) -> SimResult:
    """Simulate a scenario whose route is driven ``loops`` times.

    A closed route is driven round again; an open one (a corridor driven through) is
    driven there and back, which makes it a closed loop.
    """
    from sonarsim import scenario_from_dict, simulate

    path = scenario_path(name)
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    way = data["path"]["locations"]["waypoints"]
    if way[0] != way[-1]:
        way = way + way[-2::-1]
    data["path"]["locations"]["waypoints"] = way + way[1:] * (loops - 1)
    return simulate(scenario_from_dict(data, base_dir=path.parent, source=str(path), seed=seed))

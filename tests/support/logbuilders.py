"""Builders of sonarlog tables shared by the tests (on sys.path via pytest's ``pythonpath``)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sonarlog import FLAG_NO_ECHO, READING_DTYPE, SENSOR_DTYPE


def ring_sensors(n: int = 16, radius: float = 0.22) -> np.ndarray:
    """The Nomad ring: sensor i at i * 22.5 deg."""
    s = np.zeros(n, dtype=SENSOR_DTYPE)
    s["id"] = np.arange(n)
    ang = np.arange(n) * 2 * np.pi / n
    s["x"], s["y"], s["heading"] = radius * np.cos(ang), radius * np.sin(ang), ang
    s["half_beamwidth"] = np.deg2rad(12.5)
    s["min_range"], s["max_range"] = 0.15, 10.7
    return s


def random_readings(rng: np.random.Generator, n: int, n_sensors: int = 16) -> np.ndarray:
    r = np.zeros(n, dtype=READING_DTYPE)
    r["t"] = 1.7e9 + np.cumsum(rng.uniform(0.01, 0.05, n))
    r["tx"] = rng.integers(0, n_sensors, n)
    r["rx"] = np.where(rng.random(n) < 0.5, r["tx"], rng.integers(0, n_sensors, n))
    r["echo"] = rng.integers(0, 3, n)
    r["tof"] = rng.uniform(0.001, 0.06, n)
    r["x"], r["y"] = rng.uniform(-5, 5, n), rng.uniform(-5, 5, n)
    r["theta"], r["turret"] = rng.uniform(-np.pi, np.pi, n), rng.uniform(-np.pi, np.pi, n)
    r["flags"] = rng.integers(0, 4, n)
    return r


def ring_walk_readings(
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    turret: np.ndarray,
    axial_range: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    rng: np.random.Generator,
    *,
    sensors: np.ndarray,
    speed_of_sound: float,
    noise_m: float = 0.01,
) -> np.ndarray:
    """Readings of a ring walking ``(t, x, y)`` (heading 0) with its turret at ``turret``.

    The sensors fire in turn; each returns ``axial_range(px, py, heading)`` (the range
    along its beam's axis from its position: a diffusely reflecting world) plus Gaussian
    noise; beyond the sensor's maximum range, no echo.
    """
    n = t.size
    k = np.arange(n) % sensors.size
    c, s = np.cos(turret), np.sin(turret)
    px = x + sensors["x"][k] * c - sensors["y"][k] * s
    py = y + sensors["x"][k] * s + sensors["y"][k] * c
    h = turret + sensors["heading"][k]
    rng_m = axial_range(px, py, h) + rng.normal(0.0, noise_m, n)
    r = np.zeros(n, READING_DTYPE)
    r["t"], r["x"], r["y"], r["theta"], r["turret"] = t, x, y, 0.0, turret
    r["tx"] = r["rx"] = k
    far = ~(rng_m <= sensors["max_range"][k])
    r["tof"] = np.where(far, np.nan, 2 * rng_m / speed_of_sound)
    r["flags"] = np.where(far, FLAG_NO_ECHO, 0)
    return r

"""Seeded random scenes: a surface, an array walking or standing under it, noise.

:func:`random_scenario_dict` draws one scene from ``np.random.default_rng(seed)`` as the
mapping a scenario YAML file holds (:mod:`sonarsim.scenario_spec`), so it can be written
out and simulated by ``sonarproc simulate``; :func:`random_scenario` builds it. The same
seed always gives the same scene. What is drawn:

* the surface, one profile ``y(x)`` over a 3-7 m stretch: a tilted ``wall`` (a straight
  line within 10 degrees of the array's axis), a smooth ``curve`` (a sinusoid, or a
  natural cubic spline through 4-6 random points) or a ``corner`` (two or three straight
  pieces meeting at 8-35 degree bends, the whole rising or falling by at most 0.8 m);
* the array: the Nomad's 16-sonar ``ring`` driving along under the surface (own echoes,
  first echo only), a ``linear`` array of 4-8 sensors walking under it (every pair
  listening, or each its own), ``random`` monostatic sensors, or ``bistatic`` random
  sensors with every pair listening;
* the range noise sigma (0.2-5 cm, log-uniform: a Polaroid ranger to a very noisy log),
  the spurious echo probability (0-5 %) and, for a third of the scenes, 1-inch range
  steps.

The scenes are physically sensible: every sensor lies below the surface (at least
0.9 m below its lowest point), the sensors face up into it, and the ranges are kept
within 0.2-4 m (the transducers' ``min_range`` and ``max_range``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sonarsim.scenario import Scenario, scenario_from_dict

__all__ = ["ARRAY_KINDS", "SURFACE_KINDS", "random_scenario", "random_scenario_dict"]

#: Kinds of surface drawn.
SURFACE_KINDS = ("wall", "curve", "corner")
#: Kinds of array drawn.
ARRAY_KINDS = ("ring", "linear", "random", "bistatic")
#: A corner's pieces rise or fall by at most this much in all (m).
CORNER_RISE_M = 0.8
#: Shortest and longest range (m) a scene's readings may have.
RANGE_LIMITS = (0.2, 4.0)


def _surface(rng: np.random.Generator, kind: str, width: float, height: float) -> dict[str, Any]:
    """One surface's mapping: a profile over x = 0..width whose mean height is ``height``."""
    if kind == "wall":
        tilt = np.tan(np.radians(rng.uniform(-10.0, 10.0)))
        # y = c0 + c1 x, centred on the stretch's middle
        return {
            "type": "polynomial", "name": "surface", "x_range": [0.0, width],
            "coefficients": [round(height - tilt * width / 2, 4), round(float(tilt), 5)],
        }  # fmt: skip
    if kind == "curve" and rng.random() < 0.5:
        return {
            "type": "sinusoid", "name": "surface", "x_range": [0.0, width],
            "amplitude": round(rng.uniform(0.03, 0.20), 4),
            "period": round(rng.uniform(1.0, 4.0), 3),
            "offset": round(height, 4), "phase_deg": round(rng.uniform(0.0, 360.0), 1),
        }  # fmt: skip
    if kind == "curve":
        n = int(rng.integers(4, 7))
        xs = np.linspace(0.0, width, n)
        ys = height + rng.uniform(-0.2, 0.2, n)
        return {
            "type": "profile",
            "name": "surface",
            "points": [
                [round(float(a), 4), round(float(b), 4)] for a, b in zip(xs, ys, strict=True)
            ],
        }
    # a corner: two or three straight pieces, each bend 8-35 degrees either way
    pieces = int(rng.integers(2, 4))
    cuts = np.sort(rng.uniform(0.25, 0.75, pieces - 1)) * width
    xs = np.r_[0.0, cuts, width]
    angle = np.radians(rng.uniform(-8.0, 8.0))
    rise: list[float] = [0.0]
    for k in range(pieces):
        if k:
            angle += np.radians(rng.uniform(8.0, 35.0)) * rng.choice([-1.0, 1.0])
            angle = float(np.clip(angle, np.radians(-35.0), np.radians(35.0)))
        rise.append(rise[-1] + float(np.tan(angle) * (xs[k + 1] - xs[k])))
    y = np.asarray(rise)
    y -= y.mean()
    if np.ptp(y) > CORNER_RISE_M:
        y *= CORNER_RISE_M / np.ptp(y)  # keep the ranges within the transducers' reach
    y += height
    return {
        "type": "polyline", "name": "surface",
        "points": [[round(float(a), 4), round(float(b), 4)] for a, b in zip(xs, y, strict=True)],
    }  # fmt: skip


def _lowest(surface: dict[str, Any], width: float) -> float:
    """The surface's lowest y (m) over x = 0..width (sampled every centimetre)."""
    x = np.linspace(0.0, width, int(width * 100) + 1)
    t = surface["type"]
    if t == "polynomial":
        c0, c1 = surface["coefficients"]
        return float(np.min(c0 + c1 * x))
    if t == "sinusoid":
        return float(surface["offset"] - abs(surface["amplitude"]))
    from scipy.interpolate import CubicSpline

    pts = np.asarray(surface["points"], dtype=np.float64)
    if t == "profile":
        return float(np.min(CubicSpline(pts[:, 0], pts[:, 1], bc_type="natural")(x)))
    return float(pts[:, 1].min())


def random_scenario_dict(seed: int) -> dict[str, Any]:
    """One random scene (see the module notes) as a scenario mapping.

    Parameters
    ----------
    seed : int
        Seed of every draw (``np.random.default_rng(seed)``) and of the simulation.

    Returns
    -------
    dict
        A scenario mapping (the schema of ``configs/scenarios/*.yaml``); its
        ``description`` names the surface kind and the array kind.

    Examples
    --------
    >>> d = random_scenario_dict(3)
    >>> d == random_scenario_dict(3), d["seed"]
    (True, 3)
    """
    rng = np.random.default_rng(seed)
    surface_kind = SURFACE_KINDS[int(rng.integers(len(SURFACE_KINDS)))]
    array_kind = ARRAY_KINDS[int(rng.integers(len(ARRAY_KINDS)))]
    width = float(rng.uniform(3.0, 7.0))
    height = float(rng.uniform(1.6, 2.8))
    surface = _surface(rng, surface_kind, width, height)
    # the sensors: at least 0.9 m below the surface's lowest point, never above y = 0.8 m
    top = min(0.8, _lowest(surface, width) - 0.9)
    sigma = float(np.exp(rng.uniform(np.log(0.002), np.log(0.05))))
    imperfections: dict[str, Any] = {
        "range_noise_sigma": round(sigma, 4),
        "spurious_probability": round(float(rng.uniform(0.0, 0.05)), 3),
    }
    if rng.random() < 1 / 3:
        imperfections["quantise"] = True
    data: dict[str, Any] = {
        "name": f"random-{seed}",
        "description": f"{surface_kind} / {array_kind}",
        "world": {
            "name": f"random-{seed}",
            "description": f"{surface_kind}, x = 0-{width:.2f} m",
            "resolution": 0.01,
            "surfaces": [surface],
        },
        "sensor": {"min_range": RANGE_LIMITS[0], "max_range": RANGE_LIMITS[1]},
        "imperfections": imperfections,
        "seed": int(seed),
    }
    margin = min(0.4, 0.1 * width)
    y0 = round(float(rng.uniform(0.0, top)), 3)
    if array_kind == "ring":
        data["array"] = {"type": "circular", "count": 16}
        data["path"] = {
            "locations": {"start": [margin, y0], "end": [width - margin, y0],
                          "count": int(rng.integers(25, 61))},
            "theta_deg": 0.0,
        }  # fmt: skip
        data["pairs"] = "own"
        data["first_echo_only"] = True
    elif array_kind == "linear":
        count = int(rng.integers(4, 9))
        spacing = float(rng.uniform(0.08, 0.15))
        data["array"] = {"type": "linear", "count": count, "spacing": round(spacing, 3),
                         "heading_deg": 90.0}  # fmt: skip
        data["path"] = {
            "locations": {"start": [margin, y0], "end": [width - margin - count * spacing, y0],
                          "count": int(rng.integers(20, 46))},
            "theta_deg": 0.0,
        }  # fmt: skip
        data["pairs"] = "all" if rng.random() < 0.5 else "own"
    else:
        bistatic = array_kind == "bistatic"
        lo = round(float(rng.uniform(0.0, top)), 3)
        data["array"] = {
            "type": "random",
            "count": int(rng.integers(15, 36) if bistatic else rng.integers(60, 201)),
            "x_range": [0.0, round(width, 3)], "y_range": [min(lo, y0), max(lo, y0)],
            "heading_range_deg": [60.0, 120.0],
        }  # fmt: skip
        data["pairs"] = "all" if bistatic else "own"
    return _plain(data)


def _plain(v: Any) -> Any:
    """``v`` with numpy scalars made Python numbers (a YAML file can hold it)."""
    if isinstance(v, dict):
        return {k: _plain(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_plain(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def random_scenario(seed: int) -> Scenario:
    """One random scene (:func:`random_scenario_dict`), built.

    Examples
    --------
    >>> s = random_scenario(7)
    >>> s.name, s.seed
    ('random-7', 7)
    """
    data = random_scenario_dict(seed)
    return scenario_from_dict(data, source=f"random scene {seed}")

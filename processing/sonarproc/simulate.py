"""Simulate a scenario into a sonarlog v1 file with ``/truth/profile``.

The acoustics live in :mod:`sonarsim` (drivers); this module is the I/O edge that turns
its results into a log with :class:`sonarlog.LogWriter`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sonarlog import POSE_DTYPE, LogWriter
from sonarproc.errors import InputError
from sonarsim import SimResult, load_scenario, simulate

__all__ = ["SimulationSummary", "simulate_to_log", "write_result"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SimulationSummary:
    """What a simulation wrote."""

    path: Path
    scenario: str
    readings: int
    echoes: int
    sensors: int
    truth_points: int
    seed: int


def _poses(result: SimResult) -> np.ndarray:
    """One pose-stream row per distinct (time-ordered) stop pose in the readings."""
    r = result.readings
    if r.size == 0:
        return np.zeros(0, dtype=POSE_DTYPE)
    keys = np.stack([r["x"], r["y"], r["theta"], r["turret"]], axis=1)
    change = np.ones(r.size, dtype=bool)
    change[1:] = np.any(keys[1:] != keys[:-1], axis=1)
    rows = r[change]
    out = np.zeros(rows.size, dtype=POSE_DTYPE)
    for name in ("t", "x", "y", "theta", "turret"):
        out[name] = rows[name]
    return out


def write_result(result: SimResult, out: str | Path, *, robot: str = "sonarsim") -> None:
    """Write a :class:`~sonarsim.simulation.SimResult` as sonarlog v1 (with truth)."""
    attrs = dict(result.attrs)
    with LogWriter(
        out,
        result.sensors,
        speed_of_sound=result.speed_of_sound,
        robot=robot,
        attrs=attrs,
        truth=result.truth if result.truth.size else None,
    ) as w:
        w.event("start", f"simulated scenario {attrs.get('scenario', '')}", t=_t0(result))
        w.append(result.readings)
        w.append_poses(_poses(result))
        w.event("stop", f"{result.readings.size} readings", t=_t1(result))


def _t0(result: SimResult) -> float:
    r = result.readings
    return float(r["t"][0]) if r.size else 0.0


def _t1(result: SimResult) -> float:
    r = result.readings
    return float(r["t"][-1]) if r.size else 0.0


def simulate_to_log(
    scenario: str | Path, out: str | Path, *, seed: int | None = None, force: bool = False
) -> SimulationSummary:
    """Load ``scenario``, simulate it and write the log ``out``.

    Parameters
    ----------
    scenario : path
        Scenario YAML (``configs/scenarios/*.yaml``).
    out : path
        The sonarlog to write.
    seed : int, optional
        Overrides the scenario's seed.
    force : bool
        Overwrite ``out`` if it exists (refused otherwise).

    Returns
    -------
    SimulationSummary

    Raises
    ------
    sonarsim.scenario.ScenarioError
        An invalid scenario or world (a ``ValueError``; the message names file and field).
    FileNotFoundError
        The scenario, or a file it names, does not exist.
    InputError
        The output directory does not exist, or ``out`` exists and ``force`` is False.
    """
    parent = Path(out).resolve().parent
    if not parent.is_dir():
        raise InputError(f"{out}: output directory {parent} does not exist")
    if Path(out).exists() and not force:
        raise InputError(f"{out}: exists already; pass force=True (--force) to overwrite")
    scn = load_scenario(scenario, seed=seed)
    log.info("simulating %s (seed %d)", scn.name, scn.seed)
    result = simulate(scn)
    write_result(result, out, robot=f"sonarsim:{scn.name}")
    flags = result.readings["flags"]
    return SimulationSummary(
        Path(out), scn.name, int(result.readings.size), int(np.count_nonzero((flags & 1) == 0)),
        int(result.sensors.size), int(result.truth.shape[0]), int(scn.seed),
    )  # fmt: skip

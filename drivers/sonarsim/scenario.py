"""Scenarios: load, validate and build ``configs/scenarios/*.yaml``.

:func:`load_scenario` reads a scenario (schema in :mod:`sonarsim.scenario_spec`) and
builds a :class:`Scenario`; :func:`sonarsim.simulation.simulate` turns it into
sonarlog-shaped results.

"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import ValidationError

from sonarsim.arrays import SensorArray, circular_array, linear_array, make_array, random_array
from sonarsim.geometry import FloatArray
from sonarsim.paths import Poses, grid_poses, line_locations, route_poses, sweep
from sonarsim.scenario_spec import (
    Angles,
    ArrayRef,
    CircularArray,
    ExplicitArray,
    ImperfectionSpec,
    LinearArray,
    PathSpec,
    RandomArray,
    Route,
    ScenarioSpec,
    SensorDefaults,
    SensorFile,
    Sweep,
    TimingSpec,
)
from sonarsim.shipped import resolve_shipped
from sonarsim.transducer import TransducerParams
from sonarsim.world import (
    World,
    WorldError,
    format_validation_error,
    load_world,
    load_yaml_mapping,
    world_from_dict,
)

IntArray = NDArray[np.intp]

MAX_CHANNELS = 20_000_000
"""Refuse scenarios with more (firing, receiver) channels than this."""


class ScenarioError(WorldError):
    """A scenario that cannot be used (names the file and the field)."""


@dataclass(frozen=True)
class Scenario:
    """A validated, built scenario ready to simulate."""

    name: str
    world: World
    array: SensorArray
    poses: Poses
    rotation: FloatArray
    active: IntArray
    pairs: str
    first_echo_only: bool
    max_order: int
    speed_of_sound: float
    seed: int
    timing: TimingSpec
    imperfections: ImperfectionSpec
    record_no_echo: bool
    truth_spacing: float
    source: str = ""
    text: str = ""
    physics: str = "ideal"
    transducer: TransducerParams = field(default_factory=TransducerParams)


# --- building --------------------------------------------------------------------------------


def _angles(spec: Angles | None) -> FloatArray | None:
    if spec is None:
        return None
    if isinstance(spec, Sweep):
        return np.deg2rad(sweep(spec.start, spec.stop, spec.step))
    return np.deg2rad(np.atleast_1d(np.asarray(spec, dtype=np.float64)))


def _build_array(spec: Any, defaults: SensorDefaults, rng_seed: int) -> SensorArray:
    lim = {
        "half_beamwidth": float(np.deg2rad(defaults.half_beamwidth_deg)),
        "min_range": defaults.min_range,
        "max_range": defaults.max_range,
    }
    if isinstance(spec, LinearArray):
        return linear_array(
            spec.count, spec.spacing, origin=spec.origin,
            direction=float(np.deg2rad(spec.direction_deg)),
            heading=float(np.deg2rad(spec.heading_deg)), **lim,
        )  # fmt: skip
    if isinstance(spec, CircularArray):
        step = None if spec.step_deg is None else float(np.deg2rad(spec.step_deg))
        return circular_array(spec.count, spec.radius, step=step, **lim)
    if isinstance(spec, RandomArray):
        seed = rng_seed if spec.seed is None else spec.seed
        rng = np.random.default_rng(seed)
        return random_array(
            spec.count, spec.x_range, spec.y_range,
            (float(np.deg2rad(spec.heading_range_deg[0])),
             float(np.deg2rad(spec.heading_range_deg[1]))), rng, **lim,
        )  # fmt: skip
    assert isinstance(spec, ExplicitArray)
    rows = spec.sensors
    ids = [r.id if r.id is not None else k for k, r in enumerate(rows)]
    return make_array(
        [r.x for r in rows], [r.y for r in rows],
        np.deg2rad([r.heading_deg for r in rows]), ids=ids, **lim,
    )  # fmt: skip


def _build_poses(spec: PathSpec | None) -> tuple[Poses, FloatArray]:
    if spec is None:
        return Poses.still(), np.zeros(1)
    rot = _angles(spec.sensor_rotation_deg)
    rotation = np.zeros(1) if rot is None else rot
    if isinstance(spec.locations, Route):
        return route_poses(spec.locations.waypoints, step=spec.locations.step), rotation
    if isinstance(spec.locations, list):
        loc = np.asarray(spec.locations, dtype=np.float64).reshape(-1, 2)
    else:
        ln = spec.locations
        loc = line_locations(ln.start, ln.end, count=ln.count, step=ln.step)
    theta = _angles(spec.theta_deg)
    assert theta is not None
    turret = _angles(spec.turret_deg)
    return grid_poses(loc, theta=theta, turret=turret), rotation


def scenario_from_dict(
    data: Mapping[str, Any], *, base_dir: str | Path = ".", source: str = "<scenario>",
    seed: int | None = None, text: str = "",
) -> Scenario:  # fmt: skip
    """Validate and build a scenario from a parsed YAML mapping.

    Parameters
    ----------
    data : mapping
        The parsed YAML.
    base_dir : path
        Directory that relative ``world`` and ``array.file`` paths are relative to.
    source : str
        Name used in error messages (the file path).
    seed : int, optional
        Overrides the scenario's ``seed`` (and with it every random draw).
    text : str
        The scenario's YAML text, kept for the log's attributes.

    Raises
    ------
    ScenarioError
        Naming ``source``, the field and what is allowed.
    """
    try:
        spec = ScenarioSpec.model_validate(data)
    except ValidationError as err:
        raise ScenarioError(format_validation_error(source, err)) from err
    base = Path(base_dir)
    the_seed = spec.seed if seed is None else seed
    if seed is not None and seed < 0:
        raise ScenarioError(f"{source}: seed: must be >= 0, got {seed}")
    try:
        if isinstance(spec.world, str):
            world = load_world(base / spec.world)
        else:
            world = world_from_dict(spec.world, source=f"{source}: world")
    except FileNotFoundError as err:
        raise ScenarioError(f"{source}: world: no such file {err.filename}") from err
    array_spec: Any = spec.array
    defaults = spec.sensor
    if isinstance(array_spec, ArrayRef):
        path = base / array_spec.file
        try:
            raw = load_yaml_mapping(path, "sensors")
            sf = SensorFile.model_validate(raw)
        except FileNotFoundError as err:
            raise ScenarioError(f"{source}: array.file: no such file {err.filename}") from err
        except ValidationError as err:
            raise ScenarioError(format_validation_error(str(path), err)) from err
        array_spec = sf.array
        # The file's transducer defaults apply unless the scenario sets its own.
        defaults = spec.sensor if "sensor" in spec.model_fields_set else sf.sensor
    try:
        array = _build_array(array_spec, defaults, the_seed)
        if spec.active is not None:
            array = array.select(spec.active)
        poses, rotation = _build_poses(spec.path)
    except ValueError as err:
        raise ScenarioError(f"{source}: {err}") from err
    n_stops = len(poses) * rotation.size
    per_stop = len(array) * (len(array) if spec.pairs == "all" else 1)
    if n_stops * per_stop > MAX_CHANNELS:
        raise ScenarioError(
            f"{source}: {n_stops * per_stop} (firing, receiver) channels exceed the limit "
            f"{MAX_CHANNELS}; use fewer stops, sensors or pairs"
        )
    max_id = int(array.ids.max()) if len(array) else 0
    if rotation.size > 1 and (rotation.size * (max_id + 1) - 1) > np.iinfo(np.int16).max:
        raise ScenarioError(f"{source}: too many virtual sensors for int16 ids")
    physics = spec.physics or world.physics or "ideal"
    if physics == "transducer":
        _check_transducer(spec, source)
    return Scenario(
        spec.name or Path(source).stem, world, array, poses, rotation,
        np.arange(len(array), dtype=np.intp), spec.pairs, spec.first_echo_only,
        spec.max_order, spec.speed_of_sound, the_seed, spec.timing, spec.imperfections,
        spec.record_no_echo, spec.truth_spacing, source, text, physics,
        TransducerParams(**spec.transducer.model_dump()),
    )  # fmt: skip


def _check_transducer(spec: ScenarioSpec, source: str) -> None:
    """The transducer physics models monostatic first-order echoes (corners included)."""
    if spec.pairs != "own":
        raise ScenarioError(f"{source}: pairs: physics transducer allows only 'own'")
    if spec.max_order != 1:
        raise ScenarioError(
            f"{source}: max_order: physics transducer allows only 1 (corners are modelled)"
        )
    if spec.imperfections.crosstalk:
        raise ScenarioError(
            f"{source}: imperfections.crosstalk: physics transducer allows only false"
        )


def load_scenario(path: str | Path, *, seed: int | None = None) -> Scenario:
    """Load, validate and build a scenario YAML file (or a shipped one by name: ``fig12``).

    Raises
    ------
    ScenarioError
        Invalid content (names the file, the field and what is allowed).
    FileNotFoundError
        The file does not exist.
    """
    p = resolve_shipped(path, kind="scenarios")
    data = load_yaml_mapping(p, "scenario")
    return scenario_from_dict(
        data, base_dir=p.parent, source=str(p), seed=seed,
        text=p.read_text(encoding="utf-8"),
    )  # fmt: skip

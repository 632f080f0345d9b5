"""Scenarios: a world, an array moving along poses, imperfections -> simulated readings.

:func:`load_scenario` reads and validates ``configs/scenarios/*.yaml`` (schema in
:mod:`sonarsim.scenario_spec`); :func:`simulate` produces sonarlog-shaped results
(:class:`SimResult`): the ``/sensors`` table, the readings and the truth profile.

Firing model: the array visits *stops* (location x base heading x turret heading x
sensor rotation, in that nesting). At each stop every active transducer fires once, in
array order, one firing every ``timing.firing_interval_s``. With ``pairs: own`` only the
transmitter listens; with ``pairs: all`` every active transducer of the same stop
listens (bistatic). A *channel* is one (firing, receiver).

Recording model (sonarlog ``/sensors`` + per-reading pose): mounts are in the array
(turret) frame and each reading carries its stop's pose ``(x, y, theta, turret)``. An
array without a path stands at pose ``(0, 0, 0, 0)``, so its mounts are world
coordinates (the paper's fixed random sensors). A ``sensor_rotation_deg`` sweep (each
sensor turning about its own position, Fig. 6) is recorded as one virtual transducer per
(rotation, sensor) with id ``k * (max_id + 1) + id``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import ValidationError

from sonarsim import imperfections as imp
from sonarsim.arrays import SensorArray, circular_array, linear_array, make_array, random_array
from sonarsim.echoes import pair_echoes
from sonarsim.geometry import FloatArray
from sonarsim.paths import Poses, grid_poses, line_locations, sweep
from sonarsim.records import FLAG_CROSSTALK, FLAG_NO_ECHO, READING_DTYPE
from sonarsim.scenario_spec import (
    Angles,
    ArrayRef,
    CircularArray,
    ExplicitArray,
    ImperfectionSpec,
    LinearArray,
    PathSpec,
    RandomArray,
    ScenarioSpec,
    SensorDefaults,
    SensorFile,
    Sweep,
    TimingSpec,
)
from sonarsim.specular import Sensors
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


@dataclass(frozen=True)
class SimResult:
    """Simulated log content, shaped like sonarlog v1.

    Attributes
    ----------
    sensors : ndarray of SENSOR_DTYPE
        The ``/sensors`` table (mounts in the turret frame).
    readings : ndarray of READING_DTYPE
        One row per echo (plus no-echo rows if the scenario asks for them).
    truth : ndarray, shape (N, 2)
        Dense samples of the surfaces the sensors saw.
    speed_of_sound : float
        m/s used for ``tof``.
    attrs : dict
        Root attributes worth recording (scenario name, seed, world, ...).
    """

    sensors: NDArray[np.void]
    readings: NDArray[np.void]
    truth: FloatArray
    speed_of_sound: float
    attrs: dict[str, str | int | float]


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
    if isinstance(spec.locations, list):
        loc = np.asarray(spec.locations, dtype=np.float64).reshape(-1, 2)
    else:
        ln = spec.locations
        loc = line_locations(ln.start, ln.end, count=ln.count, step=ln.step)
    theta = _angles(spec.theta_deg)
    assert theta is not None
    turret = _angles(spec.turret_deg)
    rot = _angles(spec.sensor_rotation_deg)
    return grid_poses(loc, theta=theta, turret=turret), np.zeros(1) if rot is None else rot


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
        array_spec, defaults = sf.array, sf.sensor
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
    return Scenario(
        spec.name or Path(source).stem, world, array, poses, rotation,
        np.arange(len(array), dtype=np.intp), spec.pairs, spec.first_echo_only,
        spec.max_order, spec.speed_of_sound, the_seed, spec.timing, spec.imperfections,
        spec.record_no_echo, spec.truth_spacing, source, text,
    )  # fmt: skip


def load_scenario(path: str | Path, *, seed: int | None = None) -> Scenario:
    """Load, validate and build a scenario YAML file.

    Raises
    ------
    ScenarioError
        Invalid content (names the file, the field and what is allowed).
    FileNotFoundError
        The file does not exist.
    """
    p = Path(path)
    data = load_yaml_mapping(p, "scenario")
    return scenario_from_dict(
        data, base_dir=p.parent, source=str(p), seed=seed,
        text=p.read_text(encoding="utf-8"),
    )  # fmt: skip


# --- simulation ------------------------------------------------------------------------------


def virtual_array(scn: Scenario) -> SensorArray:
    """The recorded transducers: the array, repeated per sensor-rotation step."""
    arr = scn.array
    k = scn.rotation.size
    if k == 1 and scn.rotation[0] == 0.0:
        return arr
    stride = int(arr.ids.max()) + 1
    ids = (np.arange(k)[:, None] * stride + arr.ids[None, :].astype(np.int64)).ravel()
    return SensorArray(
        ids.astype(np.int16), np.tile(arr.x, k), np.tile(arr.y, k),
        (scn.rotation[:, None] + arr.heading[None, :]).ravel(),
        np.tile(arr.half_beamwidth, k), np.tile(arr.min_range, k), np.tile(arr.max_range, k),
    )  # fmt: skip


@dataclass(frozen=True)
class _Plan:
    """Index bookkeeping for firings and channels."""

    sensors: Sensors  # one row per (stop, active sensor) instance
    stop_pose: IntArray  # (stops,) pose index of each stop
    fire_stop: IntArray  # (F,) stop of each firing
    fire_tx: IntArray  # (F,) virtual sensor index of each firing's transmitter
    chan_fire: IntArray  # (C,) firing of each channel
    chan_rx: IntArray  # (C,) virtual sensor index of each channel's receiver
    n_active: int


def _plan(scn: Scenario, varr: SensorArray) -> _Plan:
    n = len(scn.array)
    k = scn.rotation.size
    p = len(scn.poses)
    # Stops: pose-major, rotation-minor. Virtual sensor of (rotation r, sensor i): r*n + i.
    stop_pose = np.repeat(np.arange(p), k)
    stop_rot = np.tile(np.arange(k), p)
    xy, heading = varr.world(scn.poses.x, scn.poses.y, scn.poses.turret)  # (P, V, ...)
    vidx = stop_rot[:, None] * n + np.arange(n)[None, :]  # (S, n) virtual sensor index
    inst_xy = xy[stop_pose[:, None], vidx].reshape(-1, 2)
    inst_h = heading[stop_pose[:, None], vidx].reshape(-1)
    v = vidx.reshape(-1)
    sensors = Sensors(inst_xy, inst_h, varr.half_beamwidth[v], varr.min_range[v], varr.max_range[v])
    n_stops = stop_pose.size
    fire_stop = np.repeat(np.arange(n_stops), n)
    fire_local = np.tile(np.arange(n), n_stops)
    if scn.pairs == "all":
        chan_fire = np.repeat(np.arange(fire_stop.size), n)
        chan_local = np.tile(np.arange(n), fire_stop.size)
    else:
        chan_fire = np.arange(fire_stop.size)
        chan_local = fire_local
    return _Plan(
        sensors, stop_pose, fire_stop, vidx[fire_stop, fire_local], chan_fire,
        vidx[fire_stop[chan_fire], chan_local], n,
    )  # fmt: skip


def _instance(plan: _Plan, stop: IntArray, virtual: IntArray) -> IntArray:
    return np.asarray(stop * plan.n_active + virtual % plan.n_active, dtype=np.intp)


def simulate(scn: Scenario) -> SimResult:
    """Simulate a scenario's readings.

    Parameters
    ----------
    scn : Scenario
        From :func:`load_scenario` or :func:`scenario_from_dict`.

    Returns
    -------
    SimResult
        Sensors table, readings (sorted by firing time, receiver, echo rank), truth.
    """
    varr = virtual_array(scn)
    plan = _plan(scn, varr)
    c = scn.speed_of_sound
    imps = scn.imperfections
    seeds = np.random.SeedSequence(scn.seed).spawn(4)
    rng_drop, rng_spur, rng_noise, _ = (np.random.default_rng(s) for s in seeds)

    chan_stop = plan.fire_stop[plan.chan_fire]
    tx_inst = _instance(plan, chan_stop, plan.fire_tx[plan.chan_fire])
    rx_inst = _instance(plan, chan_stop, plan.chan_rx)
    ev = pair_echoes(scn.world, plan.sensors, tx_inst, rx_inst, max_order=scn.max_order)
    channel, path, order = ev.firing, ev.path, ev.order
    crosstalk = np.zeros(channel.size, dtype=bool)
    seen_surfaces = np.unique(ev.surface[order == 1])

    keep = imp.dropouts(channel.size, imps.dropout_probability, rng_drop)
    channel, path, crosstalk = channel[keep], path[keep], crosstalk[keep]

    rx_min = plan.sensors.min_range[rx_inst]
    rx_max = plan.sensors.max_range[rx_inst]
    interval = scn.timing.firing_interval_s
    if imps.crosstalk:
        window = np.minimum(interval, 2.0 * rx_max / c)
        # Echoes arriving after their own window closes are lost from it ...
        heard = path / c < window[channel]
        channel, path, crosstalk = channel[heard], path[heard], crosstalk[heard]
        # ... and echoes of earlier pulses land in later windows.
        max_lag = int(np.ceil(2.0 * float(rx_max.max(initial=0.0)) / c / interval))
        extra_c, extra_p = [channel], [path]
        for lag in range(1, max_lag + 1):
            src_fire = plan.chan_fire - lag
            ok = np.flatnonzero(src_fire >= 0)
            if ok.size == 0:
                break
            sf = src_fire[ok]
            src_tx = _instance(plan, plan.fire_stop[sf], plan.fire_tx[sf])
            late = pair_echoes(
                scn.world, plan.sensors, src_tx, rx_inst[ok], max_order=scn.max_order
            )
            ch = ok[late.firing]
            land = imp.late_echoes(late.path, c, np.full(ch.size, lag * interval), window[ch])
            extra_c.append(ch[land])
            extra_p.append(late.path[land] - c * lag * interval)
        n_own = channel.size
        channel = np.concatenate(extra_c)
        path = np.concatenate(extra_p)
        crosstalk = np.concatenate([crosstalk, np.ones(channel.size - n_own, dtype=bool)])

    sc, sp = imp.spurious(rx_min, rx_max, imps.spurious_probability, rng_spur)
    channel = np.concatenate([channel, sc])
    path = np.concatenate([path, sp])
    crosstalk = np.concatenate([crosstalk, np.zeros(sc.size, dtype=bool)])

    path = imp.range_noise(path, imps.range_noise_sigma, rng_noise)
    if imps.quantise:
        path = imp.quantise(path, imps.quantum)
    half = 0.5 * path
    audible = (half >= rx_min[channel]) & (half <= rx_max[channel])
    channel, path, crosstalk = channel[audible], path[audible], crosstalk[audible]

    if scn.first_echo_only:
        idx = imp.first_per_channel(channel, path)
    else:
        idx = np.lexsort((path, channel))
    channel, path, crosstalk = channel[idx], path[idx], crosstalk[idx]

    readings = _readings(scn, plan, varr, channel, path, crosstalk)
    truth = _truth(scn, seen_surfaces)
    attrs: dict[str, str | int | float] = {
        "simulator": "sonarsim",
        "scenario": scn.name,
        "scenario_file": scn.source,
        "scenario_yaml": scn.text,
        "world": scn.world.name or scn.world.source,
        "seed": int(scn.seed),
        "pairs": scn.pairs,
        "first_echo_only": int(scn.first_echo_only),
        "max_order": int(scn.max_order),
    }
    return SimResult(varr.records(), readings, truth, c, attrs)


def _readings(
    scn: Scenario, plan: _Plan, varr: SensorArray, channel: IntArray, path: FloatArray,
    crosstalk: NDArray[np.bool_],
) -> NDArray[np.void]:  # fmt: skip
    c = scn.speed_of_sound
    n_chan = plan.chan_fire.size
    if scn.record_no_echo:
        has = np.zeros(n_chan, dtype=bool)
        has[channel] = True
        silent = np.flatnonzero(~has)
        channel = np.concatenate([channel, silent])
        path = np.concatenate([path, np.full(silent.size, np.nan)])
        crosstalk = np.concatenate([crosstalk, np.zeros(silent.size, dtype=bool)])
        order = np.argsort(channel, kind="stable")
        channel, path, crosstalk = channel[order], path[order], crosstalk[order]
    rank = np.arange(channel.size)
    if channel.size:
        start = np.ones(channel.size, dtype=bool)
        start[1:] = channel[1:] != channel[:-1]
        rank = rank - np.maximum.accumulate(np.where(start, rank, 0))
    fire = plan.chan_fire[channel]
    pose = plan.stop_pose[plan.fire_stop[fire]]
    out = np.zeros(channel.size, dtype=READING_DTYPE)
    out["t"] = scn.timing.start_time + fire * scn.timing.firing_interval_s
    out["tx"] = varr.ids[plan.fire_tx[fire]]
    out["rx"] = varr.ids[plan.chan_rx[channel]]
    out["echo"] = np.minimum(rank, 255)
    out["tof"] = path / c
    out["x"] = scn.poses.x[pose]
    out["y"] = scn.poses.y[pose]
    out["theta"] = scn.poses.theta[pose]
    out["turret"] = scn.poses.turret[pose]
    flags = np.where(np.isnan(path), FLAG_NO_ECHO, 0)
    if scn.imperfections.flag_crosstalk:
        flags = flags | np.where(crosstalk, FLAG_CROSSTALK, 0)
    out["flags"] = flags
    return out


def _truth(scn: Scenario, seen: IntArray) -> FloatArray:
    world = scn.world
    flagged = [i for i, s in enumerate(world.surfaces) if s.truth]
    chosen = [i for i in flagged if i in set(seen.tolist())] or flagged
    return world.truth_profile(scn.truth_spacing, chosen)

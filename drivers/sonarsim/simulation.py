"""Simulation: a built scenario -> sonarlog-shaped sensors, readings and truth.

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

Imperfections, in order: dropouts of true echoes; crosstalk (echoes later than the
listening window leave it and land in the following windows); spurious echoes; range
noise; quantisation; the receiver's range limits; then first-echo selection. With
``physics: transducer`` echoes come from :mod:`sonarsim.physical_echoes` instead and the
first echo above the threshold is always the one reported.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sonarsim import imperfections as imp
from sonarsim.arrays import SensorArray
from sonarsim.geometry import FloatArray
from sonarsim.physical_echoes import transducer_echoes
from sonarsim.records import FLAG_CROSSTALK, FLAG_NO_ECHO, READING_DTYPE
from sonarsim.scenario import Scenario
from sonarsim.search import pair_echoes
from sonarsim.specular import Sensors

IntArray = NDArray[np.intp]


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
    if scn.physics == "transducer":
        return _simulate_transducer(scn, plan, varr, tx_inst)
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
    return SimResult(varr.records(), readings, truth, c, _attrs(scn))


def _attrs(scn: Scenario) -> dict[str, str | int | float]:
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
    if scn.physics != "ideal":
        # Only non-default physics is recorded, so ideal logs stay byte-identical.
        attrs["physics"] = scn.physics
    return attrs


def _simulate_transducer(
    scn: Scenario, plan: _Plan, varr: SensorArray, inst: IntArray
) -> SimResult:
    """The transducer physics: thresholded, time-walked echoes; the first one per channel.

    Dropouts and spurious echoes join the candidates; the receiver's blanking and range
    limits apply before first-echo selection (the board reports the first echo it can
    hear, Kleeman & Kuc 1995); range noise and quantisation then apply to that reading.
    """
    c = scn.speed_of_sound
    imps = scn.imperfections
    seeds = np.random.SeedSequence(scn.seed).spawn(4)
    rng_drop, rng_spur, rng_noise, _ = (np.random.default_rng(s) for s in seeds)
    heard = transducer_echoes(scn.world, plan.sensors, inst, scn.transducer, c)
    keep = imp.dropouts(heard.channel.size, imps.dropout_probability, rng_drop)
    channel, path = heard.channel[keep], heard.path[keep]
    rx_min = plan.sensors.min_range[inst]
    rx_max = plan.sensors.max_range[inst]
    sc, sp = imp.spurious(rx_min, rx_max, imps.spurious_probability, rng_spur)
    channel = np.concatenate([channel, sc])
    path = np.concatenate([path, sp])
    half = 0.5 * path
    audible = (half >= rx_min[channel]) & (half <= rx_max[channel])
    channel, path = channel[audible], path[audible]
    idx = imp.first_per_channel(channel, path)
    channel, path = channel[idx], path[idx]
    path = imp.range_noise(path, imps.range_noise_sigma, rng_noise)
    if imps.quantise:
        path = imp.quantise(path, imps.quantum)
    readings = _readings(scn, plan, varr, channel, path, np.zeros(channel.size, dtype=bool))
    truth = _truth(scn, np.unique(heard.surface))
    return SimResult(varr.records(), readings, truth, c, _attrs(scn))


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

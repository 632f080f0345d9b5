"""A log's own-echo readings for the echo models: loading, scoring, the side-wall map.

The readings are those a run maps (its selection), with the sensors' readings that heard
nothing; :func:`score` counts, per sensor direction, the echoes a model's prediction
explains within 5 cm and the silent readings it predicts an echo for.
:func:`side_wall_map` draws a diagnostic map from the side sonars' line-of-sight echo
points, and :func:`implied_incidence` asks where on a wall a sensor's ranges put the echo.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt
from echo_geometry import axis_wall, segments_of

FloatArray = npt.NDArray[np.float64]

#: A range predicted within this is explained (the quality figure's 5 cm).
TOLERANCE = 0.05
#: Sensor directions (degrees off the robot's heading) that name the groups (as
#: ``unexplained.py``).
GROUPS = (("side", 60.0, 181.0), ("oblique", 20.0, 60.0), ("front", 0.0, 20.0))


@dataclass
class Readings:
    """A log's own-echo readings: sensor poses, measured range (NaN: nothing heard within
    the sensor's range), the sensor's maximum range and direction group."""

    xy: FloatArray
    heading: FloatArray
    half: FloatArray
    rng: FloatArray
    max_range: FloatArray
    group: npt.NDArray[np.str_]
    t: FloatArray
    sensor: npt.NDArray[np.intp]
    mount: FloatArray


def group_of(mount_deg: FloatArray) -> npt.NDArray[np.str_]:
    """The direction group of sensors ``mount_deg`` degrees off the robot's heading.

    >>> group_of(np.array([90.0, -50.0, 10.0])).tolist()
    ['side', 'oblique', 'front']
    """
    out = np.full(mount_deg.shape, "", dtype="<U8")
    a = np.abs(mount_deg)
    for name, lo, hi in GROUPS:
        out[(a >= lo) & (a < hi)] = name
    return out


def load_readings(log: Path, sensors: Path | None, robot: str | None) -> Readings:
    """The mapped readings (the run's selection: first echoes of a sensor's own pulse
    within its range) and the sensors' own readings that heard nothing."""
    from sonarproc.params import RunParams
    from sonarproc.pipeline.run import load_log
    from sonarproc.pipeline.selection import select_beams

    lg = load_log(log, sensors=sensors, robot=robot)
    beams, _ = select_beams(lg, RunParams())
    r, p = beams.readings, beams.poses
    own = np.all(p.tx_xy == p.rx_xy, axis=1) & (np.asarray(r["echo"]) == 0)
    parts = [(r[own], p.tx_xy[own], p.tx_heading[own], p.tx_half_beamwidth[own],
              0.5 * beams.path[own], p.max_range[own])]  # fmt: skip
    if beams.silent is not None:
        allr = lg.readings
        own_all = allr["tx"] == allr["rx"]
        flagged = (allr["flags"] & 1) != 0
        far = ~flagged & (0.5 * lg.path_lengths(allr) > float(lg.sensors["max_range"].min()))
        sr, sp = allr[own_all & (flagged | far)], beams.silent
        parts.append((sr, sp.tx_xy, sp.tx_heading, sp.tx_half_beamwidth,
                      np.full(len(sr), np.nan), sp.max_range))  # fmt: skip
    rr = np.concatenate([q[0] for q in parts])
    heading = np.concatenate([q[2] for q in parts]).astype(np.float64)
    mount = np.degrees(np.angle(np.exp(1j * (heading - np.asarray(rr["theta"], np.float64)))))
    return Readings(
        xy=np.vstack([q[1] for q in parts]).astype(np.float64),
        heading=heading,
        half=np.concatenate([q[3] for q in parts]).astype(np.float64),
        rng=np.concatenate([q[4] for q in parts]).astype(np.float64),
        max_range=np.concatenate([q[5] for q in parts]).astype(np.float64),
        group=group_of(mount),
        t=np.asarray(rr["t"], np.float64),
        sensor=np.asarray(rr["tx"], np.intp),
        mount=mount,
    )


def read_lines(path: Path) -> list[FloatArray]:
    """The polylines of a run's surfaces.csv (one-row point features left out)."""
    return read_map(path)[0]


def read_map(path: Path) -> tuple[list[FloatArray], FloatArray]:
    """The polylines of a run's surfaces.csv and its reported corners (P, 2)."""
    import csv

    polys: dict[int, list[tuple[float, float]]] = {}
    kinds: dict[int, str] = {}
    with path.open(newline="") as f:
        for row in csv.DictReader(f):
            polys.setdefault(int(row["surface"]), []).append((float(row["x"]), float(row["y"])))
            kinds[int(row["surface"])] = row["kind"]
    lines = [np.asarray(v, dtype=np.float64) for _, v in sorted(polys.items()) if len(v) >= 2]
    corners = [v[0] for k, v in sorted(polys.items()) if len(v) == 1 and kinds[k] == "corner"]
    return lines, np.asarray(corners, dtype=np.float64).reshape(-1, 2)


#: Largest gap (m) between consecutive line-of-sight points of one side sonar that still
#: lie on one wall: the robot moves a few centimetres between firings, so a longer jump is
#: a doorway, a corner or another wall.
WALL_GAP = 0.25
#: Largest distance (m) of a point from its wall's line: the ranges' quantisation and a few
#: centimetres of odometry error.
WALL_FIT = 0.05
#: Fewest points and shortest length (m) of a wall: a person draws walls, not glints.
WALL_POINTS, WALL_LENGTH = 5, 0.5


def _split_line(pts: FloatArray) -> list[FloatArray]:
    """``pts`` (in order along a run) as straight pieces within :data:`WALL_FIT` of their
    total-least-squares line (split at the farthest point, as split-and-merge does)."""
    if pts.shape[0] < WALL_POINTS:
        return []
    c = pts.mean(axis=0)
    _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
    dev = np.abs((pts - c) @ vt[1])
    if dev.max() <= WALL_FIT:
        t = (pts - c) @ vt[0]
        if t.max() - t.min() < WALL_LENGTH:
            return []
        return [np.vstack((c + t.min() * vt[0], c + t.max() * vt[0]))]
    k = int(np.clip(np.argmax(dev), 1, pts.shape[0] - 1))
    return _split_line(pts[:k]) + _split_line(pts[k:])


def side_wall_map(rd: Readings) -> list[FloatArray]:
    """Straight walls through the side sonars' line-of-sight echo points (a diagnostic map).

    Each side sonar's echo points, in time order, are cut where consecutive ones jump by
    more than :data:`WALL_GAP`, and each run into straight pieces (:func:`_split_line`).

    Examples
    --------
    >>> xs = np.arange(0.0, 2.0, 0.05)
    >>> rd = Readings(np.column_stack((xs, np.zeros_like(xs))), np.full(xs.size, np.pi / 2),
    ...               np.full(xs.size, 0.26), np.ones(xs.size), np.full(xs.size, 5.0),
    ...               np.full(xs.size, "side"), xs.copy(), np.zeros(xs.size, np.intp),
    ...               np.full(xs.size, 90.0))
    >>> np.round(side_wall_map(rd)[0], 3).tolist()
    [[0.0, 1.0], [1.95, 1.0]]
    """
    heard = np.isfinite(rd.rng) & (rd.group == "side")
    out: list[FloatArray] = []
    for sensor in np.unique(rd.sensor[heard]):
        sel = np.flatnonzero(heard & (rd.sensor == sensor))
        sel = sel[np.argsort(rd.t[sel], kind="stable")]
        pts = rd.xy[sel] + rd.rng[sel, None] * np.column_stack(
            (np.cos(rd.heading[sel]), np.sin(rd.heading[sel])))  # fmt: skip
        cut = np.flatnonzero(np.hypot(*np.diff(pts, axis=0).T) > WALL_GAP) + 1
        for run in np.split(pts, cut):
            out.extend(_split_line(run))
    return out


def score(rd: Readings, predicted: FloatArray) -> dict[str, dict[str, float]]:
    """Per group (and ``all``): the fraction of the readings with an echo that the
    prediction explains within :data:`TOLERANCE` (``explained``), their count
    (``echoes``), and the fraction of the readings that heard nothing for which it
    predicts an echo within the sensor's range (``false_echo``) and their count
    (``silent``).

    Examples
    --------
    >>> rd = Readings(np.zeros((3, 2)), np.zeros(3), np.zeros(3), np.array([1.0, 2.0, np.nan]),
    ...               np.full(3, 5.0), np.array(["side"] * 3), np.zeros(3), np.zeros(3, np.intp),
    ...               np.full(3, 90.0))
    >>> s = score(rd, np.array([1.03, 2.2, 4.0]))["side"]
    >>> s["explained"], s["false_echo"], s["echoes"], s["silent"]
    (0.5, 1.0, 2.0, 1.0)
    """
    heard = np.isfinite(rd.rng)
    within = predicted <= rd.max_range
    good = heard & within & (np.abs(predicted - np.nan_to_num(rd.rng)) <= TOLERANCE)
    false = ~heard & within
    out: dict[str, dict[str, float]] = {}
    for g in ("all", *(name for name, _, _ in GROUPS)):
        m = np.ones(rd.rng.shape, dtype=bool) if g == "all" else rd.group == g
        e, s = int((m & heard).sum()), int((m & ~heard).sum())
        out[g] = {
            "explained": float((good & m).sum()) / max(e, 1),
            "echoes": float(e),
            "false_echo": float((false & m).sum()) / max(s, 1),
            "silent": float(s),
        }
    return out


def implied_incidence(rd: Readings, walls: list[FloatArray]) -> dict[int, tuple[float, FloatArray]]:
    """Per sensor: the axis's incidence on the wall it meets (median, degrees), and the
    quantiles 10/25/50/75/90 % of the incidence its measured ranges imply on that wall,
    ``arccos(d / r)`` (the direction at which a point of the wall lies at the measured
    range ``r``; NaN for ranges shorter than the wall's distance ``d``).

    Were the mounts wrong, the implied incidences of a sensor would gather at another
    angle; echoes from features scattered along the wall or behind it spread them."""
    start, end = segments_of(walls)
    d, inc = axis_wall(rd.xy, rd.heading, start, end)
    out: dict[int, tuple[float, FloatArray]] = {}
    for s in np.unique(rd.sensor):
        m = (rd.sensor == s) & np.isfinite(rd.rng) & np.isfinite(d)
        if not m.any():
            continue
        ratio = d[m] / rd.rng[m]
        implied = np.degrees(np.arccos(np.where(ratio <= 1.0, ratio, np.nan)))
        q = np.nanquantile(implied, [0.1, 0.25, 0.5, 0.75, 0.9]) if np.isfinite(implied).any() \
            else np.full(5, np.nan)  # fmt: skip
        out[int(s)] = (float(np.degrees(np.median(inc[m]))), q)
    return out


def remount(rd: Readings, mounts_deg: dict[int, float]) -> Readings:
    """``rd`` with the sensors turned to other mount angles (degrees off the robot's
    heading; positions kept): to test whether the log's mount angles are the limit."""
    from dataclasses import replace

    heading = rd.heading.copy()
    for sensor, new in mounts_deg.items():
        m = rd.sensor == sensor
        heading[m] = rd.heading[m] + np.radians(new - rd.mount[m])
    mount = rd.mount.copy()
    for sensor, new in mounts_deg.items():
        mount[rd.sensor == sensor] = new
    return replace(rd, heading=heading, mount=mount, group=group_of(mount))

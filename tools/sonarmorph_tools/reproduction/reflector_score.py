"""How a surface map of a transducer-physics scene reports corners, far points and doorways.

The truth comes from the scene's world and the log's own readings; every rule is
geometric:

* **output far from truth**: the fitted surfaces sampled every :data:`SAMPLE_M` (a point
  reflector is one sample); the share of samples more than :data:`FAR_M` from every true
  surface.
* **concave corners in view**: a world vertex one of whose free-space sectors opens
  within :data:`CORNER_TOL_DEG` of 90 degrees (the retro-reflecting corners of
  :mod:`sonarsim.reflectors`). It is *in view* when at least :data:`MIN_VIEW_POSES`
  distinct poses had a sensor inside that sector, the vertex within its nominal beam
  half-width and maximum range, and a clear line of sight to it, and heard it: their
  range within :data:`HEARD_M` of the distance (the ranging board reports the first echo
  above its threshold only, so a corner far off the beam's axis, or behind a nearer
  echo in the beam, leaves no trace in the log). It is *reported* when a ``corner`` of
  the map lies within :data:`CORNER_MATCH_M` of it.
* **doorways**: a gap between two convex vertices (a free-space sector wider than 180
  degrees: a jamb or a wall's free end) from :data:`DOOR_WIDTH_M` apart, each with a wall
  arm pointing straight away from the other (within :data:`ARM_TOL_DEG`: the wall runs on
  through the gap's line), and no surface within :data:`DOOR_CLEAR_M` of the gap's
  inside. It is *seen through* when readings from at least :data:`MIN_VIEW_POSES`
  distinct poses had their beam axis cross its middle (more than :data:`JAMB_M` from
  either jamb) and echoed from more than :data:`DOOR_CLEAR_M` beyond it. It is *open*
  when no sample of a fitted line or curve lies on that middle: within
  :data:`DOOR_CLEAR_M` of the gap's line, between its two ends (a wall fitted a few
  centimetres past a jamb does not close the door).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from sonarlog.reader import SonarLog
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarsim.world import World

__all__ = [
    "ReflectorScore",
    "convex_gaps",
    "corner_sectors",
    "score_reflectors",
    "sensor_rays",
]

FloatArray = npt.NDArray[np.float64]

#: Fitted surfaces are sampled this finely (m) for the share of far output.
SAMPLE_M = 0.01
#: Output farther than this (m) from every true surface is *far*.
FAR_M = 0.10
#: A corner opening within this (deg) of 90 retro-reflects (the simulator's default).
CORNER_TOL_DEG = 15.0
#: A reported corner this close (m) to a true one matches it.
CORNER_MATCH_M = 0.05
#: Distinct poses needed to call a corner in view or a doorway seen through: a point is
#: located from three ranges at least.
MIN_VIEW_POSES = 3
#: A reading heard a corner when its range is within this (m) of the distance to it:
#: 1-inch range steps, a few mm of noise and the time walk of a weak echo.
HEARD_M = 0.03
#: Doorway widths (m): from a robot's width to a corridor's.
DOOR_WIDTH_M = (0.5, 3.0)
#: A jamb's wall arm points away from the other jamb within this (deg).
ARM_TOL_DEG = 10.0
#: Clearance (m) of a doorway: the completeness match distance.
DOOR_CLEAR_M = 0.05
#: The stretch (m) next to each jamb that a beam may graze: the jamb's own echo.
JAMB_M = 0.10
#: Two sensor positions closer than this (m) are one pose (the robot's range step).
POSE_STEP_M = 0.0254


@dataclass(frozen=True)
class ReflectorScore:
    """One scene's far share, corners and doorways (module notes)."""

    far_share: float
    corners_reported: int
    corners_in_view: int
    doors_open: int
    doors_seen: int
    #: the true corners in view that no ``corner`` matched (m)
    missed_corners: tuple[tuple[float, float], ...] = ()
    #: right-angled sectors of world vertices that no sensor saw (not in view: never
    #: inside the sector with the vertex in its beam, in range and in sight from
    #: :data:`MIN_VIEW_POSES` poses; a wall's solid side counts here too)
    corners_out_of_view: int = 0


def _sectors(arms: FloatArray) -> list[tuple[float, float]]:
    """(start angle, width) of each free sector between consecutive sorted arms (rad)."""
    if arms.size == 1:
        return [(float(arms[0]), 2 * np.pi)]
    widths = np.mod(np.roll(arms, -1) - arms, 2 * np.pi)
    return [(float(a), float(w)) for a, w in zip(arms, widths, strict=True)]


def _in_sector(phi: FloatArray, start: float, width: float) -> npt.NDArray[np.bool_]:
    return np.asarray(np.mod(phi - start, 2 * np.pi) < width)


def corner_sectors(world: World) -> list[tuple[FloatArray, float, float]]:
    """Concave right-angle corners: (vertex, sector start, sector width) (module notes)."""
    from sonarsim.reflectors import world_vertices

    tol = np.deg2rad(CORNER_TOL_DEG)
    out = []
    for v in world_vertices(world):
        for start, width in _sectors(v.arms):
            if abs(width - np.pi / 2) <= tol:
                out.append((v.xy, start, width))
    return out


def convex_gaps(world: World, truth: FloatArray) -> list[tuple[FloatArray, FloatArray]]:
    """The doorways of a world: pairs of jambs (module notes)."""
    from sonarsim.reflectors import world_vertices

    jambs = [(v.xy, v.arms) for v in world_vertices(world)
             if any(w > np.pi + 1e-3 for _, w in _sectors(v.arms))]  # fmt: skip
    tree = cKDTree(truth)
    tol = np.deg2rad(ARM_TOL_DEG)
    out = []
    for i, (a, arms_a) in enumerate(jambs):
        for b, arms_b in jambs[i + 1 :]:
            d = float(np.hypot(*(b - a)))
            if not DOOR_WIDTH_M[0] <= d <= DOOR_WIDTH_M[1]:
                continue
            away_a = np.arctan2(*(a - b)[::-1])  # from b towards a, continued past a
            away_b = np.arctan2(*(b - a)[::-1])
            ok_a = np.any(np.abs(np.angle(np.exp(1j * (arms_a - away_a)))) <= tol)
            ok_b = np.any(np.abs(np.angle(np.exp(1j * (arms_b - away_b)))) <= tol)
            if not (ok_a and ok_b):
                continue
            s = np.linspace(JAMB_M / d, 1 - JAMB_M / d, max(3, int(d / 0.01)))
            inside = a + s[:, None] * (b - a)
            if float(tree.query(inside)[0].min()) > DOOR_CLEAR_M:
                out.append((a, b))
    return out


@dataclass(frozen=True)
class SensorRays:
    """Every reading's sensor position, heading, half beam, maximum range and range (m, rad)."""

    xy: FloatArray
    heading: FloatArray
    half_beam: FloatArray
    max_range: FloatArray
    range_m: FloatArray  # NaN: no echo


def sensor_rays(log: SonarLog) -> SensorRays:
    """The readings of a sonarlog in world coordinates (the sensors ride on the turret)."""
    r = log.readings
    sens = log.sensors
    c = float(log.attrs.get("speed_of_sound", 343.0))
    row = {int(i): k for k, i in enumerate(sens["id"])}
    k = np.array([row[int(t)] for t in r["tx"]], dtype=np.intp)
    th = np.asarray(r["turret"], dtype=np.float64)
    mx, my = sens["x"][k], sens["y"][k]
    xy = np.column_stack((r["x"] + np.cos(th) * mx - np.sin(th) * my,
                          r["y"] + np.sin(th) * mx + np.cos(th) * my))  # fmt: skip
    rng = np.asarray(r["tof"], dtype=np.float64) * c / 2.0
    rng[np.asarray(r["flags"]) != 0] = np.nan
    return SensorRays(xy, th + sens["heading"][k], np.asarray(sens["half_beamwidth"][k]),
                      np.asarray(sens["max_range"][k], dtype=np.float64), rng)  # fmt: skip


def _poses(xy: FloatArray) -> int:
    return int(np.unique(np.round(xy / POSE_STEP_M).astype(np.int64), axis=0).shape[0])


def _corner_in_view(world: World, rays: SensorRays, v: FloatArray, start: float,
                    width: float) -> bool:  # fmt: skip
    from sonarsim.occlusion import blocked

    rel = rays.xy - v
    dist = np.hypot(rel[:, 0], rel[:, 1])
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(-rel[:, 1], -rel[:, 0]) - rays.heading))))
    cand = _in_sector(np.arctan2(rel[:, 1], rel[:, 0]), start, width)
    cand &= (off <= rays.half_beam) & (dist <= rays.max_range) & (dist > 0)
    idx = np.flatnonzero(cand)
    if _poses(rays.xy[idx]) < MIN_VIEW_POSES:
        return False
    clear = ~blocked(world.segments, rays.xy[idx], np.repeat(v[None, :], idx.size, axis=0),
                     tol=1e-3)  # fmt: skip
    idx = idx[clear]
    heard = np.abs(rays.range_m[idx] - dist[idx]) <= HEARD_M  # NaN (no echo): not heard
    return _poses(rays.xy[idx[heard]]) >= MIN_VIEW_POSES


def _seen_through(rays: SensorRays, a: FloatArray, b: FloatArray) -> bool:
    h = np.column_stack((np.cos(rays.heading), np.sin(rays.heading)))
    v = b - a
    length = float(np.hypot(*v))
    den = h[:, 0] * v[1] - h[:, 1] * v[0]
    d = a - rays.xy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (d[:, 0] * v[1] - d[:, 1] * v[0]) / den
        u = (d[:, 0] * h[:, 1] - d[:, 1] * h[:, 0]) / den
    lo = JAMB_M / length
    hit = (np.abs(den) > 1e-9) & (t > 0) & (u >= lo) & (u <= 1 - lo)
    hit &= np.isfinite(rays.range_m) & (rays.range_m > t + DOOR_CLEAR_M)
    return _poses(rays.xy[hit]) >= MIN_VIEW_POSES


def _bridged(samples: FloatArray, a: FloatArray, b: FloatArray) -> bool:
    """Whether a fitted sample lies on the doorway's middle (module notes)."""
    v = b - a
    length = float(np.hypot(*v))
    d = samples - a
    along = d @ v / length
    across = np.abs(d[:, 0] * v[1] - d[:, 1] * v[0]) / length
    on = (along > JAMB_M) & (along < length - JAMB_M) & (across <= DOOR_CLEAR_M)
    return bool(on.any())


def _samples(fits: Sequence[SurfaceFit]) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Samples of the fitted surfaces every :data:`SAMPLE_M`, and which are point reflectors."""
    pts: list[FloatArray] = []
    point: list[npt.NDArray[np.bool_]] = []
    for f in fits:
        poly = np.asarray(f.polyline, dtype=np.float64)
        if poly.shape[0] == 1:
            pts.append(poly)
            point.append(np.ones(1, dtype=bool))
            continue
        if f.closed:
            poly = np.vstack((poly, poly[:1]))
        for p, q in itertools.pairwise(poly):
            n = max(1, int(np.ceil(np.hypot(*(q - p)) / SAMPLE_M)))
            s = np.linspace(0.0, 1.0, n + 1)
            pts.append(p + s[:, None] * (q - p))
            point.append(np.zeros(n + 1, dtype=bool))
    if not pts:
        return np.zeros((0, 2)), np.zeros(0, dtype=bool)
    return np.concatenate(pts), np.concatenate(point)


def score_reflectors(world: World, log: SonarLog, fits: Sequence[SurfaceFit]) -> ReflectorScore:
    """The far share, corners and doorways of one run (module notes).

    Parameters
    ----------
    world : sonarsim.World
        The scene's world (every surface is truth).
    log : sonarlog.SonarLog
        The simulated log the map was made from.
    fits : list of SurfaceFit
        The run's surfaces (``model`` ``corner`` for a reported corner).
    """
    truth = world.truth_profile(spacing=0.005, surfaces=range(len(world.surfaces)))
    truth = truth[np.isfinite(truth).all(axis=1)]
    tree = cKDTree(truth)
    xy, is_point = _samples(fits)
    far = float(np.mean(tree.query(xy)[0] > FAR_M)) if xy.shape[0] else 0.0
    rays = sensor_rays(log)
    found = np.array([np.asarray(f.polyline)[0] for f in fits
                      if f.model == "corner"]).reshape(-1, 2)  # fmt: skip
    in_view, reported, missed, out_of_view = 0, 0, [], 0
    for v, start, width in corner_sectors(world):
        if not _corner_in_view(world, rays, v, start, width):
            out_of_view += 1
            continue
        in_view += 1
        if found.shape[0] and float(np.hypot(*(found - v).T).min()) <= CORNER_MATCH_M:
            reported += 1
        else:
            missed.append((round(float(v[0]), 3), round(float(v[1]), 3)))
    lines = xy[~is_point]
    seen, open_ = 0, 0
    for a, b in convex_gaps(world, truth):
        if not _seen_through(rays, a, b):
            continue
        seen += 1
        if not _bridged(lines, a, b):
            open_ += 1
    return ReflectorScore(far, reported, in_view, open_, seen, tuple(missed), out_of_view)

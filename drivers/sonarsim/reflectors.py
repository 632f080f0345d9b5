"""Point reflectors of a world: concave corners and convex edges, derived from polylines.

Every straight piece of a ``wall``, ``polyline`` or ``room`` surface leaves its two end
points along a direction (an *arm*). End points within :data:`MERGE_TOLERANCE` of each
other are one vertex (so two ``wall`` entries meeting at a point make a corner). Around
a vertex its arms split the plane into sectors. Which side of the walls is free space is
not declared: it is the sector the sensor stands in (a sensor never stands inside solid
material). Seen from a sector narrower than 180 degrees the vertex is a concave corner;
from one wider than 180 degrees (including the full turn around a free wall end, a door
jamb) it is a convex edge; a sector of 180 degrees is a straight continuation and gives
no point echo. Curved surfaces (circles, curves) have no vertices: their sampled
segments' ends are not corners, and a straight wall ending on a curve keeps a free end
(it diffracts as an edge, which is also what a junction far from a right angle does).

A concave corner whose opening is within ``corner_angle_tolerance_deg`` of 90 degrees
retro-reflects (two specular bounces return the pulse towards the sensor from anywhere
inside the opening, Kuc & Siegel 1987): path ``2 |S - V|``. Other vertices diffract as
weak point sources (Kuc & Siegel 1987; Leonard & Durrant-Whyte 1991).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sonarsim.geometry import FloatArray, wrap_angle
from sonarsim.occlusion import blocked
from sonarsim.segments import Segments
from sonarsim.specular import Sensors
from sonarsim.surfaces import Polyline
from sonarsim.transducer import TransducerParams, amplitude
from sonarsim.world import World

MERGE_TOLERANCE = 1e-3
"""End points closer than this (m) are one vertex: below any wall thickness modelled."""

STRAIGHT_TOLERANCE = 1e-3
"""Sectors within this (rad) of 180 degrees are straight continuations."""

IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class Vertex:
    """A vertex: position, sorted arm angles (rad, CCW) and the surface it belongs to."""

    xy: FloatArray
    arms: FloatArray
    surface: int


def world_vertices(world: World) -> list[Vertex]:
    """The vertices of the world's straight-piece surfaces (see the module docstring)."""
    pts: list[FloatArray] = []
    dirs: list[FloatArray] = []
    srf: list[int] = []
    for i, s in enumerate(world.surfaces):
        if not isinstance(s, Polyline):
            continue
        v = np.vstack([s.points, s.points[:1]]) if s.closed else s.points
        a, b = v[:-1], v[1:]
        keep = np.hypot(*(b - a).T) > 0.0
        a, b = a[keep], b[keep]
        pts += [a, b]
        dirs += [np.arctan2(*(b - a)[:, ::-1].T), np.arctan2(*(a - b)[:, ::-1].T)]
        srf += [i] * (2 * len(a))
    if not pts:
        return []
    p = np.concatenate(pts)
    d = np.concatenate(dirs)
    s_idx = np.asarray(srf)
    key = np.round(p / MERGE_TOLERANCE).astype(np.int64)
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    out = []
    for g in range(int(inv.max()) + 1):
        m = np.flatnonzero(inv == g)
        out.append(Vertex(p[m].mean(axis=0), np.sort(np.mod(d[m], 2 * np.pi)), int(s_idx[m[0]])))
    return out


def _sector_width(arms: FloatArray, phi: FloatArray) -> FloatArray:
    """Angular width (rad) of the sector between arms that contains direction ``phi``."""
    if arms.size == 1:
        return np.full(phi.shape, 2 * np.pi)
    ph = np.mod(phi, 2 * np.pi)
    k = np.searchsorted(arms, ph, side="right")  # next arm CCW is arms[k % n]
    lo = arms[(k - 1) % arms.size]
    hi = arms[k % arms.size]
    return np.asarray(np.mod(hi - lo, 2 * np.pi))


@dataclass(frozen=True)
class PointEchoes:
    """Heard point echoes: channel, path (m, before time walk), amplitude, surface."""

    channel: IntArray
    path: FloatArray
    amp: FloatArray
    surface: IntArray


def point_echoes(
    world: World, segs: Segments, sensors: Sensors, inst: IntArray, params: TransducerParams,
    speed_of_sound: float, search_angle: float,
) -> PointEchoes:  # fmt: skip
    """Corner and edge echoes above the threshold, for monostatic channels.

    Parameters
    ----------
    inst : ndarray of intp, shape (C,)
        Row of ``sensors`` that fires and listens on each channel.
    search_angle : float
        No echo is heard farther off the axis than this (rad).
    """
    xy = sensors.xy[inst]
    hd = sensors.heading[inst]
    rmin = sensors.min_range[inst]
    rmax = sensors.max_range[inst]
    tol90 = np.deg2rad(params.corner_angle_tolerance_deg)
    ch: list[IntArray] = []
    path: list[FloatArray] = []
    amp: list[FloatArray] = []
    srf: list[IntArray] = []
    for v in world_vertices(world):
        rel = v.xy[None, :] - xy
        r = np.hypot(rel[:, 0], rel[:, 1])
        theta = np.abs(wrap_angle(np.arctan2(rel[:, 1], rel[:, 0]) - hd))
        cand = np.flatnonzero((theta <= search_angle) & (r >= rmin) & (r <= rmax))
        if cand.size == 0:
            continue
        width = _sector_width(v.arms, np.arctan2(-rel[cand, 1], -rel[cand, 0]))
        corner = np.abs(width - np.pi / 2) <= tol90
        straight = np.abs(width - np.pi) <= STRAIGHT_TOLERANCE
        refl = np.where(corner, params.corner_reflectivity, params.edge_reflectivity)
        expo = np.where(corner, 2.0, params.edge_spreading_exponent)
        th = theta[cand]
        a = amplitude(th, th, r[cand], refl, expo, params, speed_of_sound)
        ok = (a >= params.threshold) & ~straight
        cand, a = cand[ok], a[ok]
        if cand.size == 0:
            continue
        free = ~blocked(segs, xy[cand], np.broadcast_to(v.xy, (cand.size, 2)).copy(), tol=1e-4)
        ch.append(cand[free])
        path.append(2.0 * r[cand[free]])
        amp.append(a[free])
        srf.append(np.full(int(free.sum()), v.surface, dtype=np.intp))
    if not ch:
        z = np.zeros(0)
        return PointEchoes(np.zeros(0, np.intp), z, z, np.zeros(0, np.intp))
    return PointEchoes(
        np.concatenate(ch), np.concatenate(path), np.concatenate(amp), np.concatenate(srf)
    )

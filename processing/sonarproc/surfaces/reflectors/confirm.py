"""Point reflectors checked against the fitted surfaces: only what no surface explains.

:func:`confirm_points` gives each point only the readings no fitted surface explains: a
reading whose range equals its sensor's distance to a fitted surface, at a foot inside
that surface and inside its beam, is that surface's specular echo (near a concave
corner the two walls' readings together can look like a point in front of it; at a
wall's end, the readings from near its normal read the distance to the end as well); so
is a reading whose beam axis meets a fitted surface at its range (a diffuse echo off it).
The point is refitted on the rest and tested again
(:func:`sonarproc.surfaces.reflectors.rcd.point_feature`). A point inside a fitted plane
(:func:`sonarproc.surfaces.reflectors.walls.inside_walls`) is that plane's echo and goes;
so does a point on a fitted arc's circle that the circle explains (:func:`on_circles`),
and one that is a pillar's surface with the planes fitted to parts of that pillar
(:func:`~sonarproc.surfaces.reflectors.cylinders.pillar_pieces`).
A point stays where a fitted plane ends at it, or where its echoes say it is a
retro-reflecting corner (:func:`heard_as_corner`) that answered its beams
(:func:`~sonarproc.surfaces.reflectors.point_echoes.answers_its_beams`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry, echo_points
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.cylinders import pillar_pieces, segment_distance
from sonarproc.surfaces.reflectors.point_echoes import (
    CORNER_TOL_RAD,
    MIN_FAR_POSES,
    BeamIndex,
    answers_its_beams,
    far_poses,
)
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M
from sonarproc.surfaces.reflectors.rcd import PointFeature, point_feature
from sonarproc.surfaces.reflectors.walls import (
    CHAIN_GAP_M,
    END_REACH_M,
    LINE_REACH_M,
    inside_walls,
    on_wall_lines,
    side_of_line,
)

__all__ = ["confirm_points", "heard_as_corner", "line_ends", "on_circles"]

FloatArray = npt.NDArray[np.float64]

#: Curved surfaces are tested for diffuse echoes along chords about this long (m): the
#: range tolerance's worth of sagitta on a 0.3 m radius.
CHORD_M = 0.08


def confirm_points(
    points: list[PointFeature], echoes: EchoGeometry, surfaces: list[SurfaceFit]
) -> list[tuple[int, PointFeature]]:
    """``points`` refitted on the readings no fitted surface explains (module notes).

    Parameters
    ----------
    points : list of PointFeature
        From :func:`~sonarproc.surfaces.reflectors.rcd.find_point_features`.
    echoes : EchoGeometry
        The readings the points index.
    surfaces : list of SurfaceFit
        The fitted surfaces (lines, arcs, splines).

    Returns
    -------
    list of (int, PointFeature)
        The points that still pass every test (their index in ``points``, the refitted
        point), in the order given.
    """
    polys = [s.polyline for s in surfaces if s.polyline.shape[0] >= 2]
    closed = [s.closed for s in surfaces if s.polyline.shape[0] >= 2]
    walls = line_ends(surfaces)
    boxes = _WallBoxes(walls)
    todo = [k for k, f in enumerate(points) if not boxes.inside(f.xy)]
    explained = np.zeros(echoes.size, dtype=bool)
    if polys and todo:
        # the points' readings at once (each belongs to one point)
        mine = np.zeros(echoes.size, dtype=bool)
        for k in todo:
            mine[points[k].readings] = True
        rows = np.flatnonzero(mine)
        for got in echo_points(polys, closed, echoes.subset(mine), tol=RANGE_TOL_M):
            explained[rows[got.readings]] = True
        coarse = [np.stack((a, b)) for a, b in walls]
        coarse += [_decimated(s.polyline) for s in surfaces
                   if s.model != "line" and s.polyline.shape[0] >= 2]  # fmt: skip
        explained[rows[_axis_meets(echoes.subset(mine), coarse)]] = True
    pillars = _Pillars(echoes, surfaces)
    out: list[tuple[int, PointFeature]] = []
    beams: BeamIndex | None = None  # made once, when the first point gets that far
    for k in todo:
        f = points[k]
        new = point_feature(echoes, f.readings[~explained[f.readings]], f.xy)
        if new is None or on_circles(new.xy, surfaces, _heard(new, echoes)):
            continue
        if not _anchored(new, walls, boxes):
            if not heard_as_corner(new, echoes, walls):
                continue
            beams = BeamIndex(echoes) if beams is None else beams
            if not answers_its_beams(new, echoes, beams):
                continue
        # last: a circle fit (and the near planes' readings), for the points that stay
        if not pillars.pieces(new):
            out.append((k, new))
    return out


class _Pillars:
    """Whether a point and the planes that may end at it are one pillar's pieces
    (:func:`~sonarproc.surfaces.reflectors.cylinders.pillar_pieces`); a plane's specular
    readings are found when a point near it first asks."""

    def __init__(self, echoes: EchoGeometry, surfaces: list[SurfaceFit]) -> None:
        self.echoes = echoes
        self.planes = [s.polyline for s in surfaces if s.model == "line"
                       and not s.closed and s.polyline.shape[0] >= 2]  # fmt: skip
        self.walls = [(p[0], p[-1]) for p in self.planes]
        self._got: dict[int, tuple[npt.NDArray[np.intp], FloatArray]] = {}

    def pieces(self, p: PointFeature) -> bool:
        """Whether ``p`` is the surface of a pillar that planes were fitted to in part."""
        near = [k for k, (a, b) in enumerate(self.walls)
                if segment_distance(p.xy, a, b) <= END_REACH_M]  # fmt: skip
        todo = [k for k in near if k not in self._got]
        if todo:
            got = echo_points([self.planes[k] for k in todo], [False] * len(todo), self.echoes,
                              tol=RANGE_TOL_M)  # fmt: skip
            self._got.update((k, (g.readings, g.points)) for k, g in zip(todo, got, strict=True))
        planes = [(*self.walls[k], *self._got[k]) for k in near]
        return pillar_pieces(self.echoes, p.readings, p.xy, planes)


class _WallBoxes:
    """The fitted planes near a point, by their bounding boxes, for :func:`inside_walls`.

    A point inside a plane lies within :data:`LINE_REACH_M` of its segment, so within its
    bounding box grown by that (and a micrometre for rounding); only those planes are
    tested, which gives :func:`inside_walls`' answer for every plane without testing
    the rest one by one.
    """

    def __init__(self, walls: list[tuple[FloatArray, FloatArray]]) -> None:
        self.walls = walls
        ends = np.array(walls, dtype=np.float64).reshape(-1, 2, 2)
        reach = LINE_REACH_M + 1e-6
        self.lo, self.hi = ends.min(axis=1) - reach, ends.max(axis=1) + reach

    def inside(self, xy: FloatArray) -> bool:
        """Whether ``xy`` lies inside a plane (:func:`inside_walls`)."""
        near = np.flatnonzero(((self.lo <= xy) & (xy <= self.hi)).all(axis=1))
        return bool(near.size) and bool(inside_walls(xy, [self.walls[i] for i in near])[0])


def on_circles(
    xy: npt.ArrayLike,
    surfaces: list[SurfaceFit],
    heard: tuple[FloatArray, FloatArray] | None = None,
) -> bool:
    """Whether a point lies on the circle of a fitted arc (within :data:`RANGE_TOL_M`).

    A cylinder answers from the point of it facing the sensor, so seen from a narrow
    sector it looks like a point reflector; on its fitted arc's circle, past the arc's
    ends, such a point is more of the cylinder, not a corner or an edge. With ``heard``
    (the point's sensor positions (N, 2) and ranges (N,)), only when that circle explains
    the ranges: more than half of them within :data:`RANGE_TOL_M` of the distance to the
    circle (``| |s - c| - r |``). The point's position alone does not say it: a wall
    fitted as an arc of a large radius runs through its own corners, whose echoes come
    from the corner, not from the circle's facing point.
    """
    p = np.asarray(xy, dtype=np.float64).reshape(2)
    for s in surfaces:
        if s.model != "arc" or "centre" not in s.params or "radius" not in s.params:
            continue
        c = np.asarray(s.params["centre"], dtype=np.float64).reshape(2)
        radius = float(s.params["radius"])
        if abs(math.dist(p, c) - radius) > RANGE_TOL_M:
            continue
        if heard is None:
            return True
        sensors, rng = heard
        to_circle = np.abs(np.hypot(*(sensors - c).T) - radius)
        if np.count_nonzero(np.abs(to_circle - rng) <= RANGE_TOL_M) * 2 > rng.size:
            return True
    return False


def heard_as_corner(
    point: PointFeature, echoes: EchoGeometry, walls: list[tuple[FloatArray, FloatArray]]
) -> bool:
    """Whether the echoes say a point is a retro-reflecting corner without a plane ending there.

    A corner answers from anywhere in its opening, also where neither of its walls is
    ever seen head on (a door recess's back corners from the corridor), so a point that
    ended a first fit's plane stays when a refit without its readings loses that plane
    (:func:`~sonarproc.surfaces.reflectors.points.refine_with_points`) if it is heard from
    :data:`MIN_FAR_POSES` poses beyond the edge reach, inside one right angle
    (:func:`~sonarproc.surfaces.reflectors.point_echoes.echo_kind`). Its sound reached
    the sensors, so their sight lines to it cross no fitted plane (:func:`_occluded`);
    and its two walls meet at it, so it does not stand just in front of a fitted plane's
    face (:func:`_before_wall`).
    """
    if point.span_rad > math.pi / 2 + CORNER_TOL_RAD or far_poses(point, echoes) < MIN_FAR_POSES:
        return False
    return not (_occluded(point, echoes, walls) or _before_wall(point, echoes, walls))


def _occluded(
    point: PointFeature, echoes: EchoGeometry, walls: list[tuple[FloatArray, FloatArray]]
) -> bool:
    """Whether most of the point's sight lines cross a fitted plane short of it.

    Short of it: by more than :data:`RANGE_TOL_M` (the plane it sits on meets them there).
    """
    if not walls:
        return False
    q = echoes.xy[point.readings]
    d = point.xy - q  # (N, 2) sight lines
    blocked = np.zeros(q.shape[0], dtype=bool)
    for a, b in walls:
        v = b - a
        den = d[:, 0] * v[1] - d[:, 1] * v[0]
        w = a - q
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[:, 0] * v[1] - w[:, 1] * v[0]) / den  # along the sight line (0..1)
            u = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / den  # along the plane (0..1)
        reach = 1.0 - RANGE_TOL_M / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        blocked |= (np.abs(den) > 1e-12) & (t > 0) & (t < reach) & (u >= 0) & (u <= 1)
    return bool(np.count_nonzero(blocked) * 2 > blocked.size)


def _before_wall(
    point: PointFeature, echoes: EchoGeometry, walls: list[tuple[FloatArray, FloatArray]]
) -> bool:
    """Whether the point stands in front of a fitted plane's face, inside its extent.

    In front: on the sensors' side, from :data:`LINE_REACH_M` to :data:`CHAIN_GAP_M` off
    the plane (a sonar cannot tell a point that close from the plane's own echoes),
    more than :data:`END_REACH_M` from its ends.
    """
    sensors = echoes.xy[point.readings]
    for a, b in walls:
        v = b - a
        length = math.hypot(float(v[0]), float(v[1]))
        if length <= 2 * END_REACH_M:
            continue
        u = v / length
        along = float((point.xy - a) @ u)
        off = float(side_of_line(a, b, point.xy)) / length
        side = float(np.median(np.sign(side_of_line(a, b, sensors))))
        if END_REACH_M < along < length - END_REACH_M and LINE_REACH_M < side * off <= CHAIN_GAP_M:
            return True
    return False


def _heard(point: PointFeature, echoes: EchoGeometry) -> tuple[FloatArray, FloatArray]:
    """The point's sensor positions and ranges."""
    return echoes.xy[point.readings], echoes.range_m[point.readings]


def _anchored(
    f: PointFeature, walls: list[tuple[FloatArray, FloatArray]], boxes: _WallBoxes
) -> bool:
    """Whether a point is where a fitted plane ends.

    A point reflector is the end of a wall (a corner, a box's edge, a jamb): it lies on a
    fitted plane's line at or past one of its ends
    (:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`), not inside it (there it
    is the plane's own echo). A point no plane leads to is not reported: the arcs of
    several surfaces cross by chance at points, a few times each, and what is seen of a
    real reflector without any wall (a thin post) is fitted as a curve by the map. A
    retro-reflecting corner whose walls were not fitted (seen only from far along its
    bisector, at the end of a corridor) is kept by :func:`confirm_points` when its echoes
    say so (:func:`heard_as_corner`: heard from beyond an edge's reach, inside one right
    angle) and it answered most beams that held it near their axis
    (:func:`~sonarproc.surfaces.reflectors.point_echoes.answers_its_beams`; a chance
    crossing of arcs answers few of them).
    """
    if not walls or boxes.inside(f.xy):
        return False
    return bool(on_wall_lines(f.xy, walls)[0])


def _decimated(poly: FloatArray) -> FloatArray:
    """Every few vertices of a polyline, chords about :data:`CHORD_M` long, both ends kept."""
    step = float(np.median(np.hypot(*np.diff(poly, axis=0).T)))
    k = max(1, round(CHORD_M / max(step, 1e-9)))
    idx = np.unique(np.r_[np.arange(0, poly.shape[0], k), poly.shape[0] - 1])
    return np.asarray(poly[idx], dtype=np.float64)


def _axis_meets(echoes: EchoGeometry, polys: list[FloatArray]) -> npt.NDArray[np.bool_]:
    """Readings whose beam axis meets a fitted surface at their range (a diffuse echo off it).

    The axis is a ray from the sensor; each polyline's segments are tested, and a reading
    is explained when the nearest crossing lies within :data:`RANGE_TOL_M` of its range.
    """
    h = np.column_stack((np.cos(echoes.heading), np.sin(echoes.heading)))
    first = np.full(echoes.size, np.inf)
    for poly in polys:
        a, b = poly[:-1], poly[1:]
        v = b - a  # (S, 2)
        den = h[:, None, 0] * v[None, :, 1] - h[:, None, 1] * v[None, :, 0]
        d = a[None, :, :] - echoes.xy[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (d[..., 0] * v[None, :, 1] - d[..., 1] * v[None, :, 0]) / den
            u = (d[..., 0] * h[:, None, 1] - d[..., 1] * h[:, None, 0]) / den
        hit = (np.abs(den) > 1e-12) & (t > 0) & (u >= 0) & (u <= 1)
        first = np.minimum(first, np.where(hit, t, np.inf).min(axis=1))
    return np.asarray(np.abs(first - echoes.range_m) <= RANGE_TOL_M)


def line_ends(surfaces: list[SurfaceFit]) -> list[tuple[FloatArray, FloatArray]]:
    """The two ends of each open straight surface (plane)."""
    return [(s.polyline[0], s.polyline[-1]) for s in surfaces
            if s.model == "line" and not s.closed and s.polyline.shape[0] >= 2]  # fmt: skip

"""Point reflectors checked against the fitted surfaces, and told apart: corner or edge.

:func:`confirm_points` gives each point only the readings no fitted surface explains: a
reading whose range equals its sensor's distance to a fitted surface, at a foot inside
that surface and inside its beam, is that surface's specular echo (near a concave
corner the two walls' readings together can look like a point in front of it; at a
wall's end, the readings from near its normal read the distance to the end as well); so
is a reading whose beam axis meets a fitted surface at its range (a diffuse echo off it).
The point is refitted on the rest and tested again
(:func:`sonarproc.surfaces.reflectors.rcd.point_feature`). A point inside a fitted plane
(:func:`sonarproc.surfaces.reflectors.walls.inside_walls`) is that plane's echo and goes.

:func:`point_kind` says which kind of point it is. First from the echo physics
(:func:`echo_kind`):

* sensors spread round the point by more than a right angle plus
  :data:`CORNER_TOL_RAD`: an **edge** (a concave corner retro-reflects only towards
  sensors inside its opening, and only when that opening is within
  :data:`CORNER_TOL_RAD` of a right angle; a convex edge has a free sector wider than
  180 degrees);
* heard from at least :data:`MIN_FAR_POSES` distinct poses farther than
  :data:`EDGE_REACH_M`: a **corner** (its two specular bounces return as much as a
  plane, spreading as 1/r^2, heard to the sonar's full range; an edge's diffracted
  echo is far weaker and dies out close by);
* passed by: at least :data:`MIN_CROSSINGS` readings from inside the sensors' sector,
  farther than :data:`EDGE_REACH_M`, with the point near their beam's axis, echoed from
  beyond it: an **edge** (a corner there would have answered first).

When the echoes do not tell, from the fitted straight surfaces
(planes) that end at it (the point on the plane's line, within :data:`LINE_REACH_M`, at
or past its nearer end, from :data:`END_REACH_M` inside it:
:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`):

* two such planes: a **corner** (concave) when each plane's far end lies on the side of
  the other that the sensors saw it from (the sensors inside the angle), else an
  **edge** (a convex box corner seen from outside);
* one plane: an **edge** when sensors past its end (beyond the point along the plane)
  heard the point, which only a free end or a convex corner allows (behind a concave
  corner's other wall there is no room for a sensor), or when at least
  :data:`MIN_CROSSINGS` beams crossed the place of the other wall a right-angled concave
  corner would have there (from :data:`OTHER_WALL_M`, from the point towards the sensors'
  side: a reading's axis crossing it before its echo saw free space there); else a
  **corner** whose other wall was not fitted;
* no plane: a **corner** when its sensors all lie in one half-plane round it (a
  concave corner is heard only from inside its opening, of at most 180 degrees), an
  **edge** when they surround it by more.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry, echo_points
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.rcd import (
    RANGE_TOL_M,
    PointFeature,
    point_feature,
)
from sonarproc.surfaces.reflectors.walls import (
    CHAIN_GAP_M,
    END_REACH_M,
    LINE_REACH_M,
    inside_walls,
    on_wall_lines,
)

__all__ = [
    "answers_its_beams",
    "confirm_points",
    "echo_kind",
    "heard_as_corner",
    "line_ends",
    "on_circles",
    "point_kind",
]

FloatArray = npt.NDArray[np.float64]

#: A sensor is past a plane's end when it lies beyond the point along the plane by more
#: than this (m): the range tolerance.
PAST_END_M = RANGE_TOL_M
#: The other wall of a concave corner is looked for over this stretch (m) from the
#: point: from twice the range tolerance (beams aimed at the corner itself graze it) to
#: a beam's footprint at 1 m (2 x 1 m x tan 12.5 deg, about 0.45 m).
OTHER_WALL_M = (2 * RANGE_TOL_M, 0.45)
#: Beams crossing that stretch that say it is free space (one may be a stray echo).
MIN_CROSSINGS = 2
#: A concave vertex retro-reflects when its opening is within this (rad) of a right angle
#: (two specular bounces return the pulse only when the walls are near perpendicular;
#: Kuc & Siegel 1987 find a tolerance of the order of the beam half-width).
CORNER_TOL_RAD = math.radians(15.0)
#: An edge is heard no farther than this (m). A diffracted echo is at least 20 dB weaker
#: than a specular one at 1 m (Kuc & Siegel 1987; Barshan & Kuc 1990) and spreads at
#: least as fast: with the receiver threshold that lets a plane or a corner be heard to
#: the Polaroid ranging board's 5 m or more (a specular echo at 5 m is 1/25 of one at
#: 1 m), an edge falls below it at 5 m x sqrt(0.1), about 1.6 m; 2 m leaves margin.
EDGE_REACH_M = 2.0
#: Distinct poses from beyond :data:`EDGE_REACH_M` that make a point a corner (one or
#: two may be another surface's echo at the same range by chance).
MIN_FAR_POSES = 3
#: A point lies near a beam's axis when it is within this fraction of the half-width off
#: it: the main lobe's centre, where a corner's echo clears the threshold at any range.
AXIS_SHARE = 0.5


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
    out: list[tuple[int, PointFeature]] = []
    for k in todo:
        f = points[k]
        new = point_feature(echoes, f.readings[~explained[f.readings]], f.xy)
        if new is None or on_circles(new.xy, surfaces, _heard(new, echoes)):
            continue
        if _anchored(new, walls, boxes) or (
            heard_as_corner(new, echoes, walls) and answers_its_beams(new, echoes)
        ):
            out.append((k, new))
    return out


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
    (:func:`echo_kind`). Its sound reached the sensors, so their sight lines to it cross
    no fitted plane (:func:`_occluded`); and its two walls meet at it, so it does not
    stand just in front of a fitted plane's face (:func:`_before_wall`).
    """
    if point.span_rad > math.pi / 2 + CORNER_TOL_RAD or _far_poses(point, echoes) < MIN_FAR_POSES:
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
        off = float(_side(a, b, point.xy)) / length
        side = float(np.median(np.sign(_side(a, b, sensors))))
        if END_REACH_M < along < length - END_REACH_M and LINE_REACH_M < side * off <= CHAIN_GAP_M:
            return True
    return False


#: Share of the beams holding a point near their axis that a retro-reflecting corner
#: answers: all of them, less dropouts and the range step's rounding; more than half.
ANSWER_SHARE = 0.5


def answers_its_beams(point: PointFeature, echoes: EchoGeometry) -> bool:
    """Whether the point answered most of the beams that held it near their axis.

    A retro-reflecting corner returns as much as a plane from anywhere inside its
    opening, so every reading from inside its sensors' sector (the complement of their
    largest gap of bearings), no farther than its farthest reading, with the point within
    :data:`AXIS_SHARE` of the half beam of its axis, ranges it, within :data:`RANGE_TOL_M`.
    Where several surfaces' arcs cross by chance, the beams aimed at the crossing range
    the surfaces behind it, or a surface in front of it (a crossing behind a wall, which
    no sound reached): more than :data:`ANSWER_SHARE` of them must range the point.
    """
    p = point.xy
    rel = echoes.xy - p
    dist = np.hypot(rel[:, 0], rel[:, 1])
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    own = np.sort(bearing[point.readings])
    if own.size < 2:
        return False
    gaps = np.diff(np.r_[own, own[0] + 2 * np.pi])
    start = own[(int(np.argmax(gaps)) + 1) % own.size]
    inside = np.mod(bearing - start, 2 * np.pi) <= point.span_rad
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(-rel[:, 1], -rel[:, 0]) - echoes.heading))))
    aimed = inside & (off <= AXIS_SHARE * echoes.half_beam)
    aimed &= dist <= float(dist[point.readings].max()) + RANGE_TOL_M
    answered = aimed & (np.abs(echoes.range_m - dist) <= RANGE_TOL_M)
    return bool(np.count_nonzero(answered) > ANSWER_SHARE * np.count_nonzero(aimed))


def _heard(point: PointFeature, echoes: EchoGeometry) -> tuple[FloatArray, FloatArray]:
    """The point's sensor positions and ranges."""
    return echoes.xy[point.readings], echoes.range_m[point.readings]


def _far_poses(point: PointFeature, echoes: EchoGeometry) -> int:
    """Distinct poses that heard the point from beyond :data:`EDGE_REACH_M`."""
    own = point.readings
    far = own[echoes.range_m[own] > EDGE_REACH_M]
    return _poses(echoes.xy[far]) if far.size else 0


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
    (:func:`answers_its_beams`; a chance crossing of arcs answers few of them).
    """
    if not walls or boxes.inside(f.xy):
        return False
    return bool(on_wall_lines(f.xy, walls)[0])


#: Curved surfaces are tested for diffuse echoes along chords about this long (m): the
#: range tolerance's worth of sagitta on a 0.3 m radius.
CHORD_M = 0.08


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


def _ends_at(fit: SurfaceFit, p: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """The plane's (end near ``p``, far end) when it ends at ``p``, else None.

    It ends at ``p`` when ``p`` lies on its line at or past its nearer end
    (:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`): a wall refitted through
    its echo points may stop well short of the corner it runs into.
    """
    if fit.model != "line" or fit.closed or fit.polyline.shape[0] < 2:
        return None
    a, b = fit.polyline[0], fit.polyline[-1]
    if math.dist(a, b) <= 0 or not bool(on_wall_lines(p, [(a, b)])[0]):
        return None
    return (a, b) if math.dist(a, p) <= math.dist(b, p) else (b, a)


def _side(a: FloatArray, b: FloatArray, q: FloatArray) -> npt.NDArray[np.float64]:
    """Signed side of points ``q`` (N, 2) of the line through ``a`` and ``b``."""
    u = b - a
    return np.asarray(u[0] * (q[..., 1] - a[1]) - u[1] * (q[..., 0] - a[0]), dtype=np.float64)


def _crossings(
    echoes: EchoGeometry, a: FloatArray, b: FloatArray, own: npt.NDArray[np.intp]
) -> int:
    """Readings (not ``own``) whose beam axis crosses the segment ``a b`` well before their echo.

    Well before: the range reaches beyond ``t / cos(half beam) + tolerance`` for a
    crossing at ``t`` along the axis, so a wall there would have answered first from
    anywhere in the beam (a reading grazing past a corner at the edge of its beam does not
    count).
    """
    h = np.column_stack((np.cos(echoes.heading), np.sin(echoes.heading)))
    v = b - a
    den = h[:, 0] * v[1] - h[:, 1] * v[0]
    ok = np.abs(den) > 1e-9
    d = a - echoes.xy
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (d[:, 0] * v[1] - d[:, 1] * v[0]) / den  # along the beam (m)
        u = (d[:, 0] * h[:, 1] - d[:, 1] * h[:, 0]) / den  # along the segment (0..1)
    reach = t / np.cos(np.minimum(echoes.half_beam, 1.5)) + RANGE_TOL_M
    hit = ok & (t > 0) & (reach < echoes.range_m) & (u >= 0) & (u <= 1)
    hit[own] = False
    return int(np.count_nonzero(hit))


def point_kind(point: PointFeature, echoes: EchoGeometry, surfaces: list[SurfaceFit]) -> str:
    """``corner`` (concave) or ``edge`` (convex) for a point reflector (module notes).

    Examples
    --------
    Two walls meeting at (0, 0), sensors inside the right angle: a corner; outside it, an
    edge.

    >>> a = SurfaceFit("line", np.array([[0.0, 0.0], [2.0, 0.0]]), 2.0, 0.0, 9, 9)
    >>> b = SurfaceFit("line", np.array([[0.0, 0.0], [0.0, 2.0]]), 2.0, 0.0, 9, 9)
    >>> inside = EchoGeometry(np.array([[1.0, 1.0], [1.5, 0.5]]), np.zeros(2), np.zeros(2),
    ...                       np.zeros(2))
    >>> f = PointFeature(np.zeros(2), np.arange(2), 2, 0.0, 1.0, 0.5)
    >>> point_kind(f, inside, [a, b])
    'corner'
    >>> outside = EchoGeometry(-inside.xy, np.zeros(2), np.zeros(2), np.zeros(2))
    >>> point_kind(f, outside, [a, b])
    'edge'
    """
    by_echo = echo_kind(point, echoes)
    if by_echo is not None:
        return by_echo
    p = point.xy
    sensors = echoes.xy[point.readings]
    ends = [e for e in (_ends_at(s, p) for s in surfaces) if e is not None]
    if len(ends) >= 2:
        # the two longest planes ending here
        ends.sort(key=lambda e: -math.dist(e[0], e[1]))
        (na, fa), (nb, fb) = ends[:2]
        side_a = float(np.median(np.sign(_side(na, fa, sensors))))
        side_b = float(np.median(np.sign(_side(nb, fb, sensors))))
        concave = side_a * float(_side(na, fa, fb)) > 0 and side_b * float(_side(nb, fb, fa)) > 0
        return "corner" if concave else "edge"
    if len(ends) == 1:
        near, far = ends[0]
        u = (near - far) / max(math.dist(near, far), 1e-12)
        past = (sensors - p) @ u > PAST_END_M
        if bool(past.any()):
            return "edge"
        # the other wall of a concave corner: perpendicular to this one, on the sensors' side
        w = np.array([-u[1], u[0]])
        if float(np.median((sensors - p) @ w)) < 0:
            w = -w
        a, b = p + OTHER_WALL_M[0] * w, p + OTHER_WALL_M[1] * w
        return "edge" if _crossings(echoes, a, b, point.readings) >= MIN_CROSSINGS else "corner"
    return "corner" if point.span_rad <= math.pi else "edge"


def echo_kind(point: PointFeature, echoes: EchoGeometry) -> str | None:
    """``corner`` or ``edge`` from the echoes alone, or None when they do not tell (notes).

    Examples
    --------
    Heard from 3 to 4 m by sensors inside a right angle: a corner. Heard from all round,
    close by: an edge.

    >>> xy = np.array([[3.0, 0.5], [3.5, 0.5], [2.5, 2.5], [0.5, 3.0], [0.5, 3.5]])
    >>> e = EchoGeometry(xy, np.zeros(5), np.full(5, 0.2), np.hypot(*xy.T))
    >>> echo_kind(PointFeature(np.zeros(2), np.arange(5), 5, 0.0, 1.0, 1.2), e)
    'corner'
    >>> f = PointFeature(np.zeros(2), np.arange(5), 5, 0.0, 1.0, 3.0)
    >>> echo_kind(f, e)
    'edge'
    """
    if point.span_rad > math.pi / 2 + CORNER_TOL_RAD:
        return "edge"
    if _far_poses(point, echoes) >= MIN_FAR_POSES:
        return "corner"
    if _passed_by(point, echoes) >= MIN_CROSSINGS:
        return "edge"
    return None


def _poses(xy: FloatArray) -> int:
    """Distinct sensor positions, one per :data:`RANGE_TOL_M` cell."""
    return int(np.unique(np.floor(xy / RANGE_TOL_M).astype(np.int64), axis=0).shape[0])


def _passed_by(point: PointFeature, echoes: EchoGeometry) -> int:
    """Readings from inside the point's sector, beyond the edge reach, that echoed past it.

    Inside the sector: the sensor's bearing from the point lies within the bearings of
    the point's own sensors (the complement of their largest gap); the point lies within
    :data:`AXIS_SHARE` of the half beam of the axis; the echo came from more than
    :data:`RANGE_TOL_M` beyond it.
    """
    p = point.xy
    rel = echoes.xy - p
    dist = np.hypot(rel[:, 0], rel[:, 1])
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    own = np.sort(bearing[point.readings])
    if own.size < 2:
        return 0
    gaps = np.diff(np.r_[own, own[0] + 2 * np.pi])
    k = int(np.argmax(gaps))
    start = own[(k + 1) % own.size]
    inside = np.mod(bearing - start, 2 * np.pi) <= point.span_rad
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(-rel[:, 1], -rel[:, 0]) - echoes.heading))))
    passed = inside & (dist > EDGE_REACH_M) & (off <= AXIS_SHARE * echoes.half_beam)
    passed &= echoes.range_m > dist + RANGE_TOL_M
    passed[point.readings] = False
    return int(np.count_nonzero(passed))

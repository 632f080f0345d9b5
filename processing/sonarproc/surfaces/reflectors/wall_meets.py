"""Corners where two fitted walls meet: a corner whose readings a head-on wall owns.

A concave corner retro-reflects, so a sensor whose perpendicular foot on one of its walls
lies a distance ``s`` from the corner hears the corner at ``sqrt(d^2 + s^2)`` and the wall
at ``d``: within ``s < sqrt(2 d tol)`` of the corner (about 0.4 m at 3 m for the ranges'
tolerance ``tol``) the two cannot be told apart, and on the wall's side of the corner the
wall's echo comes first. A corner at the end of a wall seen head on (a corridor's end
wall, a passage's back wall) is then heard only in readings the wall explains within
the tolerance: every finder of point reflectors
(:mod:`~sonarproc.surfaces.reflectors.rcd`,
:mod:`~sonarproc.surfaces.reflectors.line_corners`) rightly leaves them to the wall, and
the corner is missed.

When the corner's other wall was fitted too, the map places it without those readings:
two walls' lines meet at one point, and a room's walls meet square.
:func:`corners_where_walls_meet` reports a ``corner`` where the lines of two fitted
straight walls cross when:

* they cross square, within the retro-reflection tolerance
  :data:`~sonarproc.surfaces.reflectors.point_echoes.CORNER_TOL_RAD` (only a right-angled
  dihedral returns the sound along its path; walls meeting otherwise are not a corner
  that was heard, and a plane crossing a wall obliquely is
  :mod:`~sonarproc.surfaces.reflectors.corner_planes`' business);
* a wall heard from both sides (at least
  :data:`~sonarproc.surfaces.reflectors.line_corners.MIN_LINE_POSES` distinct poses on
  each, their feet spread over :data:`MIN_FACE_M` at least) is thin, and one fit may span
  both its faces (a door's wall, seen from the corridor and from the room, runs on past
  the corridor's corner as the room's wall): each face is a wall of its own, over the
  feet of its side's echoes, and the readings from behind a face (its other face's) are
  no readings of a corner on it;
* the crossing lies on each wall's line at its end: from
  :data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M` inside it (a wall seen head
  on is fitted up to ``sqrt(2 d tol)`` past its corner, above) to at most
  :data:`MAX_REACH_SHARE` times its length past it (see that constant);
* it is concave: each wall's far end lies on the side of the other wall that the other
  was seen from (its echoes' sensors), and every reading heard at the crossing came from
  there too (inside the corner's opening, from where both walls were seen). Two walls
  whose lines meet behind one of them are a convex edge, or a junction's mouth; a wall
  seen from its other side belongs to the next room;
* it was heard: at least :data:`~sonarproc.surfaces.reflectors.line_corners.MIN_LINE_POSES`
  distinct sensor positions hold readings that pass through it (range within the
  tolerance of the distance, inside the beam:
  :func:`~sonarproc.surfaces.reflectors.gathering.gather`), whoever explains them. A
  corner never in view is no corner of the map;
* nothing was seen through it: fewer than
  :data:`~sonarproc.surfaces.freespace.MIN_FREE_POSES` viewpoints saw free space on
  either wall's line round it or between either wall's end and it
  (:func:`~sonarproc.surfaces.freespace.free_feet`: an opening at the corner, such as a
  doorway beside an end wall, stays open), no stretch from an end to it crosses another
  fitted surface, and no stretch stood hidden behind something else
  (:func:`~sonarproc.surfaces.echoes.unseen.hidden_runs`: its corner is another wall's);
* no point reflector is reported within
  :data:`~sonarproc.surfaces.reflectors.gathering.CANDIDATE_SPACING_M` of it.

Its kind is ``corner`` by construction (two walls meeting concave); its readings are the
ones that pass through it, which stay the walls' too.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry, echo_points
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import MIN_FREE_POSES, FreeCones, free_feet
from sonarproc.surfaces.reflectors.complete import stretch_blocked
from sonarproc.surfaces.reflectors.gathering import CANDIDATE_SPACING_M, gather
from sonarproc.surfaces.reflectors.line_corners import MIN_LINE_POSES
from sonarproc.surfaces.reflectors.point_echoes import CORNER_TOL_RAD
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_TOL_M,
    distinct_poses,
    plane_rms,
    sensor_span,
)
from sonarproc.surfaces.reflectors.rcd import PointFeature
from sonarproc.surfaces.reflectors.walls import END_REACH_M, side_of_line

__all__ = ["MAX_REACH_SHARE", "MIN_FACE_M", "corners_where_walls_meet"]

FloatArray = npt.NDArray[np.float64]
Wall = tuple[FloatArray, FloatArray]

#: The crossing lies at most this many times a wall's length past its end. No reading
#: places the corner along the head-on wall: the other wall's line does, and with each of
#: its ends placed within the ranges' tolerance ``tol`` that line is placed within about
#: ``tol (1 + 2 D / L)`` at a distance ``D`` past its end (length ``L``). At ``D = L / 2``
#: that is ``2 tol``, the spacing at which two points are told apart
#: (:data:`~sonarproc.surfaces.reflectors.gathering.CANDIDATE_SPACING_M`); farther, the
#: corner's place is not known to a point's precision (a pillar's short face, extended,
#: crosses a wall anywhere).
MAX_REACH_SHARE = 0.5
#: Shortest face (m) a wall heard from both sides is split into: two range tolerances,
#: the spacing at which two points are told apart (a shorter spread of feet does not
#: tell where the face ends).
MIN_FACE_M = 2 * RANGE_TOL_M


def _crossing(w: Wall, v: Wall) -> FloatArray | None:
    """Where the lines of two walls cross, or None when they are within
    :data:`CORNER_TOL_RAD` of other than square."""
    (a, b), (c, d) = w, v
    u, t = b - a, d - c
    lu, lt = float(np.hypot(*u)), float(np.hypot(*t))
    if lu <= 0 or lt <= 0:
        return None
    den = float(u[0] * t[1] - u[1] * t[0])
    if abs(den) / (lu * lt) < math.cos(CORNER_TOL_RAD):
        return None
    s = float((c - a)[0] * t[1] - (c - a)[1] * t[0]) / den
    return np.asarray(a + s * u, dtype=np.float64)


def _end_to(w: Wall, x: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    """The wall's end nearer ``x`` and its far end, when ``x`` lies on its line at that end
    (from :data:`END_REACH_M` inside to :data:`MAX_REACH_SHARE` lengths past)."""
    a, b = w
    length = float(np.hypot(*(b - a)))
    along = float((x - a) @ (b - a)) / length
    inner = min(END_REACH_M, 0.5 * length)
    if -MAX_REACH_SHARE * length <= along <= inner:
        return a, b
    if length - inner <= along <= length * (1.0 + MAX_REACH_SHARE):
        return b, a
    return None


def _seen_through(
    x: FloatArray,
    ends: list[tuple[FloatArray, FloatArray]],
    cones: FreeCones,
    others: list[FloatArray],
) -> bool:
    """Whether free space was seen at ``x`` or between a wall's end and it, or a stretch
    from an end to it is blocked (module notes)."""
    for near, far in ends:
        u = (near - far) / max(float(np.hypot(*(near - far))), 1e-300)
        # round x on the wall's line, and from its end to x when x lies past that end
        start = near if float((x - near) @ u) > RANGE_TOL_M else x - RANGE_TOL_M * u
        _, read, _ = free_feet(start[None, :], (x + RANGE_TOL_M * u)[None, :], cones,
                               margin=RANGE_TOL_M)  # fmt: skip
        if np.unique(cones.viewpoint[read]).size >= MIN_FREE_POSES:
            return True
        if float((x - near) @ u) > RANGE_TOL_M and stretch_blocked(near, x, others, cones):
            return True
    return False


def _faces(
    k: int, fit: SurfaceFit, a: FloatArray, b: FloatArray, echoes: EchoGeometry
) -> list[tuple[int, FloatArray, FloatArray, FloatArray, bool]]:
    """The wall ``a b`` (fit ``k``) as ``(k, start, end, sensors, thin)`` faces.

    One face, the whole wall with every sensor that heard it, unless at least
    :data:`~sonarproc.surfaces.reflectors.line_corners.MIN_LINE_POSES` distinct poses heard
    it from each side: then it is a thin wall (a door's wall seen from the corridor and
    from the room), and each side's face runs over the feet of that side's echoes only
    (a corner on one face is no corner of the other; one fit may span both).
    """
    # only a reading ranging the line's distance can echo from it: asked first, cheaply
    length = float(np.hypot(*(b - a)))
    d = np.abs(side_of_line(a, b, echoes.xy)) / length
    sub = echoes.subset(np.abs(d - echoes.range_m) <= RANGE_TOL_M)
    got = echo_points([fit.polyline], [False], sub, tol=RANGE_TOL_M)[0]
    sensors = sub.xy[got.readings]
    sides = np.sign(side_of_line(a, b, sensors))
    u = (b - a) / length
    faces = []
    for side in (1.0, -1.0):
        mine = sides == side
        along = (got.points[mine] - a) @ u
        # too few poses, or feet too close together to tell the face's ends: one wall
        if distinct_poses(sensors[mine]) < MIN_LINE_POSES or float(np.ptp(along)) < MIN_FACE_M:
            return [(k, a, b, sensors, False)]
        lo, hi = float(along.min()), float(along.max())
        faces.append((k, a + lo * u, a + hi * u, sensors[mine], True))
    return faces


def corners_where_walls_meet(
    fits: list[SurfaceFit], echoes: EchoGeometry, points: list[PointFeature]
) -> list[PointFeature]:
    """Corners where the lines of two fitted walls meet square and concave (module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The fitted surfaces.
    echoes : EchoGeometry
        The readings they were fitted to.
    points : list of PointFeature
        The point reflectors reported already.

    Returns
    -------
    list of PointFeature
        The corners, each with the readings that pass through it.

    Examples
    --------
    An end wall x = 0 and a side wall y = 1.6, each heard head on from a sensor line along
    y = 0.8 (sensors looking west, then north), and five poses that range the corner
    (0, 1.6) itself: one corner there.

    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> from sonarproc.surfaces.planar.polylines import resample
    >>> end = SurfaceFit("line", resample([[0.0, 0.2], [0.0, 1.65]], 0.01), 1.45, 0.0, 9, 9)
    >>> side = SurfaceFit("line", resample([[0.6, 1.6], [3.0, 1.6]], 0.01), 2.4, 0.0, 9, 9)
    >>> x = np.linspace(0.3, 0.5, 5)
    >>> xy = np.vstack([np.column_stack((x, np.full(5, 0.8)))] * 2
    ...                + [np.column_stack((x + 1.0, np.full(5, 0.8)))])
    >>> head = np.concatenate((np.arctan2(0.8, -x), np.full(5, np.pi), np.full(5, np.pi / 2)))
    >>> rng = np.concatenate((np.hypot(x, 0.8), x, np.full(5, 0.8)))
    >>> echoes = EchoGeometry(xy, head, np.full(15, 0.26), rng)
    >>> [np.round(p.xy, 3).tolist() for p in corners_where_walls_meet([end, side], echoes, [])]
    [[0.0, 1.6]]
    """
    lines = [(k, np.asarray(f.polyline[0], dtype=np.float64), np.asarray(f.polyline[-1]))
             for k, f in enumerate(fits)
             if f.model == "line" and not f.closed and len(f.polyline) >= 2
             and float(np.hypot(*(f.polyline[-1] - f.polyline[0]))) > 0]  # fmt: skip
    if len(lines) < 2:
        return []
    # each wall's faces: its stretch heard from each side, when it was heard from both
    walls = [face for k, a, b in lines for face in _faces(k, fits[k], a, b, echoes)]
    found = [p.xy for p in points]
    cones: FreeCones | None = None
    everyone = np.ones(echoes.size, dtype=bool)
    out: list[PointFeature] = []

    def seen(sensors: FloatArray, n: FloatArray, f: FloatArray) -> float:
        """The side of line ``n -> f`` its echoes' ``sensors`` lie on (+1, -1; 0 none)."""
        return float(np.median(np.sign(side_of_line(n, f, sensors)))) if sensors.size else 0.0

    for i, (ki, ai, bi, si, thin_i) in enumerate(walls):
        for kj, aj, bj, sj, thin_j in walls[i + 1 :]:
            if ki == kj:
                continue
            x = _crossing((ai, bi), (aj, bj))
            if x is None or any(math.dist(x, q) < CANDIDATE_SPACING_M for q in found):
                continue
            ei, ej = _end_to((ai, bi), x), _end_to((aj, bj), x)
            if ei is None or ej is None:
                continue
            idx = gather(echoes, everyone, x, None)
            # a wall heard from both sides is thin: a reading from behind the face at hand
            # heard the other face, not a corner on this one
            for thin, sensors, (n, f) in ((thin_i, si, ei), (thin_j, sj, ej)):
                if thin and idx.size:
                    side = seen(sensors, n, f)
                    idx = idx[np.sign(side_of_line(n, f, echoes.xy[idx])) == side]
            xy = echoes.xy[idx]
            if idx.size == 0 or distinct_poses(xy) < MIN_LINE_POSES:
                continue
            # concave: each wall's far end on the side of the other that the wall was seen
            # from, and every sensor there too
            if not all(np.all(np.sign(side_of_line(n, f, np.vstack((xy, g)))) == seen(sk, n, f))
                       for sk, (n, f), (_, g) in ((si, ei, ej), (sj, ej, ei))):  # fmt: skip
                continue
            if cones is None:
                cones = FreeCones.of(echoes.xy, echoes.heading, echoes.half_beam, echoes.range_m)
            others = [f.polyline for k, f in enumerate(fits) if k not in (ki, kj)
                      and len(f.polyline) >= 2]  # fmt: skip
            if _seen_through(x, [ei, ej], cones, others):
                continue
            rng = echoes.range_m[idx]
            res = np.hypot(xy[:, 0] - x[0], xy[:, 1] - x[1]) - rng
            out.append(PointFeature(x, idx, distinct_poses(xy), float(np.sqrt(np.mean(res**2))),
                                    plane_rms(xy, rng), sensor_span(xy, x)))  # fmt: skip
            found.append(x)
    return out

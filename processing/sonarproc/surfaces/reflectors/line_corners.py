"""Corners placed by the walls' lines: a corner the ranges alone cannot tell from a plane.

A concave corner heard over a small spread of bearings (one sensor on a straight stretch
of track, through a doorway or from far along its bisector) gives ranges that a plane
explains about as well as a point, so
:func:`~sonarproc.surfaces.reflectors.rcd.point_feature` rightly does not accept it; when
no plane is fitted through them either
(:mod:`~sonarproc.surfaces.reflectors.corner_planes` handles those), its readings are
left unexplained and the corner is missed.

A corner is where its walls end, so its place is on a fitted wall's line, at or past its
end (:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`). On that line a point
has one unknown instead of two, and the question changes: not "does a point explain the
ranges better than a plane?" but "do the unexplained readings all meet at one place of
the line?". :func:`corners_on_wall_lines` looks along each fitted plane's line, from
:data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M` inside each end to
:data:`~sonarproc.surfaces.reflectors.walls.WALL_GAP_M` past it (the reach of a corner's
echo), every :data:`STEP_M`, for the place the most unexplained readings pass through
(range within :data:`~sonarproc.surfaces.reflectors.range_models.RANGE_TOL_M` of the
distance, inside the beam: :func:`~sonarproc.surfaces.reflectors.gathering.gather`). It
is a corner when:

* at least :data:`MIN_LINE_POSES` unexplained readings (no fitted surface's specular
  echo, no reported point's; a corner's readings near their beams' axes meet its walls'
  lines at their range, so a diffuse echo off a wall is not ruled out here) from as many
  distinct sensor positions pass through it, refitted along the line (one unknown, least
  squares on the ranges) and gathered again there: one fewer than a point fitted freely
  needs (:data:`~sonarproc.surfaces.reflectors.rcd.MIN_POSES`), since the line fixes one
  of its two unknowns (see :data:`MIN_LINE_POSES`);
* with less support than a free point needs (fewer than
  :data:`~sonarproc.surfaces.reflectors.rcd.MIN_READINGS` readings or
  :data:`~sonarproc.surfaces.reflectors.rcd.MIN_POSES` poses), :data:`MIN_LINE_POSES` of
  its poses heard it from beyond
  :data:`~sonarproc.surfaces.reflectors.point_echoes.EDGE_REACH_M`
  (:func:`~sonarproc.surfaces.reflectors.point_echoes.far_poses`): a convex edge on the
  line (a door jamb, a wall's free end) is heard close by, where a few readings cannot
  tell its weak diffracted echo from a corner's; beyond that reach only a corner's
  retro-reflection returns, so its support there is a corner's alone;
* the sensors lie on the side of the line that the wall was seen from, and span no
  more than a right angle and the retro-reflection tolerance round it (inside the
  corner's opening; a corner is heard from its inside only);
* the readings whose line of sight to it crosses a fitted plane short of it are left
  out, and the rest must still meet every test: such a reading heard something else at
  that range (the sound did not reach the corner), and one reading of that kind says
  nothing of the others (a wall's end, fitted a few centimetres past the jamb of a
  niche's mouth, crosses the sight line of a reading that grazed the jamb);
* it answered most beams that held it near their axis
  (:func:`~sonarproc.surfaces.reflectors.point_echoes.answers_its_beams`: a corner
  retro-reflects from anywhere inside its opening, while the beams aimed at a chance
  crossing of arcs range the surfaces behind or before it; a long log's many readings
  cross at some place of a line several times by chance);
* it is not a pillar's surface where planes fitted to the pillar leave it: one cylinder
  of a clear radius does not explain its readings together with those of the planes
  that may end there
  (:func:`~sonarproc.surfaces.reflectors.cylinders.pillar_pieces`);
* it lies inside no fitted plane, and not within
  :data:`~sonarproc.surfaces.reflectors.gathering.CANDIDATE_SPACING_M` of a point
  reported already;
* no plane explains the readings instead (:func:`_no_plane`): a plane is heard only near
  normal incidence, so only a plane that every one of the readings could have heard
  inside its effective beam is an alternative
  (:func:`~sonarproc.surfaces.reflectors.range_models.heard_plane`, the transducer
  model's beam); such a plane wins when it explains the ranges significantly better,
  or when it meets the wall's line square (within the retro-reflection tolerance
  :data:`~sonarproc.surfaces.reflectors.point_echoes.CORNER_TOL_RAD`: then it is likely
  the corner's other wall, seen head on), or when it runs along the line within that
  tolerance and on from the wall's nearer end (it passes the end within the range
  tolerance and its own RMS misfit: more of the wall itself, seen head on). A plane a
  few degrees off the wall's line that passes the wall's end far off is no more of that
  wall: the wall was fitted along its own line, and a continuation bent by the angle
  would leave a step at its end; it is the plane normal to the line of sight that
  explains any point's ranges heard over a narrow spread of bearings. An oblique plane
  crossing the wall's line just where the readings' arcs meet is what
  :mod:`~sonarproc.surfaces.reflectors.corner_planes` rejects. The point is judged,
  and placed, when it holds a free point's support, with the time walk of its weak
  echoes taken out
  (:func:`~sonarproc.surfaces.reflectors.time_walk.place_on_line_with_walk`: seen over
  a narrow span of bearings from far, the walk growing across the beam shifts it along
  the line by centimetres; from fewer readings the walk fitted beside the place takes up
  the range steps' noise instead). Such a corner, when the ranges place it within their
  1-inch resolution, is not beaten by a plane: heard from one straight stretch of track
  far off, a point's ranges step by whole inches as evenly as a plane's, and the plane's
  smaller residual is the rounding's.

Its kind is then decided like every other point's.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry, SurfaceEchoes, echo_points
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.cylinders import pillar_pieces
from sonarproc.surfaces.reflectors.gathering import (
    CANDIDATE_SPACING_M,
    ArcIndex,
    gather,
    gather_all,
)
from sonarproc.surfaces.reflectors.line_crossings import arc_crossings, crossing_counts, local_peaks
from sonarproc.surfaces.reflectors.point_echoes import (
    CORNER_TOL_RAD,
    BeamIndex,
    answers_its_beams,
    far_poses,
)
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_STEP_NOISE_M,
    RANGE_TOL_M,
    distinct_poses,
    heard_plane,
    place_on_line,
    plane_rms,
    point_beats_plane,
    sensor_span,
)
from sonarproc.surfaces.reflectors.rcd import MIN_POSES, MIN_READINGS, PointFeature
from sonarproc.surfaces.reflectors.time_walk import place_on_line_with_walk
from sonarproc.surfaces.reflectors.walls import (
    END_REACH_M,
    WALL_GAP_M,
    inside_walls,
    side_of_line,
)

__all__ = ["MIN_LINE_POSES", "STEP_M", "corners_on_wall_lines"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Fewest distinct sensor positions (and readings) of a corner on a wall's line. A point
#: fitted freely has two unknowns: the arcs of any two poses cross somewhere, and only
#: each further pose's arc tests that they meet there; ``MIN_POSES`` leaves three such
#: tests. On a known line a point has one unknown: any one arc crosses the line, and
#: every further pose's arc is a test, passed by chance when an arc of another surface
#: crosses the line within the range tolerance of the place (the same chance per arc as
#: for the free point), so one pose fewer leaves the same three tests; the line itself,
#: fitted to other readings, is independent evidence that a wall ends there. Readings
#: count no more than poses: those of one pose repeat one arc (no geometry), and a sparse
#: log hears a corner once per pose.
MIN_LINE_POSES = MIN_POSES - 1
#: Places along a wall's line are tried this often (m): half the range tolerance, so
#: every reading through a corner passes through a place tried.
STEP_M = 0.5 * RANGE_TOL_M
#: Gauss-Newton steps of the position along the line (one unknown; the gather is within
#: the range tolerance already, two steps settle it to a fraction of a millimetre).
LINE_FIT_STEPS = 3


def _occluded(
    sensors: FloatArray, x: FloatArray, walls: list[tuple[FloatArray, FloatArray]]
) -> npt.NDArray[np.bool_]:
    """Which sensors' sight lines to ``x`` cross a fitted plane short of it.

    Short of it: by more than :data:`RANGE_TOL_M` (the walls meeting at ``x`` end there).
    """
    if not walls:
        return np.zeros(sensors.shape[0], dtype=bool)
    d = x - sensors
    length = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    # every sight line against every wall at once (sensors down, walls across)
    ends = np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2)
    v = ends[:, 1] - ends[:, 0]
    den = d[:, 0, None] * v[:, 1] - d[:, 1, None] * v[:, 0]
    w0 = ends[:, 0, 0] - sensors[:, 0, None]
    w1 = ends[:, 0, 1] - sensors[:, 1, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w0 * v[:, 1] - w1 * v[:, 0]) / den
        s = (w0 * d[:, 1, None] - w1 * d[:, 0, None]) / den
    hit = (np.abs(den) > 1e-12) & (t > 0) & (t < 1.0 - RANGE_TOL_M / length) & (s >= 0) & (s <= 1)
    return np.asarray(hit.any(axis=1))


def _no_plane(
    echoes: EchoGeometry,
    idx: IntArray,
    x: FloatArray,
    u: FloatArray,
    end: FloatArray,
    point_res: FloatArray | None = None,
    *,
    resolved_ok: bool = False,
) -> bool:
    """Whether no plane explains the readings ``idx`` in place of a corner at ``x`` (module notes).

    Only a plane every reading could have heard inside its effective beam is an
    alternative (:func:`heard_plane`); none, and the corner stands. The best such plane is
    preferred when it explains the ranges significantly better than the point
    (:func:`point_beats_plane` the other way round), or when it meets the wall's line
    (direction ``u``) square (within :data:`CORNER_TOL_RAD`: it may be the corner's other
    wall seen head on), or runs along it within that tolerance and passes the wall's
    nearer ``end`` within :data:`RANGE_TOL_M` and its own RMS misfit (more of this wall,
    seen head on; module notes).

    Examples
    --------
    A wall along x = 0 fitted from y = 1.5 up, and a corner at (0, 0) that sensors along
    x = -4 heard over a few degrees of bearing: the plane normal to their line of sight,
    9 degrees off the wall's line, passes the wall's end 0.23 m off (a corner); had the
    wall been fitted down to y = 0.05, that plane would run on from it.

    >>> u = np.array([0.0, 1.0])
    >>> xy = np.c_[np.full(7, -4.0), np.linspace(0.5, 0.8, 7)]
    >>> toward = np.arctan2(-xy[:, 1], -xy[:, 0])
    >>> g = EchoGeometry(xy, toward, np.full(7, np.radians(15.0)), np.hypot(*xy.T))
    >>> _no_plane(g, np.arange(7), np.zeros(2), u, np.array([0.0, 1.5]))
    True
    >>> _no_plane(g, np.arange(7), np.zeros(2), u, np.array([0.0, 0.05]))
    False
    """
    xy, rng = echoes.xy[idx], echoes.range_m[idx]
    plane = heard_plane(xy, rng, echoes.heading[idx], echoes.half_beam[idx])
    if plane is None:
        return True
    n, plane_res = plane
    if point_res is None:
        point_res = np.hypot(xy[:, 0] - x[0], xy[:, 1] - x[1]) - rng
    resolved = resolved_ok and float(np.sqrt(np.mean(point_res**2))) <= RANGE_STEP_NOISE_M
    if not resolved and point_beats_plane(plane_res, point_res):
        return False
    cross = abs(float(n @ u))  # the sine of the angle between the plane and the line
    if cross <= math.sin(CORNER_TOL_RAD):
        # along the line: more of this wall only if it runs on from the wall's end, within
        # the ranges' tolerance and the plane's own misfit (it is placed no better)
        reach = float(np.mean(rng + xy @ n))  # the plane is n . p = reach
        misfit = float(np.sqrt(np.mean(plane_res**2)))
        return abs(float(n @ end) - reach) > RANGE_TOL_M + misfit
    return cross < math.cos(CORNER_TOL_RAD)


def corners_on_wall_lines(
    fits: list[SurfaceFit],
    echoes: EchoGeometry,
    points: list[PointFeature],
    *,
    got: list[SurfaceEchoes] | None = None,
) -> list[PointFeature]:
    """Corners on the fitted planes' lines that the unexplained readings meet at (module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The fitted surfaces.
    echoes : EchoGeometry
        The readings they were fitted to.
    points : list of PointFeature
        The point reflectors reported already (their readings are explained).
    got : list of SurfaceEchoes, optional
        ``echo_points`` of the ``fits`` at :data:`RANGE_TOL_M`, when the caller has it
        (every fit a polyline of two vertices or more).

    Returns
    -------
    list of PointFeature
        The corners found, most readings first; each reading belongs to at most one.

    Examples
    --------
    A wall along y = 0 from x = 1 to 4, seen from above, and a corner at its line's
    (0, 0) that one sensor driving along y = 3.8, looking back at 231 degrees, heard
    eight times:

    >>> xs = np.linspace(2.5, 3.2, 8)
    >>> s = np.r_[np.c_[xs, np.full(8, 3.8)], np.c_[xs, np.ones(8)]]
    >>> heading = np.radians(np.r_[np.full(8, -129.0), np.full(8, -90.0)])
    >>> g = EchoGeometry(s, heading, np.full(16, np.radians(15.0)),
    ...                  np.r_[np.hypot(xs, 3.8), np.ones(8)])
    >>> wall = SurfaceFit("line", np.c_[np.linspace(1, 4, 301), np.zeros(301)], 3.0, 0.0, 8, 8)
    >>> [np.round(p.xy, 3).tolist() for p in corners_on_wall_lines([wall], g, [])]
    [[0.0, 0.0]]
    """
    polys = [k for k, s in enumerate(fits) if s.polyline.shape[0] >= 2]
    if got is None or len(polys) < len(fits):
        got = echo_points([fits[k].polyline for k in polys], [fits[k].closed for k in polys],
                          echoes, tol=RANGE_TOL_M)  # fmt: skip
    explained = np.zeros(echoes.size, dtype=bool)
    for g in got:
        explained[g.readings] = True
    for p in points:
        explained[p.readings] = True
    free = ~explained
    lines = [(k, g) for k, g in zip(polys, got, strict=True)
             if fits[k].model == "line" and not fits[k].closed]  # fmt: skip
    if not lines or np.count_nonzero(free) < MIN_LINE_POSES:
        return []
    walls = [(fits[k].polyline[0], fits[k].polyline[-1]) for k, _ in lines]
    # the side each wall was seen from: the median side of its own readings
    seen_side = [float(np.median(np.sign(side_of_line(a, b, echoes.xy[g.readings]))))
                 if g.readings.size else 0.0
                 for (a, b), (_, g) in zip(walls, lines, strict=True)]  # fmt: skip
    planes = [(a, b, g.readings, g.points) for (a, b), (_, g) in zip(walls, lines, strict=True)]
    index = ArcIndex(echoes, free)
    pool = echoes.subset(free)  # the free readings, gathered once for every line
    places, owner, along = [], [], []
    for k, (a, b) in enumerate(walls):
        length = float(np.hypot(*(b - a)))
        if length <= 0 or seen_side[k] == 0.0:
            continue
        u = (b - a) / length
        inner = min(END_REACH_M, 0.5 * length)
        crossings = arc_crossings(pool, a, u)
        for t in (
            np.arange(-WALL_GAP_M, inner, STEP_M),
            np.arange(length - inner, length + WALL_GAP_M, STEP_M),
        ):
            # where the most arcs cross the line: a place within the candidate spacing of
            # one with more is that one's (its arcs spread over the range tolerance round it)
            counts = crossing_counts(crossings, t)
            t = t[local_peaks(t, counts) & (counts >= MIN_LINE_POSES)]
            if t.size:
                places.append(a + t[:, None] * u)
                owner.append(np.full(t.size, k))
                along.append(t)
    if not places:
        return []
    starts, which = np.concatenate(places), np.concatenate(owner)
    gathers = gather_all(echoes, free, starts, index)
    sizes = np.fromiter(map(len, gathers), dtype=np.intp, count=len(gathers))
    # the places where the most readings meet along each line: a place within the
    # candidate spacing of one with more is that one's (its arcs spread over the range
    # tolerance round it)
    cuts = np.cumsum([t.size for t in along])[:-1]
    peak = np.concatenate(
        [local_peaks(t, n) for t, n in zip(along, np.split(sizes, cuts), strict=True)]
    )
    found: list[PointFeature] = []
    taken = [p.xy for p in points]
    tried: dict[int, list[FloatArray]] = {k: [] for k in range(len(walls))}
    beams: BeamIndex | None = None  # made once, when the first place gets that far
    for c in np.argsort(-sizes, kind="stable"):
        if sizes[c] < MIN_LINE_POSES:
            break
        k = int(which[c])
        # a place whose readings settled, on this line, where others' had and failed
        if not peak[c] or any(
            float(np.hypot(*(starts[c] - q))) < CANDIDATE_SPACING_M for q in tried[k]
        ):
            continue
        a, b = walls[k]
        u = (b - a) / float(np.hypot(*(b - a)))
        idx = gathers[c][free[gathers[c]]]
        if idx.size < MIN_LINE_POSES:
            continue
        at = place_on_line(
            echoes.xy[idx],
            echoes.range_m[idx],
            a,
            u,
            float((starts[c] - a) @ u),
            steps=LINE_FIT_STEPS,
        )
        x = a + at * u
        tried[k].append(x)
        idx = gather(echoes, free, x, index)
        xy, rng = echoes.xy[idx], echoes.range_m[idx]
        if idx.size < MIN_LINE_POSES:
            continue
        poses = distinct_poses(xy)
        if poses < MIN_LINE_POSES:
            continue
        if any(float(np.hypot(*(x - q))) < CANDIDATE_SPACING_M for q in taken):
            continue
        if not bool(np.all(np.sign(side_of_line(a, b, xy)) == seen_side[k])):
            continue
        if bool(inside_walls(x, walls)[0]):
            continue
        # a reading whose sight line to the corner a fitted plane crosses heard something
        # else there: it is left out, and the corner stands or falls on the rest
        mine = ~_occluded(xy, x, walls)
        if not bool(mine.all()):
            idx = idx[mine]
            xy, rng = echoes.xy[idx], echoes.range_m[idx]
            poses = distinct_poses(xy)
            if poses < MIN_LINE_POSES:
                continue
        # a corner is heard from inside its opening only: a right angle, and the tolerance
        span = sensor_span(xy, x)
        if span > 0.5 * math.pi + CORNER_TOL_RAD:
            continue
        # its misfits are filled in once it passes every test (no test reads them)
        f = PointFeature(x, idx, poses, math.nan, math.nan, span)
        # less support than a free point needs: a corner's echo alone, heard from far
        weak = idx.size < MIN_READINGS or poses < MIN_POSES
        if weak and far_poses(f, echoes) < MIN_LINE_POSES:
            continue
        # the retro-reflection test first: it turns down the chance crossings of a long log
        beams = BeamIndex(echoes) if beams is None else beams
        end = a if float(np.hypot(*(x - a))) <= float(np.hypot(*(x - b))) else b
        if not answers_its_beams(f, echoes, beams):
            continue
        # with a free point's support, the place with the time walk of its weak echoes
        # taken out: seen over a narrow span of bearings, the walk growing across the beam
        # shifts it along the line (with fewer readings the walk fitted beside the place
        # takes up the noise of the range steps instead, and moves the place as much)
        walked = None
        if not weak:
            at, walked = place_on_line_with_walk(
                xy, rng, echoes.heading[idx], echoes.half_beam[idx], a, u, float((x - a) @ u)
            )
            x = a + at * u
        if not _no_plane(echoes, idx, x, u, end, walked, resolved_ok=not weak):
            continue
        # where planes fitted to a pillar leave its surface: one cylinder explains them all
        # (last: a circle fit, asked of the few places that passed every other test)
        if pillar_pieces(echoes, idx, x, planes):
            continue
        res = np.hypot(xy[:, 0] - x[0], xy[:, 1] - x[1]) - rng
        f = PointFeature(x, idx, poses, float(np.sqrt(np.mean(res**2))), plane_rms(xy, rng), span)
        found.append(f)
        taken.append(x)
        free[idx] = False
    return found

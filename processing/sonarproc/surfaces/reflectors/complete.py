"""Walls completed to the corners they run into, and ended at the points they run past.

A wall refitted through its echo points stops where the last perpendicular from a sensor
met it (:mod:`sonarproc.surfaces.reflectors.walls`): a robot driving round a room keeps
clear of its walls, so it never stands square to the last metre or so before each
corner, and each wall is found that much short of it. A concave corner is where two walls
meet, and it retro-reflects from anywhere inside its opening, so the map does know where
those walls end: at the ``corner`` their lines run into.

:func:`complete_to_corners` therefore stretches a straight surface's end to a reported
``corner`` that lies on its line beyond that end
(:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`: within the ranges' tolerance
of the line, up to :data:`~sonarproc.surfaces.reflectors.walls.WALL_GAP_M` past the end),
the nearest such corner at each end. A corner farther past the end than
:data:`MAX_REACH_PER_LENGTH` times the wall's length must lie on a second wall's line too
(a corner is where two walls meet; a short wall's line, extended far, passes points that
are not its corner, such as a pillar's echo). The stretch is not made where readings from
:data:`~sonarproc.surfaces.freespace.MIN_FREE_POSES` distinct viewpoints saw through it
(:func:`~sonarproc.surfaces.freespace.free_feet`: an opening between the wall's end and
the corner stays open), nor where it would cross another fitted surface (the corner is
another room's) or run along one (another piece of the same line, found nearer the
corner, reaches it: the stretch would put two surfaces on one stretch of wall), nor past
an ``edge`` reported on the stretch (a convex edge is a wall's free end, a jamb or the
mouth of a junction: the wall does not run on through it, and the stretch would close
the opening the edge stands at), nor
through a stretch that stood hidden behind something else
(:func:`~sonarproc.surfaces.echoes.unseen.hidden_runs`, from either side: the readings
facing it squarely came back short of it, so its corner is another wall's on the same
line, such as the back corner of the next door recess behind a corridor wall).

:func:`trim_to_points` does the converse: a straight surface fitted past a point
reflector that lies on its line, within :data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M`
of its end, ends at that point. A corner or an edge is where a wall ends, and the stretch
beyond it is the point's own echoes: a sensor nearly square to the wall at the vertex
reads the vertex's range within the ranges' tolerance ``tol`` from feet up to
``sqrt(2 r tol)`` past it (about 0.28 m at 1.3 m), and the point's arcs, all through the
vertex, make a ridge along the wall's line on both sides of it. Left on, that stretch
takes the point's readings as the wall's echoes (the point then fails its tests) and
bridges a doorway past its jamb.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.occlusion import segment_crossings
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.echoes.unseen import hidden_runs
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import MIN_FREE_POSES, FreeCones, free_feet
from sonarproc.surfaces.planar.polylines import resample
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M
from sonarproc.surfaces.reflectors.walls import END_REACH_M, LINE_REACH_M, on_wall_lines

__all__ = ["complete_to_corners", "stretch_blocked", "trim_to_points"]

FloatArray = npt.NDArray[np.float64]

#: A stretch shorter than this (m) is not worth making (a polyline step).
MIN_STRETCH_M = 0.01
#: Segments of the other surfaces overlap their neighbours by this (m).
_OVERLAP_M = 1e-3
#: The stretch's last part (m) next to the wall's end and to the corner is not tested for
#: crossings: other walls meet it there.
CROSS_END_M = 0.10
#: A wall reaches a corner on its own line only (no other wall's line runs into it) at
#: most this many times its own length past its end. Its line is known from its echoes
#: only: with each end placed within the ranges' tolerance ``tol``, the line at a distance
#: ``D`` past an end is placed within about ``tol (1 + 2 D / L)`` for a wall of length
#: ``L``, three times the tolerance the corner is tested with at ``D = L``. Farther out a
#: point found on that line alone is no evidence that the wall runs there (a short plane
#: fitted on a pillar's echoes points anywhere); a second wall's line through it is.
MAX_REACH_PER_LENGTH = 1.0


def _crosses(p: FloatArray, q: FloatArray, others: list[FloatArray]) -> bool:
    """Whether the segment ``p q`` (less its last :data:`CROSS_END_M` at both ends)
    properly crosses one of the polylines."""
    length = float(np.hypot(*(q - p)))
    if length <= 2 * CROSS_END_M or not others:
        return False
    u = (q - p) / length
    a, b = (p + CROSS_END_M * u)[None, :], (q - CROSS_END_M * u)[None, :]
    s0 = np.concatenate([o[:-1] for o in others if len(o) >= 2] or [np.zeros((0, 2))])
    s1 = np.concatenate([o[1:] for o in others if len(o) >= 2] or [np.zeros((0, 2))])
    if s0.shape[0] == 0:
        return False
    # each segment overlaps its neighbours by a hair: a crossing through a shared vertex
    # is no proper crossing of either
    d = (s1 - s0) / np.maximum(np.hypot(*(s1 - s0).T), 1e-300)[:, None]
    rows, _, _ = segment_crossings(a, b, s0 - _OVERLAP_M * d, s1 + _OVERLAP_M * d)
    return bool(rows.size)


def _runs_along(p: FloatArray, q: FloatArray, others: list[FloatArray]) -> bool:
    """Whether the segment ``p q`` (less its last :data:`CROSS_END_M` at both ends) runs
    along another polyline: a vertex of one lies on it, within the ranges' tolerance."""
    length = float(np.hypot(*(q - p)))
    if length <= 2 * CROSS_END_M or not others:
        return False
    u = (q - p) / length
    pts = np.concatenate(others)
    d = pts - p
    along = d @ u
    across = np.abs(d[:, 0] * u[1] - d[:, 1] * u[0])
    inside = (along > CROSS_END_M) & (along < length - CROSS_END_M)
    return bool(np.any(inside & (across <= LINE_REACH_M)))


def _hidden(p: FloatArray, q: FloatArray, cones: FreeCones) -> bool:
    """Whether the stretch ``p q`` holds a hidden run, seen from either side of it."""
    length = float(np.hypot(*(q - p)))
    t = (q - p) / max(length, 1e-300)
    normal = np.array([-t[1], t[0]])
    return any(hidden_runs(0.0, length, p, t, side * normal, cones, RANGE_TOL_M)
               for side in (1.0, -1.0))  # fmt: skip


def stretch_blocked(
    p: FloatArray, q: FloatArray, others: list[FloatArray], cones: FreeCones
) -> bool:
    """Whether a wall may not run from ``p`` to ``q``: the stretch crosses another polyline
    or runs along one, or holds a hidden run (module notes; free space is tested apart).

    Examples
    --------
    >>> none = FreeCones.of(np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0))
    >>> p, q = np.array([0.0, 0.0]), np.array([2.0, 0.0])
    >>> stretch_blocked(p, q, [np.array([[1.0, -1.0], [1.0, 1.0]])], none)
    True
    >>> stretch_blocked(p, q, [np.array([[1.0, 0.5], [1.0, 1.0]])], none)
    False
    """
    return _crosses(p, q, others) or _runs_along(p, q, others) or _hidden(p, q, cones)


def complete_to_corners(fits: list[SurfaceFit], echoes: EchoGeometry) -> list[SurfaceFit]:
    """The fits with each straight surface stretched to its corners (module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The surfaces, point reflectors included (model ``corner`` or ``edge``).
    echoes : EchoGeometry
        The readings (their free space guards the stretches).

    Returns
    -------
    list of SurfaceFit
        The same surfaces in the same order; stretched ones replaced.

    Examples
    --------
    A wall y = 0 found from x = 1 to 4 and a corner reported at (0, 0):

    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> wall = SurfaceFit("line", resample([[1.0, 0.0], [4.0, 0.0]], 0.01), 3.0, 0.0, 50,
    ...                   50, False, {"point": [2.5, 0.0], "direction": [1.0, 0.0]})
    >>> corner = SurfaceFit("corner", np.array([[0.0, 0.01]]), 0.0, 0.0, 9, 9, False, {})
    >>> none = EchoGeometry(np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0))
    >>> out = complete_to_corners([wall, corner], none)
    >>> out[0].polyline[[0, -1]].tolist(), round(out[0].length_m, 2)
    ([[0.0, 0.0], [4.0, 0.0]], 4.0)
    """
    corners = np.array([f.polyline[0] for f in fits if f.model == "corner"]).reshape(-1, 2)
    if corners.shape[0] == 0:
        return list(fits)
    edges = np.array([f.polyline[0] for f in fits if f.model == "edge"]).reshape(-1, 2)
    cones = FreeCones.of(echoes.xy, echoes.heading, echoes.half_beam, echoes.range_m)
    out = list(fits)
    # each straight surface's ends (a zero-length stand-in for the others keeps the indices)
    walls = [(np.asarray(g.polyline[0], dtype=np.float64), np.asarray(g.polyline[-1]))
             if g.model == "line" and not g.closed and len(g.polyline) >= 2
             else (np.zeros(2), np.zeros(2)) for g in fits]  # fmt: skip
    for i, f in enumerate(fits):
        if f.model != "line" or f.closed or len(f.polyline) < 2:
            continue
        a, b = np.asarray(f.polyline[0], dtype=np.float64), np.asarray(f.polyline[-1])
        length = float(np.hypot(*(b - a)))
        if length <= 0:
            continue
        t = (b - a) / length
        on = corners[on_wall_lines(corners, [(a, b)])]
        along = (on - a) @ t
        others = [g.polyline for j, g in enumerate(fits) if j != i and len(g.polyline) >= 2]
        lo, hi = 0.0, length
        for end_before, s in ((True, along[along < 0.0]), (False, along[along > length])):
            if s.size == 0:
                continue
            target = float(s.max() if end_before else s.min())
            # far past a short wall: the corner needs a second wall's line through it
            far = (-target if end_before else target - length) > MAX_REACH_PER_LENGTH * length
            if far and not bool(on_wall_lines(a + t * target, walls[:i] + walls[i + 1 :])[0]):
                continue
            p = a + t * (target if end_before else length)
            q = a + t * (0.0 if end_before else target)
            if float(np.hypot(*(q - p))) < MIN_STRETCH_M or _crosses(p, q, others):
                continue
            if _runs_along(p, q, others) or _runs_along(p, q, [edges]):
                continue
            _, read, _ = free_feet(p[None, :], q[None, :], cones, margin=RANGE_TOL_M)
            if np.unique(cones.viewpoint[read]).size >= MIN_FREE_POSES or _hidden(p, q, cones):
                continue
            lo, hi = (target, hi) if end_before else (lo, target)
        if lo == 0.0 and hi == length:
            continue
        step = length / (len(f.polyline) - 1)  # the polyline keeps its step
        poly = resample(np.stack((a + t * lo, a + t * hi)), step)
        out[i] = replace(f, polyline=poly, length_m=float(hi - lo))
    return out


def trim_to_points(fits: list[SurfaceFit], points: npt.ArrayLike) -> list[SurfaceFit]:
    """The fits with each straight surface ended at the point reflectors it runs past.

    A point within :data:`~sonarproc.surfaces.reflectors.walls.LINE_REACH_M` of a line's
    segment and within :data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M` of one of
    its ends (inside it) becomes that end (module notes); a line shorter than twice that
    reach keeps its length (its ends are all near the point).

    Parameters
    ----------
    fits : list of SurfaceFit
        The surfaces.
    points : array_like, shape (P, 2)
        The point reflectors' positions (m).

    Returns
    -------
    list of SurfaceFit
        The same surfaces in the same order; trimmed ones replaced.

    Examples
    --------
    A wall y = 0 fitted from x = 0 to 3.1 past an edge at (3, 0):

    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> wall = SurfaceFit("line", resample([[0.0, 0.0], [3.1, 0.0]], 0.01), 3.1, 0.0, 50,
    ...                   50, False, {"point": [1.5, 0.0], "direction": [1.0, 0.0]})
    >>> out = trim_to_points([wall], [[3.0, 0.01]])
    >>> out[0].polyline[[0, -1]].round(6).tolist(), round(out[0].length_m, 2)
    ([[0.0, 0.0], [3.0, 0.0]], 3.0)
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if pts.shape[0] == 0:
        return list(fits)
    out = list(fits)
    for i, f in enumerate(fits):
        if f.model != "line" or f.closed or len(f.polyline) < 2:
            continue
        a, b = np.asarray(f.polyline[0], dtype=np.float64), np.asarray(f.polyline[-1])
        length = float(np.hypot(*(b - a)))
        if length <= 2 * END_REACH_M:
            continue
        t = (b - a) / length
        d = pts - a
        along = d @ t
        across = np.abs(d[:, 0] * t[1] - d[:, 1] * t[0])
        on = across <= LINE_REACH_M
        near_a = along[on & (along > 0.0) & (along <= END_REACH_M)]
        near_b = along[on & (along < length) & (along >= length - END_REACH_M)]
        lo = float(near_a.max()) if near_a.size else 0.0
        hi = float(near_b.min()) if near_b.size else length
        if lo < MIN_STRETCH_M and length - hi < MIN_STRETCH_M:
            continue
        step = length / (len(f.polyline) - 1)  # the polyline keeps its step
        poly = resample(np.stack((a + t * lo, a + t * hi)), step)
        out[i] = replace(f, polyline=poly, length_m=float(hi - lo))
    return out

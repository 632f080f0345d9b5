"""A wall heard only head on, from a pass along its normal: its direction is the pass's.

A plane answers a sensor from the foot of the perpendicular. A robot that drives straight
at a wall (or away from it, a rear sensor listening) keeps that foot at one spot: every
reading's echo point lands there, at ranges that change with the robot's distance. The
echo points then span less than a direction needs (the refinement's ``MIN_SPREAD_M``), and
a line fitted through them turns by whatever the range noise and the sensors' few
centimetres across the pass make of it (a 1 inch range step across 7 cm of points is 20
degrees), so that no reading's foot lies on it any more and it goes for want of echoes.

The readings fix the wall all the same: the sensors lie on one line through the spot, at
depths along it that differ by much more than the range tolerance, and a plane answers
every one of them from that spot only if its normal is that line
(:func:`heard_head_on`). :func:`approach_line` is that wall: the line through the echo
points' centre, square to the mean direction from it to the sensors. It spans the echo
points only; the refinement then stretches it over its ridge as any other line
(by at most its ``MAX_STRETCH_M`` at each end), and such a piece, having no direction of
its own, is joined to no other as collinear with it.

The map's ridge of such a wall is the crest of the pass's range arcs, all tangent at the
foot: it bends towards the sensors with their curvature, and is often fitted as an arc
centred among them, whose every point lies nearer the sensors beyond its centre than its
middle does, so that no reading's foot falls inside it and it would go for want of
echoes. :func:`apex_tangent` is the line tangent to it at its middle, where the arcs
touch; it is kept in the arc's place only when its echoes come from such a pass
(:func:`driven_at`: sensors of one heading carried along their axis).

Kleeman & Kuc (1995) and Leonard & Durrant-Whyte (1991) describe such head-on returns
(the strongest a plane gives); a point reflector straight ahead answers the same ranges,
and :mod:`sonarproc.surfaces.reflectors` claims the readings of the corners and edges it
finds before the walls are refitted.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.lines import line_params
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample

__all__ = [
    "HEADING_STEP_RAD",
    "HEAD_ON_DEPTH_M",
    "Pieces",
    "apex_tangent",
    "approach_line",
    "driven_at",
    "heard_head_on",
    "join_directed",
    "spread_m",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Echoes at one spot make a wall when their ranges span at least this (m): sensors within
#: the ``MIN_SPREAD_M`` (0.1 m) of the spot across the pass and this far apart along it
#: fix the pass's direction, the wall's normal, within atan(0.1 / 0.5) = 11 degrees, less
#: than a sonar's half beam (the most a heard plane's normal can be off its axis); and
#: it is 20 of the coarsest range steps (1 inch), so that the ranges surely changed.
HEAD_ON_DEPTH_M = 0.5


def spread_m(points: SurfaceCells) -> float:
    """How far apart (m) the outermost of the echo points ``points`` lie.

    >>> spread_m(SurfaceCells(np.array([0.0, 0.3]), np.array([0.0, 0.4]), np.zeros(2),
    ...                       np.ones(2), False))
    0.5
    """
    if points.size == 0:
        return 0.0
    return float(np.hypot(np.ptp(points.x), np.ptp(points.y)))


def heard_head_on(readings: IntArray, range_m: FloatArray) -> bool:
    """Whether the readings ``readings`` (their ranges ``range_m[readings]``) came from
    depths along one pass at least :data:`HEAD_ON_DEPTH_M` apart (module notes).

    >>> heard_head_on(np.arange(3), np.array([1.0, 1.3, 1.6])), heard_head_on(
    ...     np.arange(2), np.array([1.0, 1.3, 1.6]))
    (True, False)
    """
    r = np.asarray(range_m, dtype=np.float64)[np.asarray(readings, dtype=np.intp)]
    return r.size > 0 and float(np.ptp(r)) >= HEAD_ON_DEPTH_M


#: Readings whose headings round to one step this wide (rad) point one way: one sensor of
#: a ring (its neighbours point a ring's spacing, 20 degrees and more, away), while the
#: robot drives straight; over the metre of a pass, 1 degree moves the axis 2 cm across.
HEADING_STEP_RAD = math.radians(1.0)


def driven_at(xy: FloatArray, heading: FloatArray, *, across: float) -> bool:
    """Whether some sensors ``xy`` pointing one way (``heading``, to
    :data:`HEADING_STEP_RAD`) lie within ``across`` (m) of one line along their axis and
    at least :data:`HEAD_ON_DEPTH_M` apart along it: a pass along the heard wall's normal.

    Sensors carried sideways past a spot (their depth changing only as the spot's bearing
    does) are no such pass: a corner heard from a corridor passing its room's doorway
    gives ranges as far apart, from sensors spread across their axes.

    >>> xy = np.column_stack((np.linspace(0.0, 1.0, 11), np.zeros(11)))
    >>> driven_at(xy, np.zeros(11), across=0.1), driven_at(xy, np.full(11, np.pi / 2),
    ...                                                     across=0.1)
    (True, False)
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    h = np.asarray(heading, dtype=np.float64)
    steps = np.round(h / HEADING_STEP_RAD).astype(np.int64) % round(2 * math.pi / HEADING_STEP_RAD)
    for b in np.unique(steps):
        sel = steps == b
        if np.count_nonzero(sel) < 2:
            continue
        mid = float(b) * HEADING_STEP_RAD
        along = xy[sel] @ np.array([math.cos(mid), math.sin(mid)])
        side = xy[sel] @ np.array([-math.sin(mid), math.cos(mid)])
        order = np.argsort(side, kind="stable")
        side, along = side[order], along[order]
        ends = np.searchsorted(side, side + across, side="right")
        for i, j in enumerate(ends):
            if j - i >= 2 and float(np.ptp(along[i:j])) >= HEAD_ON_DEPTH_M:
                return True
    return False


def approach_line(points: SurfaceCells, sensors: FloatArray, *, cell: float) -> SurfaceFit:
    """The wall through head-on echo points ``points`` heard from ``sensors`` (module notes).

    Parameters
    ----------
    points : SurfaceCells
        The echo points (m), at one spot.
    sensors : ndarray, shape (E, 2)
        The positions (m) of the sensors that heard them.
    cell : float
        The polyline's step (m).

    Returns
    -------
    SurfaceFit
        A ``line`` square to the mean direction from the points' centre to the sensors,
        spanning the points (at least one step).

    Examples
    --------
    Echo points round (0, 2), scattered by range noise, heard from sensors driving
    along x = 0:

    >>> pts = SurfaceCells(np.array([-0.01, 0.02, 0.0]), np.array([2.01, 1.98, 2.0]),
    ...                    np.zeros(3), np.ones(3), False)
    >>> f = approach_line(pts, np.array([[0.0, 0.0], [0.01, 0.6], [0.0, 1.2]]), cell=0.01)
    >>> [round(abs(v), 3) for v in f.params["direction"]], round(float(f.polyline[0, 1]), 3)
    ([1.0, 0.0], 1.997)
    """
    xy = np.stack((points.x, points.y), axis=1)
    c = xy.mean(axis=0)
    v = np.asarray(sensors, dtype=np.float64).reshape(-1, 2) - c
    v /= np.maximum(np.hypot(v[:, 0], v[:, 1]), 1e-12)[:, None]
    n = v.mean(axis=0)
    n /= max(float(np.hypot(*n)), 1e-12)
    t = np.array([-n[1], n[0]])
    if t[0] < 0 or (t[0] == 0 and t[1] < 0):  # one direction for one wall, whatever the side
        t = -t
    u = (xy - c) @ t
    lo, hi = float(u.min()), float(u.max())
    if hi - lo < cell:
        lo, hi = -0.5 * cell, 0.5 * cell
    poly = resample(np.stack((c + lo * t, c + hi * t)), cell)
    rms = float(np.sqrt(np.mean(((xy - c) @ n) ** 2)))
    length = float(np.hypot(*(poly[-1] - poly[0])))
    return SurfaceFit("line", poly, length, rms, points.size, points.size, False,
                      line_params(c, t), {"line": rms})  # fmt: skip


def apex_tangent(fit: SurfaceFit, *, cell: float) -> SurfaceFit:
    """The line tangent to the open arc ``fit`` at its middle, as long as its chord.

    Arcs of readings tangent at one spot (a wall heard head on, from depths along one
    pass) make a ridge that bends towards the sensors with the arcs' own curvature: it is
    fitted as an arc centred near the sensors, whose ends lie nearer them than its
    middle, so that no reading's foot (the nearest point) falls inside it and it has no
    echoes. The wall stands at the arc's middle, where the arcs touch, square to the
    pass: the tangent there. Off the pass's direction by an angle phi (the ridge's
    ends heard unequally far to the sides), a sensor at distance ``d`` from the centre
    ranges the tangent ``d (1 - cos phi)`` off the wall's range, a millimetre for 5
    degrees at a metre, well inside the first round's tolerance, and the head-on test
    (module notes) then refits it square to the pass.

    Examples
    --------
    A quarter arc of radius 2 about the origin, from -45 to 45 degrees:

    >>> a = np.radians(np.linspace(-45.0, 45.0, 91))
    >>> arc = SurfaceFit("arc", 2 * np.column_stack((np.cos(a), np.sin(a))), 3.14, 0.0, 91,
    ...                  91, False, {"centre": [0.0, 0.0], "radius": 2.0,
    ...                  "start_rad": -np.pi / 4, "sweep_rad": np.pi / 2})
    >>> f = apex_tangent(arc, cell=0.01)
    >>> f.model, [round(abs(v), 3) for v in f.params["direction"]], round(f.length_m, 2)
    ('line', [0.0, 1.0], 2.83)
    >>> round(float(f.polyline[0, 0]), 3), round(float(f.polyline[-1, 0]), 3)
    (2.0, 2.0)
    """
    c = np.asarray(fit.params["centre"], dtype=np.float64)
    mid = float(fit.params["start_rad"]) + 0.5 * float(fit.params["sweep_rad"])
    p = c + float(fit.params["radius"]) * np.array([math.cos(mid), math.sin(mid)])
    t = np.array([-math.sin(mid), math.cos(mid)])
    half = 0.5 * max(float(np.hypot(*(fit.polyline[-1] - fit.polyline[0]))), cell)
    poly = resample(np.stack((p - half * t, p + half * t)), cell)
    length = float(np.hypot(*(poly[-1] - poly[0])))
    return SurfaceFit("line", poly, length, fit.rms_m, fit.support, fit.arcs, False,
                      line_params(p, t), dict(fit.candidates))  # fmt: skip


#: Surfaces, their echo points and their readings' indices, in one order.
Pieces = tuple[list[SurfaceFit], list[SurfaceCells], list[IntArray]]


def join_directed(
    join: Callable[[list[SurfaceFit], list[SurfaceCells], list[IntArray]], Pieces],
    fits: list[SurfaceFit],
    points: list[SurfaceCells],
    readings: list[IntArray],
    *,
    min_spread: float,
) -> Pieces:
    """``join(fits, points, readings)`` of the pieces whose echo points span at least
    ``min_spread`` (m); the others, heard head on only (module notes), have no direction
    of their own to be collinear by and follow unjoined."""
    lone = {i for i, c in enumerate(points) if spread_m(c) < min_spread}
    rest = [i for i in range(len(fits)) if i not in lone]
    out_f, out_p, out_r = join([fits[i] for i in rest], [points[i] for i in rest],
                               [readings[i] for i in rest])  # fmt: skip
    for i in sorted(lone):
        out_f.append(fits[i])
        out_p.append(points[i])
        out_r.append(readings[i])
    return out_f, out_p, out_r

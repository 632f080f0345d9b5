"""A point placed on a fitted wall's line: the one test of a surface fitted through its arcs.

A point reflector heard over a narrow spread of bearings gives ranges that a plane or a
gently curved surface normal to the line of sight explains as well as the point; the
surfaces' fit then takes a ``line``, an ``arc`` or a ``spline`` through its readings'
echo points, whichever its criterion prefers on a few noisy points (a phantom across the
line of sight, and a missed corner). Which model it took says nothing of what was heard:
:mod:`~sonarproc.surfaces.reflectors.curve_points` (curves) and
:mod:`~sonarproc.surfaces.reflectors.corner_planes` (planes) ask the same questions, with
the same constants, here:

* Support (:func:`enough_support`): what a point fitted freely needs
  (:data:`~sonarproc.surfaces.reflectors.rcd.MIN_READINGS` readings from
  :data:`~sonarproc.surfaces.reflectors.rcd.MIN_POSES` poses), or, as the place is on a
  wall's line (one unknown instead of two),
  :data:`~sonarproc.surfaces.reflectors.line_corners.MIN_LINE_POSES` poses of which as many
  heard it from beyond
  :data:`~sonarproc.surfaces.reflectors.point_echoes.EDGE_REACH_M` (where only a corner's
  retro-reflection returns): the support
  :func:`~sonarproc.surfaces.reflectors.line_corners.corners_on_wall_lines` asks of a
  corner on a wall's line.
* Place (:func:`point_on_wall`): on the wall's line, at or past its end
  (:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`), where the ranges meet
  best (least squares along the line, from where the surface crosses it): across the line
  of sight the ranges alone leave the place to the noise, the wall's line fixes it.
* Models (:func:`no_better_model`): the place has one free parameter (along the wall's
  line), so the surface fitted through the readings, or the best plane through them, must
  not explain their ranges significantly better
  (:func:`~sonarproc.surfaces.reflectors.range_models.point_beats_plane`, Vuong's test
  the point search judges a point against a plane with). A real plane heard head on by
  sensors spread along it ranges to the feet of their perpendiculars, which one point
  explains only to within the spread's sagitta; a point's readings range to it.
* Which wall (:func:`nearest_end`): the one whose end the place is nearest. A corner is
  where its walls end; another wall's line, extrapolated metres past its end, passes
  near the corner too, and a short or slightly tilted wall's line is off there by its
  tilt times that reach (a few centimetres of tilt error over 4 m: more than the range
  tolerance). Ends nearer than :data:`~sonarproc.surfaces.reflectors.range_models.RANGE_TOL_M`
  to one another cannot be told apart by the ranges, and then the ranges' misfit decides.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.gathering import BEAM_SLACK
from sonarproc.surfaces.reflectors.line_corners import MIN_LINE_POSES
from sonarproc.surfaces.reflectors.point_echoes import EDGE_REACH_M
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_TOL_M,
    STRAY_SHARE,
    distinct_poses,
    point_beats_plane,
)
from sonarproc.surfaces.reflectors.rcd import MIN_POSES, MIN_READINGS
from sonarproc.surfaces.reflectors.walls import on_wall_lines

__all__ = [
    "end_distance",
    "enough_support",
    "nearest_end",
    "no_better_model",
    "passes_through",
    "place_on_line",
    "point_on_wall",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
#: A plane's two ends.
Segment = tuple[FloatArray, FloatArray]
#: Most Gauss-Newton steps of the place on a wall's line (one unknown: a few suffice).
POINT_ITERATIONS = 20


def enough_support(echoes: EchoGeometry, idx: IntArray) -> bool:
    """Whether the readings ``idx`` are enough for a point on a wall's line (module notes)."""
    if idx.size < MIN_LINE_POSES:
        return False
    poses = distinct_poses(echoes.xy[idx])
    if idx.size >= MIN_READINGS and poses >= MIN_POSES:
        return True
    if poses < MIN_LINE_POSES:
        return False
    far = idx[echoes.range_m[idx] > EDGE_REACH_M]
    return far.size >= MIN_LINE_POSES and distinct_poses(echoes.xy[far]) >= MIN_LINE_POSES


def passes_through(echoes: EchoGeometry, idx: IntArray, x: FloatArray) -> bool:
    """Whether the readings ``idx`` pass through ``x``, but a few strays.

    Range within :data:`RANGE_TOL_M` of the sensor's distance to ``x``, ``x`` inside the
    beam widened by :data:`~sonarproc.surfaces.reflectors.gathering.BEAM_SLACK`; at most
    :data:`~sonarproc.surfaces.reflectors.range_models.STRAY_SHARE` of them not (the
    noise's tail).
    """
    v = x - echoes.xy[idx]
    dist = np.hypot(v[:, 0], v[:, 1])
    off = np.abs((np.arctan2(v[:, 1], v[:, 0]) - echoes.heading[idx] + math.pi)
                 % (2 * math.pi) - math.pi)  # fmt: skip
    inside = off <= BEAM_SLACK * echoes.half_beam[idx]
    through = (np.abs(dist - echoes.range_m[idx]) <= RANGE_TOL_M) & inside
    return bool(np.count_nonzero(~through) <= STRAY_SHARE * idx.size)


def place_on_line(
    xy: FloatArray, rng: FloatArray, a: FloatArray, u: FloatArray, t0: float
) -> float:
    """The place ``a + t u`` on a line whose distances best match the ranges (Gauss-Newton)."""
    t = t0
    for _ in range(POINT_ITERATIONS):
        d = a + t * u - xy
        dist = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        j = (d @ u) / dist
        jj = float(j @ j)
        if jj <= 1e-12:
            break
        step = -float(j @ (dist - rng)) / jj
        t += step
        if abs(step) < 1e-9:
            break
    return t


def point_on_wall(
    xy: FloatArray, rng: FloatArray, start: FloatArray, wall: Segment
) -> FloatArray | None:
    """The place on ``wall``'s line, at or past its end, where the ranges meet, if any.

    The search starts at ``start``'s foot on the line.
    """
    a, b = wall
    v = b - a
    length = float(np.hypot(v[0], v[1]))
    if length <= 0:
        return None
    u = v / length
    t = place_on_line(xy, rng, a, u, float((start - a) @ u))
    x = np.asarray(a + t * u, dtype=np.float64)
    return x if bool(np.all(np.isfinite(x))) and bool(on_wall_lines(x, [wall])[0]) else None


def no_better_model(point_res: FloatArray, *others: FloatArray) -> bool:
    """Whether none of the ``others``' residuals beats the point's (module notes).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> plane = rng.normal(0.0, 0.008, 40)
    >>> no_better_model(plane + rng.normal(0.0, 0.012, 40), plane)
    False
    >>> no_better_model(rng.normal(0.0, 0.008, 40), plane)
    True
    """
    return not any(point_beats_plane(r, point_res) for r in others)


def nearest_end(candidates: list[tuple[float, float, FloatArray]]) -> FloatArray | None:
    """The place nearest its wall's end, of ``(end distance, RMS misfit, place)`` (notes).

    Examples
    --------
    >>> nearest_end([(3.6, 0.012, np.zeros(2)), (1.0, 0.018, np.ones(2))]).tolist()
    [1.0, 1.0]
    >>> nearest_end([(1.0, 0.012, np.zeros(2)), (1.02, 0.008, np.ones(2))]).tolist()
    [1.0, 1.0]
    """
    if not candidates:
        return None
    near = min(c[0] for c in candidates)
    return min((c for c in candidates if c[0] <= near + RANGE_TOL_M), key=lambda c: c[1])[2]


def end_distance(x: FloatArray, wall: Segment) -> float:
    """The distance from ``x`` to the nearer of ``wall``'s ends."""
    return min(math.dist(x, wall[0]), math.dist(x, wall[1]))

"""Curves that are a point's echoes: an arc or spline fitted through one point's arcs.

A point reflector (a retro-reflecting corner, a diffracting edge) answers every reading
that holds it in its beam with the distance to it: its readings' arcs all meet there (a
region of constant depth). Heard over a small spread of bearings (one sensor on a
straight stretch of track, far away), a plane or a gently curved surface normal to the
line of sight explains the same ranges as well, and the point search rightly finds no
point (:func:`~sonarproc.surfaces.reflectors.range_models.point_beats_plane` says no to
the plane). The readings then go to the surfaces' refit, whose echo points lie on the
perpendiculars from the sensors, not on any surface; through a few of them the criterion
of :mod:`sonarproc.surfaces.fitting.models` may take an arc or a spline, as an extra
parameter always lowers the residual a little: a phantom curve far from every true
surface, and a missed corner.

Where point, plane and curve explain the ranges alike, the ranges cannot decide; the map
does, as for planes (:mod:`sonarproc.surfaces.reflectors.corner_planes`).
:func:`curves_as_points` turns such a curve back into its point. A fitted ``arc`` or
``spline`` ``C`` is a point's echo at ``X`` when:

* at least :data:`~sonarproc.surfaces.reflectors.rcd.MIN_READINGS` readings from
  :data:`~sonarproc.surfaces.reflectors.rcd.MIN_POSES` distinct sensor positions echo
  from it (what any point reflector needs);
* ``X`` lies on the line of a fitted plane ``W`` at or past its end
  (:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`: corners and edges are where
  walls end), where on that line the ranges meet best (least squares), and ``C``'s chord
  crosses ``W``'s line obliquely, more than
  :data:`~sonarproc.surfaces.reflectors.point_echoes.CORNER_TOL_RAD` from parallel (a
  curve along ``W``'s line continues that wall: a stretch of it heard head on also ranges
  to one point, its foot) and from square (the other wall of a corner at ``X`` meets
  ``W`` square; a curve through a corner's arcs lies across the line of sight into it);
* every reading of ``C`` but a few strays (at most
  :data:`~sonarproc.surfaces.reflectors.range_models.STRAY_SHARE`: the noise's tail)
  passes through ``X``: its range within
  :data:`~sonarproc.surfaces.reflectors.range_models.RANGE_TOL_M` of its sensor's
  distance to ``X``, ``X`` inside its beam (widened by
  :data:`~sonarproc.surfaces.reflectors.gathering.BEAM_SLACK`): the arcs meet there;
* neither the curve nor any plane explains the ranges significantly better than ``X``:
  the Vuong (1989) test the point search judges a point against a plane with
  (:func:`~sonarproc.surfaces.reflectors.range_models.point_beats_plane` at
  :data:`~sonarproc.surfaces.reflectors.range_models.POINT_FALSE_ALARM`), each of them in
  the point's place.

A true curved wall, or a pillar heard from round it, is not lost: its readings range to
different points of it, whose arcs do not meet at one point within the range tolerance,
or the curve (three parameters, each reading its own foot) explains them significantly
better than one point. A curve crossing a wall's line obliquely, just where all of its
readings' arcs meet, would be a coincidence; a corner or an edge at the end of a wall is
what buildings are made of.

``X`` is fixed across the line of sight by the wall's line and along it by the ranges:
over a narrow spread of bearings the ranges alone leave the point's place across the
line of sight to the noise (about 0.1 m at 4 m over 3 degrees), more than the walls'
line tolerance.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry, SurfaceEchoes, echo_points
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import distance_to_polylines
from sonarproc.surfaces.reflectors.confirm import line_ends
from sonarproc.surfaces.reflectors.corner_planes import oblique, passes_through
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_TOL_M,
    distinct_poses,
    place_on_line,
    plane_residuals,
    point_beats_plane,
    sensor_span,
)
from sonarproc.surfaces.reflectors.rcd import MIN_POSES, MIN_READINGS, PointFeature
from sonarproc.surfaces.reflectors.walls import on_wall_lines

__all__ = ["CURVE_MODELS", "curve_point", "curves_as_points"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
#: A plane's two ends.
Segment = tuple[FloatArray, FloatArray]
#: Most Gauss-Newton steps of the place on a wall's line (one unknown: a few suffice).
POINT_ITERATIONS = 20

#: The fitted models a point's echoes may have been taken for (lines are judged by
#: :mod:`sonarproc.surfaces.reflectors.corner_planes`, against the walls' lines).
CURVE_MODELS = ("arc", "spline")


def _corner_on_wall(
    xy: FloatArray, rng: FloatArray, poly: FloatArray, wall: Segment
) -> FloatArray | None:
    """The point on ``wall``'s line, at or past its end, that the ranges meet at, if any.

    Only where the curve's chord crosses that line obliquely (module notes); the search
    starts at the crossing.
    """
    a, b = wall
    chord = poly[-1] - poly[0]
    v = b - a
    length = float(np.hypot(v[0], v[1]))
    if length <= 0 or not oblique(chord, v):
        return None
    u = v / length
    den = float(chord[0] * u[1] - chord[1] * u[0])
    if abs(den) < 1e-12:
        return None
    # the chord's line meets the wall's at a + t0 u
    d = poly[0] - a
    t0 = float(d[0] * chord[1] - d[1] * chord[0]) / -den
    t = place_on_line(xy, rng, a, u, t0, steps=POINT_ITERATIONS, settled=1e-9)
    x = np.asarray(a + t * u, dtype=np.float64)
    return x if bool(np.all(np.isfinite(x))) and bool(on_wall_lines(x, [wall])[0]) else None


def curve_point(
    fit: SurfaceFit, echoes: EchoGeometry, idx: IntArray, walls: list[Segment]
) -> PointFeature | None:
    """The point whose echoes the curve ``fit`` was fitted through (module notes), or None.

    Parameters
    ----------
    fit : SurfaceFit
        An ``arc`` or ``spline``.
    echoes : EchoGeometry
        The readings.
    idx : ndarray of int
        The readings that echo from ``fit`` (within :data:`RANGE_TOL_M`).
    walls : list of (ndarray, ndarray)
        The fitted planes' ends (:func:`~sonarproc.surfaces.reflectors.confirm.line_ends`).

    Returns
    -------
    PointFeature or None
    """
    if idx.size < MIN_READINGS or not walls:
        return None
    xy, rng = echoes.xy[idx], echoes.range_m[idx]
    poses = distinct_poses(xy)
    if poses < MIN_POSES:
        return None
    curve_res = distance_to_polylines(xy, [fit.polyline]) - rng
    plane_res = plane_residuals(xy, rng)
    best: tuple[float, FloatArray] | None = None
    for w in walls:
        x = _corner_on_wall(xy, rng, fit.polyline, w)
        if x is None or not passes_through(echoes, idx, x):
            continue
        point_res = np.hypot(xy[:, 0] - x[0], xy[:, 1] - x[1]) - rng
        # neither the curve nor a plane explains the ranges significantly better
        if point_beats_plane(curve_res, point_res) or point_beats_plane(plane_res, point_res):
            continue
        rms = float(np.sqrt(np.mean(point_res**2)))
        if best is None or rms < best[0]:
            best = (rms, x)
    if best is None:
        return None
    rms, x = best
    plane = float(np.sqrt(np.mean(plane_res**2)))
    return PointFeature(x, idx, poses, rms, plane, sensor_span(xy, x))


def curves_as_points(
    fits: list[SurfaceFit], echoes: EchoGeometry, *, got: list[SurfaceEchoes] | None = None
) -> tuple[list[int], list[PointFeature]]:
    """The fitted curves that are a point's echoes, and their points (module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The fitted surfaces.
    echoes : EchoGeometry
        The readings they were fitted to.
    got : list of SurfaceEchoes, optional
        ``echo_points`` of the ``fits`` at :data:`RANGE_TOL_M`, when the caller has it.

    Returns
    -------
    gone : list of int
        The indices in ``fits`` of those curves, ascending.
    points : list of PointFeature
        One point per curve gone (in the same order), with the curve's readings.

    Examples
    --------
    One sensor driving 0.3 m along x = 4 and looking back at 144 degrees hears a corner
    at (0, 3) eight times; an arc through it, across the line of sight, is that corner's
    echo where the wall x = 0 ends (alone, the ranges cannot tell); a circle of radius
    1 m heard from round it stays a curve.

    >>> import math
    >>> ys = np.linspace(0.0, 0.28, 8)
    >>> s = np.c_[np.full(8, 4.0), ys]
    >>> rng = np.hypot(4.0, ys - 3.0)
    >>> g = EchoGeometry(s, np.radians(np.full(8, 144.0)), np.full(8, np.radians(15.0)), rng)
    >>> u0 = np.array([-4.0, 2.86]) / np.hypot(4.0, 2.86)  # the line of sight
    >>> c = np.array([0.0, 3.0]) + 7.0 * u0  # a wide arc across it, through the corner
    >>> phi = math.atan2(-u0[1], -u0[0]) + np.linspace(-0.1, 0.1, 141)
    >>> arc = SurfaceFit("arc", c + 7.0 * np.c_[np.cos(phi), np.sin(phi)], 1.4, 0.0, 8, 8)
    >>> wall = SurfaceFit("line", np.c_[np.zeros(25), np.linspace(0.5, 2.9, 25)], 2.4, 0.0, 9, 9)
    >>> gone, points = curves_as_points([wall, arc], g)
    >>> gone, [(np.round(p.xy, 3) + 0.0).tolist() for p in points]
    ([1], [[0.0, 3.0]])
    >>> curves_as_points([arc], g)
    ([], [])
    >>> a = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    >>> ring = np.c_[3 * np.cos(a), 3 * np.sin(a)]
    >>> pillar = EchoGeometry(ring, a + np.pi, np.full(16, np.radians(15.0)), np.full(16, 2.0))
    >>> c = np.linspace(0.0, 2 * np.pi, 200)
    >>> circle = SurfaceFit("arc", np.c_[np.cos(c), np.sin(c)], 6.3, 0.0, 16, 16, True)
    >>> curves_as_points([circle], pillar)
    ([], [])
    """
    curves = [k for k, s in enumerate(fits)
              if s.model in CURVE_MODELS and s.polyline.shape[0] >= 2]  # fmt: skip
    if not curves:
        return [], []
    if got is None:
        got = echo_points([s.polyline for s in fits], [s.closed for s in fits], echoes,
                          tol=RANGE_TOL_M)  # fmt: skip
    walls = line_ends(fits)
    gone: list[int] = []
    points: list[PointFeature] = []
    for k in curves:
        p = curve_point(fits[k], echoes, got[k].readings, walls)
        if p is not None:
            gone.append(k)
            points.append(p)
    return gone, points

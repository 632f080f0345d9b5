"""Point echoes that are a cylinder's: a pillar seen past the ends of a plane fitted to it.

A cylinder (a pillar) answers each sensor from the point of its surface that faces the
sensor: the range is the distance to its centre less its radius. Seen over a wide span
of bearings its echo points lie on an arc; seen from a line of poses passing a small
pillar, the arc is short and a plane may be fitted through part of it (a chord). On
that plane's line, just past its ends, the readings from the sides meet the line where
it leaves the pillar's surface, and a corner searched on the line
(:mod:`~sonarproc.surfaces.reflectors.line_corners`) is found there, a centimetre or two
off the pillar. Its own readings, heard over a narrow span, cannot tell it from a point
reflector (the circle's sag over the span, ``r (1 - cos(span / 2))``, is under the time
walk); together with the plane's readings they can.

:func:`one_cylinder` fits one circle (range = the distance to a centre less a radius,
least squares) to both sets of readings. They are a cylinder's when it explains all of
them but a few strays
(:data:`~sonarproc.surfaces.reflectors.range_models.STRAY_SHARE`) within the range
tolerance (:data:`~sonarproc.surfaces.reflectors.range_models.RANGE_TOL_M`) and its
radius is clear, by the test a point reflector's own readings are given
(:func:`~sonarproc.surfaces.reflectors.rcd.clear_radius`): above
:data:`~sonarproc.surfaces.reflectors.rcd.MAX_POINT_RADIUS_M`, more than two standard
errors (range noise :data:`~sonarproc.surfaces.reflectors.rcd.RANGE_NOISE_M`) from zero,
and with a sag over the sensors' span above the time walk
(:data:`~sonarproc.surfaces.reflectors.time_walk.TIME_WALK_M`).

:func:`pillar_pieces` asks it of a point and the planes that may end at it (passing
within :data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M` of it): for a corner
searched on a wall's line and for a point reflector checked against the fitted surfaces
(:mod:`~sonarproc.surfaces.reflectors.confirm`). The pieces (each plane's readings
ranging its line, the point's the point) must also not explain the readings
significantly better than the circle
(:func:`~sonarproc.surfaces.reflectors.range_models.point_beats_plane`): a wall that ends
at an edge or a corner, whose readings a circle may follow to within the tolerance, is
explained better by the wall and the point.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_TOL_M,
    STRAY_SHARE,
    point_beats_plane,
)
from sonarproc.surfaces.reflectors.rcd import MAX_POINT_RADIUS_M, clear_radius, fit_circle
from sonarproc.surfaces.reflectors.walls import END_REACH_M, side_of_line

__all__ = ["one_cylinder", "pillar_pieces", "segment_distance"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def one_cylinder(
    xy: FloatArray,
    rng: FloatArray,
    start: npt.ArrayLike,
    pieces: FloatArray | None = None,
    fit: npt.NDArray[np.bool_] | None = None,
) -> bool:
    """Whether one cylinder of a clear radius explains the ranges (module notes).

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        Sensor positions (m): a plane's readings and a point's together.
    rng : ndarray, shape (N,)
        Their ranges (m).
    start : array_like, shape (2,)
        Where the centre's search starts (m): the point.
    pieces : ndarray, shape (N,), optional
        The same readings' range residuals (m) under the pieces the cylinder would
        replace (each plane's readings from its line, the point's from the point): the
        cylinder stands only if they do not explain the ranges significantly better
        (:func:`~sonarproc.surfaces.reflectors.range_models.point_beats_plane`, the
        pieces in the point's place): a wall's end and its edge, explained by a circle to
        within the tolerance, are still explained better by the wall and the edge.
    fit : ndarray of bool, shape (N,), optional
        The readings the circle is fitted to (default: all); it is judged on all of them.

    Examples
    --------
    A pillar of radius 0.2 m at (0, 1) seen from y = 0, and a wall y = 1 seen head on:

    >>> x = np.linspace(-1.5, 1.5, 16)
    >>> s = np.c_[x, np.zeros(16)]
    >>> one_cylinder(s, np.hypot(x, 1.0) - 0.2, [0.0, 0.8])
    True
    >>> one_cylinder(s, np.ones(16), [0.0, 0.8])
    False
    """
    q = fit_circle(xy, rng, start) if fit is None else fit_circle(xy[fit], rng[fit], start)
    centre, radius = q[:2], float(q[2])
    if not math.isfinite(radius) or radius <= MAX_POINT_RADIUS_M:
        return False
    res = np.hypot(xy[:, 0] - centre[0], xy[:, 1] - centre[1]) - radius - rng
    if np.count_nonzero(np.abs(res) > RANGE_TOL_M) > STRAY_SHARE * rng.size:
        return False
    if not clear_radius(xy, q):
        return False
    return pieces is None or not point_beats_plane(pieces, res)


def pillar_pieces(
    echoes: EchoGeometry,
    idx: IntArray,
    x: FloatArray,
    planes: list[tuple[FloatArray, FloatArray, IntArray, FloatArray]],
) -> bool:
    """Whether a point at ``x`` (its readings ``idx``) and the planes that may end there are
    one pillar's pieces (module notes).

    ``planes``: each plane's two ends, its specular readings (indices into ``echoes``) and
    their echo points (R, 2). Those passing within
    :data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M` of ``x`` may end there. The
    circle is fitted to their readings whose echo points lie within that reach of ``x``
    and the point's (a long wall's far readings cost a circle fit, and a pillar's pieces
    lie there), and judged on all their readings (a long wall is no pillar's piece).
    """
    near = [(a, b, r, pts) for a, b, r, pts in planes
            if r.size and segment_distance(x, a, b) <= END_REACH_M]  # fmt: skip
    if not near:
        return False
    both = np.concatenate([r for _, _, r, _ in near] + [idx])
    close = [np.hypot(pts[:, 0] - x[0], pts[:, 1] - x[1]) <= END_REACH_M for *_, pts in near]
    close.append(np.ones(idx.size, dtype=bool))
    # the pieces' own residuals: each plane's readings range its line, the place's the place
    pieces = [np.abs(side_of_line(a, b, echoes.xy[r])) / float(np.hypot(*(b - a)))
              - echoes.range_m[r] for a, b, r, _ in near]  # fmt: skip
    pieces.append(np.hypot(*(echoes.xy[idx] - x).T) - echoes.range_m[idx])
    xy, rng = echoes.xy[both], echoes.range_m[both]
    return one_cylinder(xy, rng, x, np.concatenate(pieces), fit=np.concatenate(close))


def segment_distance(x: FloatArray, a: FloatArray, b: FloatArray) -> float:
    """Distance (m) from ``x`` to the segment ``a``-``b``."""
    v = b - a
    t = float(np.clip((x - a) @ v / max(float(v @ v), 1e-12), 0.0, 1.0))
    return float(np.hypot(*(a + t * v - x)))

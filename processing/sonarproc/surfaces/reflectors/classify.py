"""Point reflectors told apart: a concave corner or a convex edge.

:func:`point_kind` says which kind of point it is. First from the echo physics
(:func:`~sonarproc.surfaces.reflectors.point_echoes.echo_kind`: the sensors' spread round
the point, how far it was heard, whether beams passed it by). When the echoes do not
tell, from the fitted straight surfaces (planes) that end at it (the point on the
plane's line, within :data:`~sonarproc.surfaces.reflectors.walls.LINE_REACH_M`, at or
past its nearer end, from :data:`~sonarproc.surfaces.reflectors.walls.END_REACH_M`
inside it: :func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`):

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

The points themselves are checked against the fitted surfaces first
(:mod:`sonarproc.surfaces.reflectors.confirm`, whose functions are importable from here
too).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.confirm import (
    confirm_points,
    heard_as_corner,
    line_ends,
    on_circles,
)
from sonarproc.surfaces.reflectors.point_echoes import (
    AXIS_SHARE,
    CORNER_TOL_RAD,
    EDGE_REACH_M,
    MIN_CROSSINGS,
    MIN_FAR_POSES,
    answers_its_beams,
    echo_kind,
)
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M
from sonarproc.surfaces.reflectors.rcd import PointFeature
from sonarproc.surfaces.reflectors.walls import (
    on_wall_lines,
    side_of_line,
)

__all__ = [
    "AXIS_SHARE",
    "CORNER_TOL_RAD",
    "EDGE_REACH_M",
    "MIN_CROSSINGS",
    "MIN_FAR_POSES",
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
        side_a = float(np.median(np.sign(side_of_line(na, fa, sensors))))
        side_b = float(np.median(np.sign(side_of_line(nb, fb, sensors))))
        a_sees_b = side_a * float(side_of_line(na, fa, fb)) > 0
        concave = a_sees_b and side_b * float(side_of_line(nb, fb, fa)) > 0
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

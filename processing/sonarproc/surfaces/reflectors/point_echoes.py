"""What a point reflector's echoes alone say of it: a corner, an edge, or nothing.

:func:`echo_kind` reads the echo physics:

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

:func:`answers_its_beams` says whether a point answered the beams aimed at it, as a
retro-reflecting corner does. Both look at the readings from inside the point's sector
aimed at it (:func:`aimed_from_sector`).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M, distinct_poses
from sonarproc.surfaces.reflectors.rcd import PointFeature

__all__ = [
    "ANSWER_SHARE",
    "AXIS_SHARE",
    "CORNER_TOL_RAD",
    "EDGE_REACH_M",
    "MIN_CROSSINGS",
    "MIN_FAR_POSES",
    "BeamAxes",
    "aimed_from_sector",
    "answers_its_beams",
    "echo_kind",
    "far_poses",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Beams that say a place is free space before a point is an edge (one may be a stray
#: echo).
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
#: Share of the beams holding a point near their axis that a retro-reflecting corner
#: answers: all of them, less dropouts and the range step's rounding; more than half.
ANSWER_SHARE = 0.5
# :class:`BeamAxes` keeps the beams within this (rad) more than the aim of their axis:
# far above the rounding of the exact test's angles (1e-15 rad), far below any aim.
_AIM_MARGIN_RAD = 1e-6


def _sector_start(point: PointFeature, rel: FloatArray) -> float | None:
    """Bearing (rad) where the point's sector starts (just past its sensors' largest gap).

    ``rel`` (N, 2) is every sensor's position less the point's; None when fewer than two
    readings make the point (no sector).
    """
    mine = rel[point.readings]
    own = np.sort(np.arctan2(mine[:, 1], mine[:, 0]))
    if own.size < 2:
        return None
    gaps = np.diff(np.r_[own, own[0] + 2 * np.pi])
    return float(own[(int(np.argmax(gaps)) + 1) % own.size])


def _aimed(
    point: PointFeature, echoes: EchoGeometry, rel: FloatArray, rows: IntArray, start: float
) -> npt.NDArray[np.bool_]:
    """Whether readings ``rows`` (``rel``: their sensors less the point) were aimed at the
    point from inside its sector (:func:`aimed_from_sector`)."""
    heading = echoes.heading[rows]
    bearing = np.arctan2(rel[:, 1], rel[:, 0])
    inside = np.mod(bearing - start, 2 * np.pi) <= point.span_rad
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(-rel[:, 1], -rel[:, 0]) - heading))))
    return np.asarray(inside & (off <= AXIS_SHARE * echoes.half_beam[rows]))


def aimed_from_sector(
    point: PointFeature,
    echoes: EchoGeometry,
    among: Callable[[FloatArray], npt.NDArray[np.bool_]] | None = None,
) -> tuple[FloatArray, npt.NDArray[np.bool_]] | None:
    """Every reading's distance to the point, and whether it was aimed at it from its sector.

    From its sector: the sensor's bearing from the point lies within the bearings of the
    point's own sensors (the complement of their largest gap, ``point.span_rad`` wide).
    Aimed at it: the point lies within :data:`AXIS_SHARE` of the half beam of the
    reading's axis. None when fewer than two readings make the point (no sector).

    ``among``, given the distances, marks the only readings the caller asks about (the
    others are reported not aimed): the bearings, elementwise, are then computed for
    those alone, with the same values.

    Examples
    --------
    >>> xy = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [-1.0, 0.0]])
    >>> heading = np.arctan2(-xy[:, 1], -xy[:, 0])          # every sensor faces the origin
    >>> e = EchoGeometry(xy, heading, np.full(4, 0.2), np.hypot(*xy.T))
    >>> f = PointFeature(np.zeros(2), np.arange(2), 2, 0.0, 1.0, np.pi / 2)
    >>> dist, aimed = aimed_from_sector(f, e)
    >>> aimed.tolist()                      # the sensor behind, at (-1, 0), is outside
    [True, True, True, False]
    """
    rel = echoes.xy - point.xy
    dist = np.hypot(rel[:, 0], rel[:, 1])
    start = _sector_start(point, rel)
    if start is None:
        return None
    rows = np.arange(dist.size) if among is None else np.flatnonzero(among(dist))
    aimed = np.zeros(dist.size, dtype=bool)
    aimed[rows] = _aimed(point, echoes, rel[rows], rows, start)
    return dist, aimed


class BeamAxes:
    """Every reading's beam axis, to tell cheaply which beams cannot hold a point near it.

    :func:`answers_its_beams`, asked of many points of one log, is given these, computed
    once: each axis's unit vector, and the cosine of the widest angle off it at which a
    point is near the axis (:data:`AXIS_SHARE` of the half beam) plus
    :data:`_AIM_MARGIN_RAD`. A beam whose direction to the point makes a smaller cosine
    with its axis holds the point farther off its axis than that, by far more than the
    rounding of the exact test's angles, so it is not aimed at the point; the others are
    tested exactly.

    Examples
    --------
    >>> xy = np.array([[1.0, 0.0], [0.0, 1.0]])
    >>> e = EchoGeometry(xy, np.array([np.pi, 0.0]), np.full(2, 0.2), np.ones(2))
    >>> BeamAxes(e).may_aim(xy, np.ones(2), np.arange(2)).tolist()  # the origin
    [True, False]
    """

    def __init__(self, echoes: EchoGeometry) -> None:
        self.cos = np.cos(echoes.heading)
        self.sin = np.sin(echoes.heading)
        self.cos_aim = np.cos(np.minimum(AXIS_SHARE * echoes.half_beam + _AIM_MARGIN_RAD, np.pi))

    def may_aim(self, rel: FloatArray, dist: FloatArray, rows: IntArray) -> npt.NDArray[np.bool_]:
        """Whether beams ``rows`` may hold a point near their axis (all that do, and more).

        ``rel`` (N, 2) is their sensors' positions less the point's, ``dist`` its length.
        """
        toward = -(rel[:, 0] * self.cos[rows] + rel[:, 1] * self.sin[rows])
        return np.asarray(toward >= dist * self.cos_aim[rows])


def answers_its_beams(
    point: PointFeature, echoes: EchoGeometry, axes: BeamAxes | None = None
) -> bool:
    """Whether the point answered most of the beams that held it near their axis.

    A retro-reflecting corner returns as much as a plane from anywhere inside its
    opening, so every reading from inside its sensors' sector (the complement of their
    largest gap of bearings), no farther than its farthest reading, with the point within
    :data:`AXIS_SHARE` of the half beam of its axis, ranges it, within :data:`RANGE_TOL_M`.
    Where several surfaces' arcs cross by chance, the beams aimed at the crossing range
    the surfaces behind it, or a surface in front of it (a crossing behind a wall, which
    no sound reached): more than :data:`ANSWER_SHARE` of them must range the point.

    ``axes`` (:class:`BeamAxes` of the same ``echoes``), for many points of one log,
    leaves out cheaply the beams that cannot hold the point near their axis before the
    exact test (the answer is the same).
    """
    rel = echoes.xy - point.xy
    dist = np.hypot(rel[:, 0], rel[:, 1])
    start = _sector_start(point, rel)
    if start is None:
        return False
    rows = np.flatnonzero(dist <= float(dist[point.readings].max()) + RANGE_TOL_M)
    if axes is not None:
        rows = rows[axes.may_aim(rel[rows], dist[rows], rows)]
    rows = rows[_aimed(point, echoes, rel[rows], rows, start)]
    answered = np.count_nonzero(np.abs(echoes.range_m[rows] - dist[rows]) <= RANGE_TOL_M)
    return bool(answered > ANSWER_SHARE * rows.size)


def far_poses(point: PointFeature, echoes: EchoGeometry) -> int:
    """Distinct poses that heard the point from beyond :data:`EDGE_REACH_M`."""
    own = point.readings
    far = own[echoes.range_m[own] > EDGE_REACH_M]
    return distinct_poses(echoes.xy[far]) if far.size else 0


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
    if far_poses(point, echoes) >= MIN_FAR_POSES:
        return "corner"
    if _passed_by(point, echoes) >= MIN_CROSSINGS:
        return "edge"
    return None


def _passed_by(point: PointFeature, echoes: EchoGeometry) -> int:
    """Readings from inside the point's sector, beyond the edge reach, that echoed past it.

    Inside the sector and aimed at the point (:func:`aimed_from_sector`), from beyond
    :data:`EDGE_REACH_M`; the echo came from more than :data:`RANGE_TOL_M` beyond it.
    """

    def beyond(dist: FloatArray) -> npt.NDArray[np.bool_]:
        return (dist > EDGE_REACH_M) & (echoes.range_m > dist + RANGE_TOL_M)

    sector = aimed_from_sector(point, echoes, beyond)
    if sector is None:
        return 0
    _, passed = sector
    passed[point.readings] = False
    return int(np.count_nonzero(passed))

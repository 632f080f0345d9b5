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
    "BeamIndex",
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
# :class:`BeamIndex` keeps the beams within this (rad) more than the aim of their axis,
# and the sensors within this (m) more than the reach asked: far above the rounding of
# the exact tests (1e-15 rad, 1e-15 m), far below any aim or reach.
_AIM_MARGIN_RAD = 1e-6
_REACH_MARGIN_M = 1e-6
# :meth:`BeamIndex.aiming` screens the readings by squared lengths within this relative
# margin: far above their rounding (a few 1e-16), far below any aim or reach.
_SCREEN_MARGIN = 1e-9
# :class:`BeamIndex` sorts the sensors by cells of this size (m), row by row: a point's
# reach (metres) spans tens of rows, so the square round it is read in as many slices.
_CELL_M = 0.5


def _sector_start(mine: FloatArray) -> float | None:
    """Bearing (rad) where a point's sector starts (just past its sensors' largest gap).

    ``mine`` (N, 2) is its own readings' sensor positions less the point's; None when
    fewer than two readings make the point (no sector).
    """
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
    start = _sector_start(rel[point.readings])
    if start is None:
        return None
    rows = np.arange(dist.size) if among is None else np.flatnonzero(among(dist))
    aimed = np.zeros(dist.size, dtype=bool)
    aimed[rows] = _aimed(point, echoes, rel[rows], rows, start)
    return dist, aimed


class BeamIndex:
    """The readings' sensors and beam axes, sorted to find quickly the beams that may
    hold a point near their axis within a reach of it.

    :func:`answers_its_beams`, asked of many points of one log, is given this, made once:
    the sensor positions sorted by cells of :data:`_CELL_M`, row by row (the sensors in
    the square round a point are a slice of each row of cells), each axis's unit vector
    and the cosine of the widest angle off it at which a point is near the axis
    (:data:`AXIS_SHARE` of the half beam) plus :data:`_AIM_MARGIN_RAD`. :meth:`aiming`
    keeps every reading the exact tests keep, and some more; those are screened by
    squared lengths (no square root), and the few left tested exactly.

    A kernel of our own where scipy has one (``cKDTree.query_ball_point`` on the sensor
    positions, then the same aim test): kept because ``./scripts/bench``
    (``test_bench_beam_index``) measures the tree at about 5 times its CPU time on the
    real workload, the index and the queries of the 90 000-reading room run (the ball
    of a point's reach holds thousands of sensors, which the tree hands back one Python
    integer each; the cells, as slices of sorted arrays).

    Examples
    --------
    >>> xy = np.array([[1.0, 0.0], [0.0, 1.0], [3.0, 0.0]])
    >>> e = EchoGeometry(xy, np.array([np.pi, 0.0, np.pi]), np.full(3, 0.2), np.ones(3))
    >>> rows, rel, dist = BeamIndex(e).aiming(np.zeros(2), 1.5)  # the origin
    >>> rows.tolist(), rel.tolist(), dist.tolist()
    ([0], [[1.0, 0.0]], [1.0])
    """

    def __init__(self, echoes: EchoGeometry) -> None:
        x, y = echoes.xy[:, 0], echoes.xy[:, 1]
        self._x0 = float(x.min()) if x.size else 0.0
        self._y0 = float(y.min()) if y.size else 0.0
        cx = np.floor((x - self._x0) / _CELL_M).astype(np.int64)
        cy = np.floor((y - self._y0) / _CELL_M).astype(np.int64)
        self._nx, self._ny = int(cx.max(initial=0)) + 1, int(cy.max(initial=0)) + 1
        order = np.argsort(cy * self._nx + cx, kind="stable").astype(np.intp)
        self._keys = (cy * self._nx + cx)[order]
        aim = np.minimum(AXIS_SHARE * echoes.half_beam + _AIM_MARGIN_RAD, np.pi)
        cos_aim = np.cos(aim[order])
        # the screen's bound on toward |toward| / dist^2 (see aiming); an aim past a right
        # angle keeps every direction
        screen = np.where(cos_aim > 0.0, cos_aim * cos_aim * (1.0 - _SCREEN_MARGIN), -2.0)
        # every column in the cells' order, one row each (the readings' indices exactly,
        # as floats), so that a row of cells is read as one slice of them all
        cos_h, sin_h = echoes.axes  # made once per EchoGeometry
        self._cols = np.stack((order.astype(np.float64), x[order], y[order], cos_h[order],
                               sin_h[order], cos_aim, screen))  # fmt: skip

    def aiming(self, p: FloatArray, reach: float) -> tuple[IntArray, FloatArray, FloatArray]:
        """The readings whose sensors lie within ``reach`` (m) of ``p`` and whose beams
        may hold it near their axis (all those that do, and some more).

        Returns their indices (in no particular order), their sensors' positions less
        ``p`` (N, 2), and its length.
        """
        r = reach + _REACH_MARGIN_M
        px, py = float(p[0]), float(p[1])
        # the cells of the square round p: a slice of the sorted keys in each row of cells
        left, right = (min(max(math.floor((v - self._x0) / _CELL_M), 0), self._nx - 1)
                       for v in (px - r, px + r))  # fmt: skip
        bottom = max(math.floor((py - r - self._y0) / _CELL_M), 0)
        top = min(math.floor((py + r - self._y0) / _CELL_M), self._ny - 1)
        rows = np.arange(bottom, top + 1)
        lo = np.searchsorted(self._keys, rows * self._nx + left).tolist()
        hi = np.searchsorted(self._keys, rows * self._nx + right, "right").tolist()
        cols = self._cols
        order, x, y, c, s, cos_aim, screen = np.concatenate(
            [cols[:, a:z] for a, z in zip(lo, hi, strict=True)] or [cols[:, :0]], axis=1
        )
        rx, ry = x - px, y - py
        toward = -(rx * c + ry * s)
        # a screen without square roots first: a reading the exact tests keep has
        # dist^2 <= reach^2 and toward |toward| >= dist^2 cos(aim)^2 (toward >= 0 when the
        # aim is under a right angle), both with margins far above their rounding; the
        # few it keeps (the beams aimed near p) are then tested exactly, as before
        sq = rx * rx + ry * ry
        far = reach * reach * (1.0 + _SCREEN_MARGIN)
        near = np.flatnonzero((sq <= far) & (toward * np.abs(toward) >= sq * screen))
        dist = np.hypot(rx[near], ry[near])
        keep = (dist <= reach) & (toward[near] >= dist * cos_aim[near])
        rows = near[keep]
        return (order[rows].astype(np.intp), np.column_stack((rx[rows], ry[rows])), dist[keep])


def answers_its_beams(
    point: PointFeature, echoes: EchoGeometry, index: BeamIndex | None = None
) -> bool:
    """Whether the point answered most of the beams that held it near their axis.

    A retro-reflecting corner returns as much as a plane from anywhere inside its
    opening, so every reading from inside its sensors' sector (the complement of their
    largest gap of bearings), no farther than its farthest reading, with the point within
    :data:`AXIS_SHARE` of the half beam of its axis, ranges it, within :data:`RANGE_TOL_M`.
    Where several surfaces' arcs cross by chance, the beams aimed at the crossing range
    the surfaces behind it, or a surface in front of it (a crossing behind a wall, which
    no sound reached): more than :data:`ANSWER_SHARE` of them must range the point.

    ``index`` (:class:`BeamIndex` of the same ``echoes``), for many points of one log,
    leaves out cheaply the readings too far or aimed elsewhere before the exact tests
    (the answer is the same).
    """
    mine = echoes.xy[point.readings] - point.xy
    start = _sector_start(mine)
    if start is None:
        return False
    reach = float(np.hypot(mine[:, 0], mine[:, 1]).max()) + RANGE_TOL_M
    if index is None:
        rel = echoes.xy - point.xy
        dist = np.hypot(rel[:, 0], rel[:, 1])
        rows = np.flatnonzero(dist <= reach)
        rel, dist = rel[rows], dist[rows]
    else:
        rows, rel, dist = index.aiming(point.xy, reach)
    aimed = _aimed(point, echoes, rel, rows, start)
    answered = np.count_nonzero(np.abs(echoes.range_m[rows[aimed]] - dist[aimed]) <= RANGE_TOL_M)
    return bool(answered > ANSWER_SHARE * np.count_nonzero(aimed))


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

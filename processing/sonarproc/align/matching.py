"""Echo points of one stretch of track matched to local lines of another stretch.

Each query echo point (from the stretch between two correction nodes) is matched to the
echo points of *another* stretch near it: of its ``k`` nearest neighbours within the
match radius (:class:`scipy.spatial.cKDTree`), those from the stretch of the nearest
neighbour that is not its own. If they are at least ``min_points`` and lie along a line
(a principal-component fit thinner than ``max_thickness`` and longer than it is thick
several times over), the query is matched to that line: its centroid and unit normal,
and where on the other stretch it was seen (the mean travel and robot position of its
points), so that the line moves with that stretch's correction.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

__all__ = ["LineMatches", "RayFrame", "line_matches", "match_lines"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Neighbours examined per query: enough that a stretch of wall seen by another stretch
#: of track still shows several points when the query's own stretch crowds the nearest.
NEIGHBOURS = 48
#: Travel (m) between two readings for them to count as seen from distinct places.
MIN_STEP = 0.01
#: Most threads the neighbour search runs on: the queries are independent (the answer is
#: the same on any number), and beyond a few cores memory bandwidth gains nothing more.
MAX_SEARCH_THREADS = 4
#: Shortest length (m) over which a line counts as seen (see :func:`line_matches`): a
#: line's neighbours come from one stretch of track (a node spacing, about 1 m) and at
#: least three places 1 cm apart; seen over less than this, their spread is the range
#: noise's, not the wall's extent.
FOOT_FLOOR = 0.1


def _search_threads() -> int:
    """The CPUs this process may run on, at most :data:`MAX_SEARCH_THREADS`."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on every platform
        n = os.cpu_count() or 1
    return max(1, min(n, MAX_SEARCH_THREADS))


@dataclass(frozen=True, eq=False)
class RayFrame:
    """Every ray under one set of poses (all arrays length E)."""

    #: line-of-sight echo points (E, 2)
    points: FloatArray
    #: sensor positions (E, 2) and lines of sight (E,)
    sensor_xy: FloatArray
    look: FloatArray
    #: ranges (E,) and half beam widths (E,)
    range_m: FloatArray
    half_beam: FloatArray
    #: travel (E,) and robot position (E, 2) of each ray's reading
    u: FloatArray
    robot_xy: FloatArray


@dataclass(frozen=True, eq=False)
class LineMatches:
    """Queries matched to local lines of other stretches (all arrays length M)."""

    #: query ray (index into the rays)
    query: IntArray
    #: a point of the wall (M, 2) and its unit normal (M, 2), pointing away from the
    #: sensors that saw it, in the raw frame of the line's stretch
    centroid: FloatArray
    normal: FloatArray
    #: mean travel and mean raw robot position (M, 2) of the line's readings
    anchor_u: FloatArray
    anchor_xy: FloatArray

    @property
    def size(self) -> int:
        """Number of matches."""
        return int(self.query.size)


def match_lines(
    points: FloatArray,
    stretch: IntArray,
    queries: IntArray,
    *,
    radius: float,
    min_points: int,
    max_thickness: float,
) -> tuple[IntArray, IntArray]:
    """For each query point, the neighbours that make its local line in another stretch.

    Parameters
    ----------
    points : ndarray, shape (E, 2)
        Echo points of every ray under the current correction.
    stretch : ndarray of int, shape (E,)
        The stretch of track (node interval) of each ray.
    queries : ndarray of int, shape (Q,)
        The rays to match.
    radius : float
        Match radius (m).
    min_points : int
        Fewest points a local line needs.
    max_thickness : float
        Largest RMS distance (m) of the points from their line.

    Returns
    -------
    query, neighbours : ndarray of int
        The matched queries (M,) and, as an (M, NEIGHBOURS) array padded with -1, the
        rays that make each one's line.
    """
    empty = np.zeros(0, dtype=np.intp)
    if queries.size == 0 or points.shape[0] < min_points:
        return empty, np.zeros((0, NEIGHBOURS), dtype=np.intp)
    k = min(NEIGHBOURS, points.shape[0])
    tree = cKDTree(points)
    # the run's costliest search on a long log (a few dozen neighbours of 10^4 queries)
    dist, nb = tree.query(
        points[queries], k=k, distance_upper_bound=radius, workers=_search_threads()
    )
    dist = dist.reshape(queries.size, k)
    nb = nb.reshape(queries.size, k)
    found = np.isfinite(dist)
    nb = np.where(found, nb, 0)
    other = found & (stretch[nb] != stretch[queries][:, None])
    has = other.any(axis=1)
    first = np.argmax(other, axis=1)
    chosen = stretch[nb[np.arange(queries.size), first]]
    member = other & (stretch[nb] == chosen[:, None]) & has[:, None]
    count = member.sum(axis=1)
    # only the queries with enough neighbours go on (on a log whose stretches rarely see
    # one wall, a few in a hundred): each row's sums below are the same on the subset
    rows = np.flatnonzero(count >= min_points)
    member, nb, count = member[rows], nb[rows], count[rows]
    # principal components of each query's chosen neighbours, in closed form (2 x 2)
    px = np.where(member, points[nb, 0], 0.0)
    py = np.where(member, points[nb, 1], 0.0)
    c = np.maximum(count, 1)
    mx, my = px.sum(1) / c, py.sum(1) / c
    dx, dy = np.where(member, px - mx[:, None], 0.0), np.where(member, py - my[:, None], 0.0)
    sxx, syy, sxy = (dx * dx).sum(1) / c, (dy * dy).sum(1) / c, (dx * dy).sum(1) / c
    half_tr, det = 0.5 * (sxx + syy), sxx * syy - sxy * sxy
    root = np.sqrt(np.maximum(half_tr**2 - det, 0.0))
    lam_min, lam_max = np.maximum(half_tr - root, 0.0), half_tr + root
    # a line: thin (echo noise), and several times longer than thick (not a blob)
    keep = (np.sqrt(lam_min) <= max_thickness) & (lam_max >= 9.0 * lam_min)
    keep &= np.sqrt(lam_max) >= max_thickness
    rows = rows[keep]
    out = np.where(member[keep], nb[keep], -1)
    if k < NEIGHBOURS:
        out = np.pad(out, ((0, 0), (0, NEIGHBOURS - k)), constant_values=-1)
    return queries[rows], out.astype(np.intp)


def line_matches(
    query: IntArray,
    neighbours: IntArray,
    raw: RayFrame,
    query_look: FloatArray,
    *,
    min_points: int,
    min_places: int,
) -> LineMatches:
    """The walls that matched neighbours echo from, in the raw frame of their stretch.

    The wall's direction is the principal axis of the neighbours' raw line-of-sight
    points (a sensor passing a wall traces a line parallel to it); its normal points
    away from their sensors. The specular model then places it: only neighbours whose
    line of sight lies within their half beam of the normal echo from it, each at its
    range along the normal from its sensor; the centroid is the mean of those points.
    A match needs ``min_points`` such neighbours seen from ``min_places`` distinct
    places (readings at least 1 cm of travel apart), and a query whose line of sight
    (``query_look``, under the current correction) also lies within its beam of the
    normal. The line is anchored where its readings were taken (their mean travel and
    robot position), so that the least-squares problem moves it with the correction of
    its own stretch.

    The query's specular foot must also lie on the part of the line its neighbours saw,
    widened by that part's own length on either side (:data:`FOOT_FLOOR` at least). A
    reading's foot lies, along the wall, where its sensor does, so this compares the
    sensors' positions along the line. A corner or an edge echoes like a point: seen
    from one stretch its echoes fit a line tangent to the circle round it, which agrees
    with the readings of that stretch but not with a query seen from metres further
    away, whose range to the point differs from its distance to that line in proportion
    to the distance between them. Along a corridor driven to its end wall and back those
    matches (the end wall's corners, seen from 1.7 m and from 5 m) read as a 3 %
    odometry scale error and passed the significance test on a drift-free log; a real
    wall's line is matched where it was seen, where a plane and a point agree.
    """
    member = neighbours >= 0
    nb = np.where(member, neighbours, 0)

    def mean(v: FloatArray, m: npt.NDArray[np.bool_]) -> FloatArray:
        c = np.maximum(m.sum(axis=1), 1)
        return np.asarray(np.where(m, v[nb], 0.0).sum(axis=1) / c, dtype=np.float64)

    pts = raw.points
    mx, my = mean(pts[:, 0], member), mean(pts[:, 1], member)
    dx = np.where(member, pts[nb, 0] - mx[:, None], 0.0)
    dy = np.where(member, pts[nb, 1] - my[:, None], 0.0)
    sxx, syy, sxy = (dx * dx).sum(1), (dy * dy).sum(1), (dx * dy).sum(1)
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    normal = np.column_stack((-np.sin(angle), np.cos(angle)))
    # orient each normal from the sensors towards the wall
    out_x = mean(pts[:, 0] - raw.sensor_xy[:, 0], member)
    out_y = mean(pts[:, 1] - raw.sensor_xy[:, 1], member)
    normal *= np.where(normal[:, 0] * out_x + normal[:, 1] * out_y < 0.0, -1.0, 1.0)[:, None]
    look = np.column_stack((np.cos(raw.look), np.sin(raw.look)))
    facing = (look[nb, 0] * normal[:, None, 0] + look[nb, 1] * normal[:, None, 1]
              >= np.cos(raw.half_beam[nb]))  # fmt: skip
    member &= facing
    # distinct places the line was seen from: a wall is told from a corner or from two
    # unrelated echoes only when seen from several places (one place's echoes can pair
    # any two points into a "line")
    seen_at = np.sort(np.where(member, raw.u[nb], np.nan), axis=1)
    steps = np.diff(seen_at, axis=1)
    places = member.any(axis=1) + np.sum(np.nan_to_num(steps, nan=0.0) > MIN_STEP, axis=1)
    # the mean of the specular echo points (sensor + range x normal)
    reach = mean(raw.range_m, member)
    ex = mean(raw.sensor_xy[:, 0], member) + reach * normal[:, 0]
    ey = mean(raw.sensor_xy[:, 1], member) + reach * normal[:, 1]
    q = np.column_stack((np.cos(query_look), np.sin(query_look)))
    # along the wall, each reading's specular foot lies where its sensor does (the foot
    # is the sensor moved along the normal): the line is known where its readings' feet
    # are; a point's echoes fit it there only, a plane's everywhere
    along = np.column_stack((-normal[:, 1], normal[:, 0]))
    t = raw.sensor_xy[nb, 0] * along[:, None, 0] + raw.sensor_xy[nb, 1] * along[:, None, 1]
    lo = np.where(member, t, np.inf).min(axis=1)
    hi = np.where(member, t, -np.inf).max(axis=1)
    seen_len = np.maximum(hi - lo, FOOT_FLOOR)
    tq = np.sum(raw.sensor_xy[query] * along, axis=1)
    on_seen = (tq >= lo - seen_len) & (tq <= hi + seen_len)
    keep = (
        on_seen
        & (member.sum(axis=1) >= min_points)
        & (places >= min_places)
        & (np.sum(q * normal, axis=1) >= np.cos(raw.half_beam[query]))
    )
    anchor_xy = np.column_stack((mean(raw.robot_xy[:, 0], member),
                                 mean(raw.robot_xy[:, 1], member)))  # fmt: skip
    return LineMatches(query[keep], np.column_stack((ex, ey))[keep], normal[keep],
                       mean(raw.u, member)[keep], anchor_xy[keep])  # fmt: skip

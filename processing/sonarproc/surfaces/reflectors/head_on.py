"""A plane's head-on echoes among a point reflector's readings: left to the plane.

A plane heard at normal incidence answers from the foot of the perpendicular, which moves
with the sensor: sensors pointing one way from one pass parallel to the plane (at one
depth along their axis) all read one range. A point reflector's range is the sensor's
distance to it, ``sqrt(d**2 + e**2)`` at a distance ``e`` across the axis, which grows as
the robot passes it: it holds one range (within :data:`RANGE_TOL_M`) only while
``e < sqrt(2 d RANGE_TOL_M)`` (:func:`hold_length_m`).

A point gathers the readings within :data:`RANGE_TOL_M` of its range, so near a plane it
gathers the plane's head-on readings of that stretch round its foot. Those alone seldom
tell the two apart (a stretch shorter than a point holds one range over); the pass does:
the plane's readings run on past them at the same range while the point's would change.
:func:`head_on_echoes` takes each group of the point's readings of one heading and one
pass and follows the pass through every reading of the log: the *run* is the unbroken
stretch of that heading's readings on that pass whose ranges are within
:data:`RANGE_TOL_M` of the group's. The run is a plane's when over it the point says the
range changes by more than :data:`RANGE_TOL_M` (so that the two differ) and one constant
range fits it at least as well as the point does. Then:

* a run that goes on past the point's foot on both sides by more than the hold length
  runs through the point: the plane goes on where the point is said to be, and every
  reading of the group is the plane's (a "point" on a wall's middle, made of its head-on
  echoes and a few others, goes with them);
* a run on one side of the foot ends at the point (a corner or an edge at the plane's
  end): past the foot the readings heard the point; within the hold length short of it
  the point is heard at the plane's range too, and the two do not differ; only the
  readings farther along the plane are the plane's alone (a corner fitted off its place,
  pulled along the wall by them, gathered those).

A point that leaves them leaves them to the plane
(:func:`sonarproc.surfaces.reflectors.rcd.point_feature`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_TOL_M,
    distinct_poses,
    pose_keys,
)

__all__ = [
    "HEADING_BIN_RAD",
    "MIN_HEAD_ON_POSES",
    "head_on_echoes",
    "head_on_split",
    "hold_length_m",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Readings whose headings fall in one bin this wide (rad) are taken to point one way: a
#: plane's range does not depend on the heading while its normal is in the beam, and a
#: 1 degree error in the pass's direction changes the sensors' depth by under 2 cm per
#: metre along it, within :data:`RANGE_TOL_M` over the half metre a short wall is heard.
HEADING_BIN_RAD = math.radians(1.0)
#: Fewest distinct sensor positions of one heading and pass to call their readings a
#: plane's: the plane's range is one unknown, and three positions leave two to test it on.
MIN_HEAD_ON_POSES = 3
_FULL_TURN_BINS = round(2 * np.pi / HEADING_BIN_RAD)


def hold_length_m(range_m: float) -> float:
    """Length (m) of a pass over which a point at ``range_m`` holds one range.

    From the foot of the point on the pass, its range ``sqrt(r**2 + e**2)`` stays within
    :data:`RANGE_TOL_M` of ``r`` while ``e < sqrt(2 r RANGE_TOL_M)``. Readings closer than
    that along a pass would have seen a point's range change between them, so a run
    without a longer gap is one plane's; and a plane's end (a corner, an edge) is heard at
    the plane's range that far past it.

    >>> round(hold_length_m(1.5), 3)
    0.3
    """
    return math.sqrt(2.0 * range_m * RANGE_TOL_M)


def _bins(heading: FloatArray) -> npt.NDArray[np.int64]:
    """Heading bin of each reading (:data:`HEADING_BIN_RAD`), 0 .. 359."""
    b = np.round(np.mod(heading, 2 * np.pi) / HEADING_BIN_RAD).astype(np.int64)
    b[b == _FULL_TURN_BINS] = 0
    return b


def _run(
    echoes: EchoGeometry, u: FloatArray, b: int, cell: int, r0: float, mine: IntArray
) -> IntArray:
    """The readings of the log in the unbroken run (module notes) through ``mine``.

    ``u``, ``b`` and ``cell``: the heading (unit vector), its bin and the depth cell of the
    pass; ``r0``: the group's range; ``mine``: the group's readings (into ``echoes``).
    """
    a = b * HEADING_BIN_RAD
    # a cheap screen first (heading within a whole bin of the bin's centre, by a dot
    # product: the bin reaches half that far), then exact
    c, s = echoes.axes
    rows = np.flatnonzero(c * math.cos(a) + s * math.sin(a) >= math.cos(HEADING_BIN_RAD))
    rows = rows[_bins(echoes.heading[rows]) == b]
    rows = rows[np.floor(echoes.xy[rows] @ u / RANGE_TOL_M).astype(np.int64) == cell]
    across = echoes.xy[rows] @ np.array([-u[1], u[0]])
    order = np.argsort(across, kind="stable")
    rows, across = rows[order], across[order]
    # the run is broken by a reading of another range, or by a gap a point could hide in
    same = np.abs(echoes.range_m[rows] - r0) <= RANGE_TOL_M
    gap = np.r_[np.inf, np.diff(across)] > hold_length_m(r0)
    stretch = np.cumsum(~same | gap | np.r_[True, ~same[:-1]])
    keep = same & np.isin(stretch, stretch[same & np.isin(rows, mine)])
    return rows[keep]


def head_on_echoes(echoes: EchoGeometry, idx: IntArray, p: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Which of a point's readings are a plane's head-on echoes (module notes).

    The first of :func:`head_on_split`'s masks.

    Parameters
    ----------
    echoes : EchoGeometry
        Every reading of the log (a pass is followed through all of them).
    idx : ndarray of int
        The point's readings (indices into ``echoes``).
    p : array_like, shape (2,)
        The point fitted through them (m).

    Returns
    -------
    ndarray of bool, shape (len(idx),)
        True for the readings to leave to the plane.

    Examples
    --------
    A wall at y = -1 heard head on from three passes, x = 1.0 .. 4.0; a point fitted at
    (2.5, -1), in the middle of it, gathered the readings near its foot:

    >>> x = np.tile(np.linspace(1.0, 4.0, 31), 3)
    >>> y = np.repeat([1.0, 2.0, 3.0], 31)
    >>> g = EchoGeometry(np.c_[x, y], np.full(93, -np.pi / 2), np.full(93, 0.2), y + 1.0)
    >>> near = np.flatnonzero(np.abs(x - 2.5) < 0.25)
    >>> bool(head_on_echoes(g, near, [2.5, -1.0]).all())
    True

    At the wall's end (4.0, -1) only the readings farther along the wall than the point
    holds one range over (:func:`hold_length_m`) are the wall's alone:

    >>> near = np.flatnonzero(x > 3.3)
    >>> far = head_on_echoes(g, near, [4.0, -1.0])
    >>> bool(np.all(far == (4.0 - x[near] > np.sqrt(2 * (y[near] + 1.0) * RANGE_TOL_M))))
    True

    A point's own echoes, whose range grows along the pass, stay with it:

    >>> g = EchoGeometry(g.xy, g.heading, g.half_beam, np.hypot(x - 4.0, y + 1.0))
    >>> bool(head_on_echoes(g, near, [4.0, -1.0]).any())
    False
    """
    return head_on_split(echoes, idx, p)[0]


def head_on_split(
    echoes: EchoGeometry, idx: IntArray, p: npt.ArrayLike
) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """A point's readings that are a plane's head-on echoes, and those no range tells apart.

    Parameters
    ----------
    echoes : EchoGeometry
        Every reading of the log.
    idx : ndarray of int
        The point's readings (indices into ``echoes``).
    p : array_like, shape (2,)
        The point fitted through them (m).

    Returns
    -------
    plane, level : ndarray of bool, shape (len(idx),)
        ``plane``: the readings to leave to the plane (:func:`head_on_echoes`).
        ``level``: the readings of a run of one heading and pass (module notes) over
        which the point's range changes by :data:`RANGE_TOL_M` or less while one
        constant range fits them at least as well as the point: a plane facing the pass
        explains them as well as the point does, so they are no evidence for the point,
        which must be made by readings such a plane cannot return (far off, a point on a
        wall's middle holds the wall's range over the whole stretch a pass hears).
    """
    p = np.asarray(p, dtype=np.float64)
    idx = np.asarray(idx, dtype=np.intp)
    out = np.zeros(idx.size, dtype=bool)
    level = np.zeros(idx.size, dtype=bool)
    xy, rng = echoes.xy[idx], echoes.range_m[idx]
    bins = _bins(echoes.heading[idx])
    u = np.column_stack((np.cos(bins * HEADING_BIN_RAD), np.sin(bins * HEADING_BIN_RAD)))
    # one pass parallel to a plane facing the sensors: one depth along their axis (the
    # range tolerance's cells, as for distinct poses)
    depth = np.floor(np.einsum("ij,ij->i", xy, u) / RANGE_TOL_M).astype(np.int64)
    _, group = np.unique(np.column_stack((bins, depth)), axis=0, return_inverse=True)
    group = group.ravel()
    # the distinct poses of every group at once (its distinct pose cells, by one sort):
    # only the groups with enough are followed
    pose = pose_keys(xy)
    order = np.lexsort((pose, group))
    g_sorted, pose = group[order], pose[order]
    first = np.ones(group.size, dtype=bool)
    first[1:] = (g_sorted[1:] != g_sorted[:-1]) | (pose[1:] != pose[:-1])
    poses = np.bincount(g_sorted[first], minlength=int(group.max(initial=-1)) + 1)
    for g in np.flatnonzero(poses >= MIN_HEAD_ON_POSES):
        k = np.flatnonzero(group == g)
        r0 = float(np.median(rng[k]))
        run = _run(echoes, u[k[0]], int(bins[k[0]]), int(depth[k[0]]), r0, idx[k])
        if distinct_poses(echoes.xy[run]) < MIN_HEAD_ON_POSES:
            continue
        dist = np.hypot(echoes.xy[run, 0] - p[0], echoes.xy[run, 1] - p[1])
        r = echoes.range_m[run]
        if float(np.std(r)) > float(np.sqrt(np.mean((dist - r) ** 2))):
            continue
        # the point must say the range changes along the run, or the two do not differ
        # (and then the run is no evidence for the point either)
        if float(np.ptp(dist)) <= RANGE_TOL_M:
            level[k[np.isin(idx[k], run)]] = True
            continue
        # where along the plane, from the point's foot: the run's feet and the group's
        n = np.array([-u[k[0], 1], u[k[0], 0]])
        foot = float(p @ n)
        feet = echoes.xy[run] @ n - foot
        mine = k[np.isin(idx[k], run)]
        hold = hold_length_m(r0)
        if not (feet.min() < -hold and feet.max() > hold):
            # the plane ends at the point: past its foot the readings heard the point, and
            # within the hold length short of it the two ranges do not differ (the point
            # at the plane's end is heard there too): only those farther on are the plane's
            side = np.sign(np.median(feet))
            mine = mine[(xy[mine] @ n - foot) * side > hold]
        out[mine] = True
    return out, level

"""A plane's head-on echoes among a point reflector's readings: left to the plane.

A plane heard at normal incidence answers from the foot of the perpendicular, which moves
with the sensor: sensors pointing one way from one pass parallel to the plane (at one
depth along their axis) all read one range. A point reflector's range is the sensor's
distance to it, ``sqrt(d**2 + e**2)`` at a distance ``e`` across the axis, which grows as
the robot passes it.

Near the end of a short wall (an alcove's back wall, a recess's) a corner's arcs cross
the wall's head-on readings within the range tolerance, so a corner found there gathers
them: the wall loses them and is never fitted, and the corner is pulled towards them.
:func:`head_on_echoes` finds them: the readings of one heading and one pass whose ranges
are one range at least as well as the point explains them, where the point says the
range changes along the pass (by more than :data:`RANGE_TOL_M`, so that the two differ)
and the pass is longer than a point holds one range over (``sqrt(2 r RANGE_TOL_M)``).
A point that leaves them leaves them to the plane: no other point takes them
(:func:`sonarproc.surfaces.reflectors.rcd.find_point_features`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M, distinct_poses

__all__ = ["HEADING_BIN_RAD", "MIN_HEAD_ON_POSES", "head_on_echoes"]

FloatArray = npt.NDArray[np.float64]

#: Readings whose headings fall in one bin this wide (rad) are taken to point one way: a
#: plane's range does not depend on the heading while its normal is in the beam, and a
#: 1 degree error in the pass's direction changes the sensors' depth by under 2 cm per
#: metre along it, within :data:`RANGE_TOL_M` over the half metre a short wall is heard.
HEADING_BIN_RAD = math.radians(1.0)
#: Fewest distinct sensor positions of one heading and pass to call their readings a
#: plane's: the plane's range is one unknown, and three positions leave two to test it on.
MIN_HEAD_ON_POSES = 3


def head_on_echoes(
    xy: FloatArray, heading: FloatArray, rng: FloatArray, p: npt.ArrayLike
) -> npt.NDArray[np.bool_]:
    """Which of a point's readings a plane facing their sensors explains (module notes).

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        The readings' sensor positions (m).
    heading : ndarray, shape (N,)
        Their beam axes' headings (rad).
    rng : ndarray, shape (N,)
        Their ranges (m).
    p : array_like, shape (2,)
        The point fitted through them (m).

    Returns
    -------
    ndarray of bool, shape (N,)
        True for the head-on echoes of a plane.

    Examples
    --------
    A wall at y = -1 heard head on from three passes, a point at its end (4.5, -1):

    >>> x = np.tile(np.linspace(3.9, 4.4, 6), 3)  # each pass one range, the point's grows
    >>> y = np.repeat([1.0, 2.0, 3.0], 6)
    >>> mask = head_on_echoes(np.c_[x, y], np.full(18, -np.pi / 2), y + 1.0, [4.5, -1.0])
    >>> bool(mask.all())
    True
    >>> r = np.hypot(x - 4.5, y + 1.0)  # the point's own echoes stay with it
    >>> bool(head_on_echoes(np.c_[x, y], np.full(18, -np.pi / 2), r, [4.5, -1.0]).any())
    False
    """
    p = np.asarray(p, dtype=np.float64)
    out = np.zeros(rng.size, dtype=bool)
    dist = np.hypot(xy[:, 0] - p[0], xy[:, 1] - p[1])
    bins = np.round(np.mod(heading, 2 * np.pi) / HEADING_BIN_RAD).astype(np.int64)
    bins[bins == round(2 * np.pi / HEADING_BIN_RAD)] = 0
    u = np.column_stack((np.cos(bins * HEADING_BIN_RAD), np.sin(bins * HEADING_BIN_RAD)))
    # one pass parallel to a plane facing the sensors: one depth along their axis (the
    # range tolerance's cells, as for distinct poses)
    depth = np.floor(np.einsum("ij,ij->i", xy, u) / RANGE_TOL_M).astype(np.int64)
    _, group = np.unique(np.column_stack((bins, depth)), axis=0, return_inverse=True)
    for g in np.unique(group.ravel()):
        k = np.flatnonzero(group.ravel() == g)
        if distinct_poses(xy[k]) < MIN_HEAD_ON_POSES:
            continue
        # the point must say the range changes along the pass, or the two do not differ
        if float(np.ptp(dist[k])) <= RANGE_TOL_M:
            continue
        # and the pass must be longer than a point holds one range over, sqrt(2 r tol)
        across = xy[k] @ np.array([-u[k[0], 1], u[k[0], 0]])
        if float(np.ptp(across)) < math.sqrt(2.0 * float(rng[k].min()) * RANGE_TOL_M):
            continue
        plane = float(np.std(rng[k]))
        point = float(np.sqrt(np.mean((dist[k] - rng[k]) ** 2)))
        if plane <= point:
            out[k] = True
    return out

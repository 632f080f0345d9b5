"""Where a point lies with respect to a straight wall: at its end, or inside it.

A point reflector is where a wall ends (a corner where two walls meet, an edge where a
wall or a box face stops). A point well inside a fitted wall, away from both of its
ends, is that wall's own echo: a wall that scatters diffusely answers from every point
of it, each seen from many poses at its own distance, like a point.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.reflectors.rcd import RANGE_TOL_M

__all__ = ["END_REACH_M", "LINE_REACH_M", "inside_walls", "near_ends"]

FloatArray = npt.NDArray[np.float64]

#: A wall ends at a point when its nearer end lies within this (m) of it: a wall refitted
#: through its echo points stops where the last perpendicular from a sensor met it, up to
#: a beam footprint short of the corner (a quarter of a 2 m range's 0.9 m footprint).
END_REACH_M = 0.25
#: ... and the point lies within this (m) of the wall's line: twice the ranges' tolerance.
LINE_REACH_M = 2 * RANGE_TOL_M


def inside_walls(
    xy: npt.ArrayLike, walls: list[tuple[FloatArray, FloatArray]]
) -> npt.NDArray[np.bool_]:
    """Which points lie inside a wall: on its line, more than :data:`END_REACH_M` from its ends.

    Parameters
    ----------
    xy : array_like, shape (N, 2)
        Points (m).
    walls : list of (ndarray, ndarray)
        Each wall's two ends (m).

    Returns
    -------
    ndarray of bool, shape (N,)

    Examples
    --------
    >>> wall = (np.array([0.0, 0.0]), np.array([4.0, 0.0]))
    >>> inside_walls([[2.0, 0.01], [0.1, 0.0], [2.0, 0.5]], [wall]).tolist()
    [True, False, False]
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(p.shape[0], dtype=bool)
    for a, b in walls:
        v = b - a
        length = float(np.hypot(v[0], v[1]))
        if length <= 2 * END_REACH_M:
            continue
        u = v / length
        d = p - a
        along = d @ u
        across = np.abs(d[:, 0] * u[1] - d[:, 1] * u[0])
        out |= (across <= LINE_REACH_M) & (along > END_REACH_M) & (along < length - END_REACH_M)
    return out


def near_ends(
    xy: npt.ArrayLike, walls: list[tuple[FloatArray, FloatArray]]
) -> npt.NDArray[np.bool_]:
    """Which points lie within :data:`END_REACH_M` of a wall's end.

    Examples
    --------
    >>> wall = (np.array([0.0, 0.0]), np.array([4.0, 0.0]))
    >>> near_ends([[2.0, 0.0], [-0.1, 0.1], [4.2, 0.0]], [wall]).tolist()
    [False, True, True]
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if not walls:
        return np.zeros(p.shape[0], dtype=bool)
    ends = np.array([e for w in walls for e in w], dtype=np.float64).reshape(-1, 2)
    d = np.hypot(p[:, None, 0] - ends[None, :, 0], p[:, None, 1] - ends[None, :, 1])
    return np.asarray(d.min(axis=1) <= END_REACH_M)

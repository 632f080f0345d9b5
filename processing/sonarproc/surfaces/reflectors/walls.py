"""Where a point lies with respect to a straight wall: at its end, or inside it.

A point reflector is where a wall ends (a corner where two walls meet, an edge where a
wall or a box face stops). A point well inside a fitted wall, away from both of its
ends, is that wall's own echo: a wall that scatters diffusely answers from every point
of it, each seen from many poses at its own distance, like a point.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M

__all__ = [
    "CHAIN_GAP_M",
    "END_REACH_M",
    "LINE_REACH_M",
    "WALL_GAP_M",
    "in_rows",
    "inside_walls",
    "near_ends",
    "on_wall_lines",
    "side_of_line",
]

FloatArray = npt.NDArray[np.float64]

#: A wall ends at a point when its nearer end lies within this (m) of it: a wall refitted
#: through its echo points stops where the last perpendicular from a sensor met it, up to
#: a beam footprint short of the corner (a quarter of a 2 m range's 0.9 m footprint).
END_REACH_M = 0.25
#: ... and the point lies within this (m) of the wall's line: the ranges' tolerance (both
#: the wall and the point are fitted to ranges within it).
LINE_REACH_M = RANGE_TOL_M
#: A wall refitted through its echo points stops where the last perpendicular from a
#: sensor met it, which may be metres short of the corner it runs into (the robot never
#: faced that stretch), while the corner retro-reflects from anywhere inside its opening.
#: A point reflector up to this far (m) beyond a wall's end along its line, a Polaroid
#: sonar's reach for a corner (about 5 m at the usual detection threshold), is where the
#: wall ends.
WALL_GAP_M = 5.0
#: Points closer than this (m) along one line are samples of one surface: a sonar cannot
#: resolve reflectors closer together than its beam's footprint (2 r tan 12.5 deg, 0.45 m
#: at 1 m).
CHAIN_GAP_M = 0.45


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


def in_rows(xy: npt.ArrayLike) -> npt.NDArray[np.bool_]:
    """Which points lie in a row of three or more on one line, each within :data:`CHAIN_GAP_M`.

    Three points are in a row when two of them lie within :data:`CHAIN_GAP_M` of the third
    and every one within :data:`LINE_REACH_M` of the line through the other two: the
    samples of one diffusely scattering surface, not separate point reflectors.

    Examples
    --------
    >>> in_rows([[0.0, 0.0], [0.2, 0.01], [0.4, 0.0], [2.0, 2.0]]).tolist()
    [True, True, True, False]
    >>> in_rows([[0.0, 0.0], [0.3, 0.0], [0.3, 0.3]]).tolist()   # a box's corners
    [False, False, False]
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(p.shape[0], dtype=bool)
    for i in range(p.shape[0]):
        d = np.hypot(*(p - p[i]).T)
        near = np.flatnonzero((d > 0) & (d <= CHAIN_GAP_M))
        for a_pos, j in enumerate(near):
            for k in near[a_pos + 1 :]:
                v = p[k] - p[j]
                length = float(np.hypot(v[0], v[1]))
                if length <= 0:
                    continue
                w = p[i] - p[j]
                if abs(float(v[0] * w[1] - v[1] * w[0])) / length <= LINE_REACH_M:
                    out[[i, j, k]] = True
    return out


def on_wall_lines(
    xy: npt.ArrayLike, walls: list[tuple[FloatArray, FloatArray]]
) -> npt.NDArray[np.bool_]:
    """Which points lie on a wall's line near an end: up to :data:`WALL_GAP_M` past it.

    (From :data:`END_REACH_M` inside the wall, or half its length if shorter.)

    Examples
    --------
    >>> wall = (np.array([0.0, 0.0]), np.array([4.0, 0.0]))
    >>> on_wall_lines([[4.8, 0.02], [2.0, 0.0], [4.5, 0.3], [-0.1, 0.0]], [wall]).tolist()
    [True, False, False, True]
    """
    p = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(p.shape[0], dtype=bool)
    for a, b in walls:
        v = b - a
        length = float(np.hypot(v[0], v[1]))
        if length <= 0:
            continue
        u = v / length
        d = p - a
        along = d @ u
        across = np.abs(d[:, 0] * u[1] - d[:, 1] * u[0])
        near_a = (along >= -WALL_GAP_M) & (along <= min(END_REACH_M, 0.5 * length))
        near_b = (along <= length + WALL_GAP_M) & (along >= max(length - END_REACH_M, 0.5 * length))
        out |= (across <= LINE_REACH_M) & (near_a | near_b)
    return out


def side_of_line(a: FloatArray, b: FloatArray, q: FloatArray) -> FloatArray:
    """Signed side of points ``q`` (N, 2) of the line through ``a`` and ``b``.

    Positive to the left of ``a -> b``; the value is the distance off the line times the
    length of ``b - a``.

    Examples
    --------
    >>> a, b = np.array([0.0, 0.0]), np.array([2.0, 0.0])
    >>> side_of_line(a, b, np.array([[1.0, 0.5], [1.0, -0.5]])).tolist()
    [1.0, -1.0]
    """
    u = b - a
    return np.asarray(u[0] * (q[..., 1] - a[1]) - u[1] * (q[..., 0] - a[0]), dtype=np.float64)

"""Where range arcs cross a line, and the places along it that gather the most.

:mod:`~sonarproc.surfaces.reflectors.line_corners` looks along each fitted wall's line for
the place that the most unexplained readings pass through: every reading's arc (its
sensor, its range) meets the line at up to two places (:func:`arc_crossings`), each
counted over its reach along the line (the range tolerance over the cosine of the sight
line's angle to the line) at evenly spaced places (:func:`crossing_counts`), and the
places that gather no fewer than every place within the candidate spacing of them are
the candidates (:func:`local_peaks`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.gathering import BEAM_SLACK, CANDIDATE_SPACING_M
from sonarproc.surfaces.reflectors.point_echoes import CORNER_TOL_RAD
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M

__all__ = ["arc_crossings", "crossing_counts", "local_peaks"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def arc_crossings(
    pool: EchoGeometry, a: FloatArray, u: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Where the arcs of readings ``pool`` cross the line ``a + t u``, and how far round.

    A reading's circle (its sensor, its range) meets the line at up to two places; those
    inside its beam (widened by :data:`BEAM_SLACK`) count. A reading passes within the
    range tolerance of a place within that tolerance over the cosine ``c`` of its sight
    line's angle to the line of the crossing. Sight lines within :data:`CORNER_TOL_RAD` of
    square to the line do not count: such readings face the wall's line head on, where a
    plane along the line explains them (the plane test of
    :mod:`~sonarproc.surfaces.reflectors.line_corners`), and their tolerance along the
    line would be unbounded.

    Parameters
    ----------
    pool : EchoGeometry
        The readings (sensor positions, headings, half beams, ranges).
    a, u : ndarray, shape (2,)
        A point of the line and its unit direction.

    Returns
    -------
    t, reach : ndarray
        Each counted crossing's place (m along the line from ``a``) and its reach along
        the line (m). Both ends of a line are searched with the same crossings
        (:func:`crossing_counts`).

    Examples
    --------
    A sensor 1 m below the line y = 0 looking up hears it 1 m off: its arc touches the
    line square at x = 0, which does not count; at 1.2 m its arc crosses the line inside
    a 40 degree half beam at x = -0.66 and x = 0.66.

    >>> g = EchoGeometry(np.array([[0.0, -1.0]]), np.array([np.pi / 2]),
    ...                  np.array([np.radians(40.0)]), np.array([1.2]))
    >>> t, reach = arc_crossings(g, np.zeros(2), np.array([1.0, 0.0]))
    >>> np.round(t, 2).tolist()
    [-0.66, 0.66]
    """
    d = pool.xy - a
    along = d @ u
    off = d[:, 0] * u[1] - d[:, 1] * u[0]
    rng = pool.range_m
    reach = np.flatnonzero(np.abs(off) <= rng + RANGE_TOL_M)
    half = np.sqrt(np.maximum(rng[reach] ** 2 - off[reach] ** 2, 0.0))
    tc = np.concatenate((along[reach] - half, along[reach] + half))
    rows = np.concatenate((reach, reach))
    v = a + tc[:, None] * u - pool.xy[rows]
    bearing = np.arctan2(v[:, 1], v[:, 0]) - pool.heading[rows]
    off_axis = np.abs((bearing + np.pi) % (2 * np.pi) - np.pi)
    c = np.abs(v @ u) / np.maximum(pool.range_m[rows], 1e-9)
    ok = (off_axis <= BEAM_SLACK * pool.half_beam[rows]) & (c > math.sin(CORNER_TOL_RAD))
    return tc[ok], RANGE_TOL_M / c[ok]


def crossing_counts(crossings: tuple[FloatArray, FloatArray], t: FloatArray) -> IntArray:
    """How many arcs pass near each place along a line.

    Parameters
    ----------
    crossings : tuple of ndarray
        The arcs' crossings of the line and their reaches (:func:`arc_crossings`).
    t : ndarray
        The places (m along the line), evenly spaced and ascending.

    Returns
    -------
    ndarray of int
        For each place, the crossings that reach it.

    Examples
    --------
    >>> crossing_counts((np.array([0.1, 0.12]), np.array([0.02, 0.05])),
    ...                 np.arange(0.0, 0.25, 0.05)).tolist()
    [0, 0, 2, 1, 0]
    """
    tc, width = crossings
    step = float(t[1] - t[0]) if t.size > 1 else 1.0
    lo = np.clip(np.ceil((tc - width - t[0]) / step), 0, t.size).astype(np.intp)
    hi = np.clip(np.floor((tc + width - t[0]) / step) + 1, 0, t.size).astype(np.intp)
    # each crossing adds one from its first place to its last (a difference array)
    diff = np.bincount(lo, minlength=t.size + 1) - np.bincount(hi, minlength=t.size + 1)
    return np.asarray(np.cumsum(diff)[:-1], dtype=np.intp)


def local_peaks(t: FloatArray, sizes: IntArray) -> npt.NDArray[np.bool_]:
    """Which places along a line gather no fewer readings than every place near them.

    Parameters
    ----------
    t : ndarray
        The places (m along a line), ascending.
    sizes : ndarray of int
        The readings each place gathers.

    Returns
    -------
    ndarray of bool
        Whether each place gathers no fewer than every place within
        :data:`CANDIDATE_SPACING_M` of it.
    """
    if t.size == 0:
        return np.zeros(0, dtype=bool)
    lo = np.searchsorted(t, t - CANDIDATE_SPACING_M)
    hi = np.searchsorted(t, t + CANDIDATE_SPACING_M, "right")
    # the most of each window [lo, hi) (never empty: it holds its own place); a last
    # element past the end lets a window end there
    best = np.maximum.reduceat(np.r_[sizes, 0], np.column_stack((lo, hi)).ravel())[::2]
    return np.asarray(sizes >= best.astype(sizes.dtype))

"""Straight surfaces: the one total least squares line fit, for many groups at once.

:func:`fit_lines` fits every group of points together (each group a run of consecutive
points; see :mod:`sonarproc.surfaces.fitting.grouped`): the principal axis of the group's
scatter matrix (``theta = atan2(2 Sxy, Sxx - Syy) / 2``), refitted once without the points
further than ``max(3 rms, 2 cells)`` from it (the corner cells of a neighbour), oriented
from the group's first point towards its last, spanning all its points' projections.
:func:`fit_line` is its one-group case, as a :class:`~sonarproc.surfaces.fitting.models.Candidate`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.grouped import group_labels, trimmed
from sonarproc.surfaces.fitting.models import Candidate, SurfaceFailure
from sonarproc.surfaces.planar.polylines import resample

__all__ = ["GroupedLines", "fit_line", "fit_lines", "line_candidate", "line_params"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]


class GroupedLines:
    """Total least squares lines of many groups (see the module notes).

    Attributes
    ----------
    point : ndarray, shape (G, 2)
        A point of each line (the mean of the points it was last fitted to).
    direction : ndarray, shape (G, 2)
        Unit direction, oriented from the group's first point towards its last (a group
        whose ends project alike keeps the direction of positive x).
    lo, hi : ndarray, shape (G,)
        Extent of the points' projections along ``direction`` from ``point`` (m).
    rms : ndarray, shape (G,)
        RMS orthogonal distance of all the group's points to the line (m).
    ok : ndarray of bool, shape (G,)
        False for a group whose points all lie at one place.
    """

    def __init__(
        self,
        point: FloatArray,
        direction: FloatArray,
        lo: FloatArray,
        hi: FloatArray,
        rms: FloatArray,
        ok: BoolArray,
    ) -> None:
        self.point, self.direction, self.lo, self.hi = point, direction, lo, hi
        self.rms, self.ok = rms, ok


def _principal_axes(
    x: FloatArray, y: FloatArray, gid: IntArray, weight: FloatArray, g: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mean point, principal direction (x >= 0) and scatter of each group."""
    n = np.maximum(np.bincount(gid, weights=weight, minlength=g), 1.0)
    mx = np.bincount(gid, weights=x * weight, minlength=g) / n
    my = np.bincount(gid, weights=y * weight, minlength=g) / n
    dx, dy = x - mx[gid], y - my[gid]
    sxx = np.bincount(gid, weights=dx * dx * weight, minlength=g)
    sxy = np.bincount(gid, weights=dx * dy * weight, minlength=g)
    syy = np.bincount(gid, weights=dy * dy * weight, minlength=g)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    direction = np.stack((np.cos(theta), np.sin(theta)), axis=1)
    return np.stack((mx, my), axis=1), np.asarray(direction), np.asarray(sxx + syy)


def fit_lines(x: FloatArray, y: FloatArray, sizes: IntArray, *, cell: float) -> GroupedLines:
    """Fit one trimmed total least squares line to each group of consecutive points.

    Parameters
    ----------
    x, y : ndarray, shape (P,)
        The groups' points one after the other, each group in its order along its surface.
    sizes : ndarray of int, shape (G,)
        Points per group (each at least 1).
    cell : float
        Cell size (m): the trim's floor.

    Returns
    -------
    GroupedLines

    Examples
    --------
    >>> x = np.r_[np.arange(0.0, 1.0, 0.01), np.zeros(50)]
    >>> y = np.r_[np.full(100, 2.0), np.arange(0.5, 0.0, -0.01)]
    >>> lines = fit_lines(x, y, np.array([100, 50]), cell=0.01)
    >>> np.round(lines.direction, 6).tolist(), np.round(lines.hi - lines.lo, 3).tolist()
    ([[1.0, 0.0], [-0.0, -1.0]], [0.99, 0.49])
    """
    sizes = np.asarray(sizes, dtype=np.intp)
    g = int(sizes.size)
    gid, starts = group_labels(sizes)
    point, t, spread = _principal_axes(x, y, gid, np.ones_like(x), g)
    resid = (x - point[gid, 0]) * -t[gid, 1] + (y - point[gid, 1]) * t[gid, 0]
    keep = trimmed(resid, gid, sizes, cell).astype(np.float64)
    point2, t2, spread2 = _principal_axes(x, y, gid, keep, g)
    again = (np.bincount(gid, weights=keep, minlength=g) >= 2) & (spread2 > 0)
    point[again], t[again] = point2[again], t2[again]
    u = (x - point[gid, 0]) * t[gid, 0] + (y - point[gid, 1]) * t[gid, 1]
    flip = u[starts + sizes - 1] < u[starts]
    t[flip] = -t[flip]
    u = np.where(flip[gid], -u, u)
    lo = np.minimum.reduceat(u, starts) if g else np.zeros(0)
    hi = np.maximum.reduceat(u, starts) if g else np.zeros(0)
    resid = (x - point[gid, 0]) * -t[gid, 1] + (y - point[gid, 1]) * t[gid, 0]
    rms = np.sqrt(np.bincount(gid, weights=resid * resid, minlength=g) / np.maximum(sizes, 1))
    return GroupedLines(point, t, lo, hi, rms, np.asarray(spread > 0))


def line_candidate(
    point: FloatArray, direction: FloatArray, lo: float, hi: float, rms: float, cell: float
) -> Candidate:
    """The line segment ``point + u direction`` for ``lo <= u <= hi``, sampled every cell."""
    poly = resample(np.stack((point + direction * lo, point + direction * hi)), cell)
    return Candidate("line", poly, rms, line_params(point, direction))


def line_params(point: FloatArray, direction: FloatArray) -> dict[str, Any]:
    """A line's parameters as :class:`Candidate` and ``report.json`` hold them."""
    return {"point": point.tolist(), "direction": direction.tolist()}


def fit_line(cells: SurfaceCells, *, cell: float) -> Candidate | SurfaceFailure:
    """Total least squares line segment through the cells (one trimmed refit).

    See :func:`fit_lines` (this is its one-group case).
    """
    if cells.size < 2:
        return SurfaceFailure(f"line: {cells.size} cells, need at least 2", cells.size)
    got = fit_lines(cells.x, cells.y, np.array([cells.size]), cell=cell)
    if not got.ok[0]:
        return SurfaceFailure("line: all cells at one point", cells.size)
    lo, hi, rms = float(got.lo[0]), float(got.hi[0]), float(got.rms[0])
    return line_candidate(got.point[0], got.direction[0], lo, hi, rms, cell)

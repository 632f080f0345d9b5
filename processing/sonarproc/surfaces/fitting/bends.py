"""A surface the spline won that is two straight walls meeting at a corner: its two lines.

The model criterion (:mod:`sonarproc.surfaces.fitting.models`) weighs one line, one arc
and one spline against the points of one surface. Two straight walls meeting at an
obtuse corner (a 135-degree cut corner, a corridor's bend) turn by less than the ridge's
corner test splits at, so their echo points arrive as one surface: no line fits them,
no arc bends like them, and the spline wins by rounding the corner, which puts a curve
where there are two planes and a corner.

A wall of two straight pieces is two lines by the same evidence that makes a straight
wall one line: :func:`straight_pieces` splits the points, in their order along the
surface, where two total least squares lines leave the least squared residual, and
keeps the split when the criterion picks the line for both pieces
(:func:`~sonarproc.surfaces.fitting.batch.fit_surfaces`, same floor and noise).
Otherwise the surface stays what the criterion chose. One split only, not a chain: a
curved wall that no arc fits (a parabola of 1 m radius at its apex, 3 m long) splits
into a handful of lines each straight within the range noise if the pieces are split
again and again, whereas half of it is never straight; a corner is one break, however
long the walls either side. A surface with two obtuse bends keeps its spline.

Each piece has at least :data:`MIN_PIECE_POINTS` points: with fewer, the points'
scatter does not set the piece's floor
(:data:`~sonarproc.surfaces.fitting.batch.MIN_SCATTER_POINTS`), and a handful of points
threaded by a line would say it is straight whatever the wall does.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import MIN_SCATTER_POINTS, fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFit

__all__ = ["MIN_PIECE_POINTS", "best_break", "points_subset", "straight_pieces"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Fewest points of a straight piece (see the module notes).
MIN_PIECE_POINTS = MIN_SCATTER_POINTS


def _tls_residual(sums: FloatArray) -> FloatArray:
    """Sum of squared orthogonal distances to the best line, from the sums
    ``(n, Sx, Sy, Sxx, Syy, Sxy)`` (rows) of each set of points (columns)."""
    n, sx, sy, sxx, syy, sxy = sums
    cxx = sxx - sx * sx / n
    cyy = syy - sy * sy / n
    cxy = sxy - sx * sy / n
    # the smaller eigenvalue of the scatter matrix
    return np.maximum(0.5 * (cxx + cyy) - np.hypot(0.5 * (cxx - cyy), cxy), 0.0)


def best_break(x: FloatArray, y: FloatArray, min_points: int = MIN_PIECE_POINTS) -> int | None:
    """Index splitting ordered points where two lines leave the least squared residual.

    Both sides keep at least ``min_points`` points; None when there are too few.

    Examples
    --------
    >>> x = np.r_[np.arange(0.0, 1.0, 0.05), 1.0 + np.arange(0.0, 1.0, 0.05)]
    >>> y = np.r_[np.zeros(20), np.arange(0.0, 1.0, 0.05)]
    >>> best_break(x, y)
    20
    """
    n = x.size
    if n < 2 * min_points:
        return None
    # centred, so that the sums' squares keep the centimetres of metres-away points
    u, v = x - x.mean(), y - y.mean()
    prefix = np.cumsum(np.stack((np.ones(n), u, v, u * u, v * v, u * v)), axis=1)
    cut = np.arange(min_points, n - min_points + 1)
    left = prefix[:, cut - 1]
    right = prefix[:, -1:] - left
    return int(cut[np.argmin(_tls_residual(left) + _tls_residual(right))])


def points_subset(points: SurfaceCells, idx: IntArray) -> SurfaceCells:
    """The points ``idx`` (in order) as an open surface of their own, arc length from 0."""
    s = points.s[idx]
    return SurfaceCells(points.x[idx], points.y[idx], s - s[0], points.weight[idx], False)


def straight_pieces(
    points: SurfaceCells, *, cell: float, scatter: float
) -> list[tuple[SurfaceFit, IntArray]] | None:
    """The two straight pieces of an open surface, or None if it is not two straight pieces.

    Parameters
    ----------
    points : SurfaceCells
        The surface's echo points, in order along it.
    cell : float
        Cell size (m), as for :func:`~sonarproc.surfaces.fitting.batch.fit_surfaces`.
    scatter : float
        The echo points' largest RMS range scatter (m), as there.

    Returns
    -------
    list of (SurfaceFit, ndarray of intp) or None
        Each piece's line and the indices of its points, in order along the surface;
        None when the points are too few to split or a piece is not straight.

    Examples
    --------
    Two walls meeting at 135 degrees, points every 2 cm:

    >>> a = np.arange(0.0, 1.5, 0.02)
    >>> x = np.r_[a, 1.5 + a / np.sqrt(2)]
    >>> y = np.r_[0 * a, a / np.sqrt(2)]
    >>> pts = SurfaceCells(x, y, np.arange(x.size) * 0.02, np.ones(x.size), False)
    >>> [(f.model, round(f.length_m, 2), i.size)
    ...  for f, i in straight_pieces(pts, cell=0.01, scatter=0.017)]
    [('line', 1.48, 75), ('line', 1.48, 75)]
    """
    if points.closed:
        return None
    cut = best_break(points.x, points.y)
    if cut is None:
        return None
    parts = [np.arange(cut, dtype=np.intp), np.arange(cut, points.size, dtype=np.intp)]
    subsets = [points_subset(points, p) for p in parts]
    out: list[tuple[SurfaceFit, IntArray]] = []
    for part, fit in zip(parts, fit_surfaces(subsets, cell=cell, scatter=scatter), strict=True):
        if not (isinstance(fit, SurfaceFit) and fit.model == "line"):
            return None
        out.append((fit, part))
    return out

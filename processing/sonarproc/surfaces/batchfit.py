"""Many surfaces fitted at once: the line test of every group in one pass of numpy.

A room's ridge breaks into about a thousand groups of cells, and the refinement fits
hundreds of echo sets; most of them are straight. :func:`fit_surfaces` gives, for a list
of groups, exactly what :func:`~sonarproc.surfaces.models.fit_surface` gives for each,
but it runs the line fit and the criterion's line test for all groups together with
grouped sums (``np.bincount`` over a group label per cell) instead of one SVD per group:

* the total least squares line is the principal axis of the group's scatter matrix,
  ``theta = atan2(2 Sxy, Sxx - Syy) / 2`` (the SVD's first right singular vector);
* it is refitted once without the cells further than ``max(3 rms, 2 cells)`` from it;
* it is oriented along the group's order, spans the projections of all its cells, and
  its RMS residual is the cells' RMS distance to it;
* the line is kept when that residual is at most ``1.25 floor + 0.25 cell``, the floor
  being the cells' RMS distance to their own means over 5-cell bins of arc length.

Only the groups whose line fails that test (an arc, a spline, a corner left in) and the
degenerate ones go through :func:`~sonarproc.surfaces.models.fit_surface` one by one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extract import SurfaceCells
from sonarproc.surfaces.models import (
    CELL_FACTOR,
    FLOOR_BIN_CELLS,
    MIN_CELLS,
    SPLINE_FACTOR,
    SurfaceFailure,
    SurfaceFit,
    fit_surface,
)
from sonarproc.surfaces.polylines import resample

__all__ = ["GroupedLines", "fit_lines", "fit_surfaces"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


class GroupedLines:
    """Total least squares lines of many groups of points (see the module notes).

    Attributes
    ----------
    point : ndarray, shape (G, 2)
        A point of each line (the mean of the cells it was last fitted to).
    direction : ndarray, shape (G, 2)
        Unit direction, oriented from the group's first cell towards its last.
    lo, hi : ndarray, shape (G,)
        Extent of the cells' projections along ``direction`` from ``point`` (m).
    rms : ndarray, shape (G,)
        RMS orthogonal distance of all the group's cells to the line (m).
    floor : ndarray, shape (G,)
        RMS distance of the cells to their means over 5-cell bins of arc length (m).
    """

    def __init__(
        self,
        point: FloatArray,
        direction: FloatArray,
        lo: FloatArray,
        hi: FloatArray,
        rms: FloatArray,
        floor: FloatArray,
    ) -> None:
        self.point, self.direction = point, direction
        self.lo, self.hi, self.rms, self.floor = lo, hi, rms, floor

    def accepted(self, cell: float) -> npt.NDArray[np.bool_]:
        """Groups whose line the criterion keeps (its residual near the floor)."""
        return np.asarray(self.rms <= SPLINE_FACTOR * self.floor + CELL_FACTOR * cell)


def _principal_axes(
    x: FloatArray, y: FloatArray, gid: IntArray, weight: FloatArray, g: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Mean point and principal direction of each group (cells weighted 0 or 1)."""
    n = np.bincount(gid, weights=weight, minlength=g)
    safe = np.maximum(n, 1.0)
    mx = np.bincount(gid, weights=x * weight, minlength=g) / safe
    my = np.bincount(gid, weights=y * weight, minlength=g) / safe
    dx, dy = x - mx[gid], y - my[gid]
    sxx = np.bincount(gid, weights=dx * dx * weight, minlength=g)
    sxy = np.bincount(gid, weights=dx * dy * weight, minlength=g)
    syy = np.bincount(gid, weights=dy * dy * weight, minlength=g)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    direction = np.stack((np.cos(theta), np.sin(theta)), axis=1)
    spread = np.asarray(sxx + syy, dtype=np.float64)
    return np.stack((mx, my), axis=1), np.asarray(direction, dtype=np.float64), spread


def fit_lines(
    x: FloatArray, y: FloatArray, s: FloatArray, sizes: IntArray, *, cell: float
) -> GroupedLines:
    """Fit one trimmed total least squares line to each group of consecutive points.

    Parameters
    ----------
    x, y, s : ndarray, shape (P,)
        The groups' cells one after the other, each group in its order along the surface,
        with its arc length ``s``.
    sizes : ndarray of int, shape (G,)
        Cells per group (each at least 2, not all at one point).
    cell : float
        Cell size (m): the trim's floor and the floor's bins.

    Returns
    -------
    GroupedLines

    Examples
    --------
    >>> x = np.r_[np.arange(0.0, 1.0, 0.01), np.zeros(50)]
    >>> y = np.r_[np.full(100, 2.0), np.arange(0.0, 0.5, 0.01)]
    >>> s = np.r_[np.arange(100) * 0.01, np.arange(50) * 0.01]
    >>> lines = fit_lines(x, y, s, np.array([100, 50]), cell=0.01)
    >>> np.round(lines.direction, 6).tolist(), np.round(lines.hi - lines.lo, 3).tolist()
    ([[1.0, 0.0], [0.0, 1.0]], [0.99, 0.49])
    """
    g = int(sizes.size)
    gid = np.repeat(np.arange(g, dtype=np.intp), sizes)
    starts = np.cumsum(sizes) - sizes
    ones = np.ones_like(x)
    point, t, _ = _principal_axes(x, y, gid, ones, g)
    resid = (x - point[gid, 0]) * -t[gid, 1] + (y - point[gid, 1]) * t[gid, 0]
    rms = np.sqrt(np.bincount(gid, weights=resid * resid, minlength=g) / sizes)
    keep = np.abs(resid) <= np.maximum(3.0 * rms, 2.0 * cell)[gid]
    point2, t2, spread2 = _principal_axes(x, y, gid, keep.astype(np.float64), g)
    nk = np.bincount(gid, weights=keep.astype(np.float64), minlength=g)
    again = (nk >= 2) & (spread2 > 0)
    point[again], t[again] = point2[again], t2[again]
    u = (x - point[gid, 0]) * t[gid, 0] + (y - point[gid, 1]) * t[gid, 1]
    flip = u[starts + sizes - 1] < u[starts]
    t[flip] = -t[flip]
    u = np.where(flip[gid], -u, u)
    lo = np.minimum.reduceat(u, starts)
    hi = np.maximum.reduceat(u, starts)
    resid = (x - point[gid, 0]) * -t[gid, 1] + (y - point[gid, 1]) * t[gid, 0]
    rms = np.sqrt(np.bincount(gid, weights=resid * resid, minlength=g) / sizes)
    return GroupedLines(point, t, lo, hi, rms, _floor(x, y, s, gid, g, cell))


def _floor(
    x: FloatArray, y: FloatArray, s: FloatArray, gid: IntArray, g: int, cell: float
) -> FloatArray:
    """The criterion's floor of each group (see :class:`GroupedLines`)."""
    b = np.floor(s / (FLOOR_BIN_CELLS * cell)).astype(np.int64)
    b -= np.minimum.reduceat(b, np.flatnonzero(np.r_[True, gid[1:] != gid[:-1]]))[gid]
    key = gid.astype(np.int64) * (int(b.max()) + 1) + b
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    mx = np.bincount(inv, weights=x) / cnt
    my = np.bincount(inv, weights=y) / cnt
    d2 = (x - mx[inv]) ** 2 + (y - my[inv]) ** 2
    return np.sqrt(np.bincount(gid, weights=d2, minlength=g) / np.bincount(gid, minlength=g))


def fit_surfaces(
    groups: Sequence[SurfaceCells], *, cell: float
) -> list[SurfaceFit | SurfaceFailure]:
    """:func:`~sonarproc.surfaces.models.fit_surface` of every group (see the module notes).

    Parameters
    ----------
    groups : sequence of SurfaceCells
        Surfaces' cells, each in order along it.
    cell : float
        Cell size (m).

    Returns
    -------
    list of SurfaceFit or SurfaceFailure
        One per group, in order.

    Examples
    --------
    >>> x = np.arange(0.0, 1.0, 0.01)
    >>> wall = SurfaceCells(x, 0.5 + 0 * x, x, np.ones_like(x), False)
    >>> [(f.model, round(f.length_m, 3)) for f in fit_surfaces([wall, wall], cell=0.01)]
    [('line', 0.99), ('line', 0.99)]
    """
    out: list[SurfaceFit | SurfaceFailure | None] = [None] * len(groups)
    sizes = np.array([c.size for c in groups], dtype=np.intp)
    big = np.flatnonzero(sizes >= MIN_CELLS)
    if big.size:
        x = np.concatenate([groups[i].x for i in big.tolist()])
        y = np.concatenate([groups[i].y for i in big.tolist()])
        starts = np.cumsum(sizes[big]) - sizes[big]
        moves = (np.maximum.reduceat(x, starts) > np.minimum.reduceat(x, starts)) | (
            np.maximum.reduceat(y, starts) > np.minimum.reduceat(y, starts)
        )
        # groups at one point go the slow way (it says why they fail)
        sel = big[moves]
        keep_cells = np.repeat(moves, sizes[big])
        x, y = x[keep_cells], y[keep_cells]
        s = np.concatenate([groups[i].s for i in sel.tolist()]) if sel.size else np.zeros(0)
        lines = fit_lines(x, y, s, sizes[sel], cell=cell) if sel.size else None
        if lines is not None:
            ok = lines.accepted(cell)
            weight = np.concatenate([groups[i].weight for i in sel.tolist()])
            wsum = np.add.reduceat(weight, np.cumsum(sizes[sel]) - sizes[sel])
            for k in np.flatnonzero(ok):
                size, w = int(sizes[sel[k]]), float(wsum[k])
                out[int(sel[k])] = _line_fit(lines, int(k), size, w, cell)
    for i, got in enumerate(out):
        if got is None:
            out[i] = fit_surface(groups[i], cell=cell)
    return [f for f in out if f is not None]


def _line_fit(lines: GroupedLines, k: int, size: int, weight: float, cell: float) -> SurfaceFit:
    """The accepted line ``k`` as :func:`~sonarproc.surfaces.models.fit_surface` builds it."""
    c, t = lines.point[k], lines.direction[k]
    poly = resample(np.stack((c + t * lines.lo[k], c + t * lines.hi[k])), cell)
    rms = float(lines.rms[k])
    return SurfaceFit(
        model="line",
        polyline=poly,
        length_m=float(np.hypot(*np.diff(poly, axis=0).T).sum()) if len(poly) > 1 else 0.0,
        rms_m=rms,
        support=size,
        arcs=round(weight),
        closed=False,
        params={"point": c.tolist(), "direction": t.tolist()},
        candidates={"line": rms},
    )

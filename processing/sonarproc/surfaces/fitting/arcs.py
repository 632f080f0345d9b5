"""Circular surfaces: the one circle fit, for many groups at once, and arcs of it.

:func:`fit_circles` fits every group together: Kasa's algebraic circle, refined by
Gauss-Newton on the geometric distance (at most :data:`CIRCLE_ITERATIONS` steps, until a
step moves nothing by more than 1e-10 of the radius), trimmed and refitted once like the
line (:mod:`sonarproc.surfaces.fitting.lines`). :func:`fit_arc` is its one-group case;
:func:`arc_candidate` spans the cells' angles in their order along the surface, or the
whole circle for a closed surface.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.grouped import group_labels, trimmed
from sonarproc.surfaces.fitting.models import Candidate, SurfaceFailure
from sonarproc.surfaces.planar.polylines import distance_to_polylines, to_adjacent_segments

__all__ = ["CIRCLE_ITERATIONS", "GroupedCircles", "arc_candidate", "fit_arc", "fit_circles"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: Most Gauss-Newton steps of a circle fit.
CIRCLE_ITERATIONS = 20


class GroupedCircles:
    """Circles of many groups (see the module notes).

    Attributes
    ----------
    centre : ndarray, shape (G, 2)
    radius : ndarray, shape (G,)
    ok : ndarray of bool, shape (G,)
        False where no circle fits (collinear or degenerate points, a diverging fit).
    """

    def __init__(self, centre: FloatArray, radius: FloatArray, ok: BoolArray) -> None:
        self.centre, self.radius, self.ok = centre, radius, ok


def _solve3(a: FloatArray, b: FloatArray) -> tuple[FloatArray, BoolArray]:
    """Solve the symmetric 3 x 3 systems ``a[k] x = b[k]`` (Cramer); False where singular."""
    a00, a01, a02 = a[:, 0, 0], a[:, 0, 1], a[:, 0, 2]
    a11, a12, a22 = a[:, 1, 1], a[:, 1, 2], a[:, 2, 2]
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    ok = np.isfinite(det) & (det != 0)
    d = np.where(ok, det, 1.0)
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    x = np.stack(
        (
            (c00 * b0 + c01 * b1 + c02 * b2) / d,
            (c01 * b0 + c11 * b1 + c12 * b2) / d,
            (c02 * b0 + c12 * b1 + c22 * b2) / d,
        ),
        axis=1,
    )
    return x, ok


def _circles(
    x: FloatArray, y: FloatArray, gid: IntArray, weight: FloatArray, g: int
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Kasa then Gauss-Newton for each group, over the points of weight 1."""

    def total(v: FloatArray) -> FloatArray:
        return np.asarray(np.bincount(gid, weights=v * weight, minlength=g), dtype=np.float64)

    n = total(np.ones_like(x))
    mx, my = total(x) / np.maximum(n, 1.0), total(y) / np.maximum(n, 1.0)
    u, v = x - mx[gid], y - my[gid]
    b = -(u * u + v * v)
    suu, suv, svv, su, sv = total(u * u), total(u * v), total(v * v), total(u), total(v)
    a = np.stack(
        (np.stack((suu, suv, su), 1), np.stack((suv, svv, sv), 1), np.stack((su, sv, n), 1)), 1
    )
    sol, ok = _solve3(a, np.stack((total(u * b), total(v * b), total(b)), axis=1))
    cx, cy = -0.5 * sol[:, 0], -0.5 * sol[:, 1]
    r2 = cx * cx + cy * cy - sol[:, 2]
    ok &= np.isfinite(r2) & (r2 > 0)
    p = np.stack((cx, cy, np.sqrt(np.where(ok, r2, 1.0))), axis=1)
    active = ok.copy()
    for _ in range(CIRCLE_ITERATIONS):
        if not active.any():
            break
        # the steps of the groups still moving, from their own points only: a group's
        # sums are the same whichever other groups' points are left out
        at = np.flatnonzero(active[gid])
        ga, wa = gid[at], weight[at]

        def part(w: FloatArray, ga: IntArray = ga, wa: FloatArray = wa) -> FloatArray:
            return np.asarray(np.bincount(ga, weights=w * wa, minlength=g), dtype=np.float64)

        dx, dy = u[at] - p[ga, 0], v[at] - p[ga, 1]
        dist = np.maximum(np.hypot(dx, dy), 1e-12)
        jx, jy = -dx / dist, -dy / dist
        res = p[ga, 2] - dist
        sxx, sxy, syy, sx, sy = part(jx * jx), part(jx * jy), part(jy * jy), part(jx), part(jy)
        jtj = np.stack(
            (
                np.stack((sxx, sxy, -sx), 1),
                np.stack((sxy, syy, -sy), 1),
                np.stack((-sx, -sy, n), 1),
            ),
            1,
        )
        step, solvable = _solve3(jtj, np.stack((part(jx * res), part(jy * res), -part(res)), 1))
        move = active & solvable
        p[move] += step[move]
        diverged = move & ~np.all(np.isfinite(p), axis=1)
        ok &= ~diverged
        done = ~solvable | diverged
        done |= np.abs(step).max(axis=1) < 1e-10 * np.maximum(1.0, np.abs(p[:, 2]))
        active &= ~done
    ok &= p[:, 2] > 0
    centre = np.stack((p[:, 0] + mx, p[:, 1] + my), axis=1)
    return centre, p[:, 2], np.asarray(ok)


def fit_circles(x: FloatArray, y: FloatArray, sizes: IntArray, *, cell: float) -> GroupedCircles:
    """Fit one trimmed circle to each group of consecutive points (see the module notes).

    Parameters
    ----------
    x, y : ndarray, shape (P,)
        The groups' points one after the other.
    sizes : ndarray of int, shape (G,)
        Points per group.
    cell : float
        Cell size (m): the trim's floor.

    Returns
    -------
    GroupedCircles

    Examples
    --------
    >>> phi = np.linspace(0.0, 2.0, 40)
    >>> x = np.r_[1 + 0.5 * np.cos(phi), 2 * np.cos(phi)]
    >>> y = np.r_[-1 + 0.5 * np.sin(phi), 2 * np.sin(phi)]
    >>> c = fit_circles(x, y, np.array([40, 40]), cell=0.01)
    >>> np.round(c.centre, 9).tolist(), np.round(c.radius, 9).tolist(), c.ok.tolist()
    ([[1.0, -1.0], [0.0, -0.0]], [0.5, 2.0], [True, True])
    """
    sizes = np.asarray(sizes, dtype=np.intp)
    g = int(sizes.size)
    gid, _ = group_labels(sizes)
    centre, radius, ok = _circles(x, y, gid, np.ones_like(x), g)
    resid = np.hypot(x - centre[gid, 0], y - centre[gid, 1]) - radius[gid]
    keep = trimmed(resid, gid, sizes, cell) & ok[gid]
    again = ok & (np.bincount(gid, weights=keep.astype(np.float64), minlength=g) >= 3)
    if again.any():
        c2, r2, ok2 = _circles(x, y, gid, (keep & again[gid]).astype(np.float64), g)
        better = again & ok2
        centre[better], radius[better] = c2[better], r2[better]
    return GroupedCircles(centre, radius, ok)


def arc_candidate(cells: SurfaceCells, centre: FloatArray, radius: float, cell: float) -> Candidate:
    """The arc of a circle over the cells' angles (the whole circle for a closed surface)."""
    x, y = cells.x, cells.y
    cx, cy, r = float(centre[0]), float(centre[1]), float(radius)
    ang = np.unwrap(np.arctan2(y - cy, x - cx))
    if cells.closed:
        start, sweep = float(ang[0]), 2.0 * math.pi
    else:
        start, sweep = float(ang[0]), float(ang[-1] - ang[0])
        lo, hi = float(ang.min()), float(ang.max())
        start, sweep = (lo, hi - lo) if sweep >= 0 else (hi, lo - hi)
    n = max(2, math.ceil(abs(sweep) * r / cell) + 1)
    phi = start + sweep * np.linspace(0.0, 1.0, n)
    poly = np.stack((cx + r * np.cos(phi), cy + r * np.sin(phi)), axis=1)
    dist = _arc_distances(np.stack((x, y), 1), poly, cx, cy, start, sweep)
    rms = float(np.sqrt(np.mean(dist**2)))
    params = {"centre": [cx, cy], "radius": r, "start_rad": start, "sweep_rad": sweep}
    return Candidate("arc", poly, rms, params, closed=cells.closed)


def _arc_distances(
    q: FloatArray, poly: FloatArray, cx: float, cy: float, start: float, sweep: float
) -> FloatArray:
    """:func:`distance_to_polylines` of ``q`` to an arc's polyline, its vertices at equal angles.

    The nearest vertex of a circle's polyline is the one nearest in angle, so no search
    is needed; the distance is then taken to it and its two segments, as there.
    """
    n = poly.shape[0]
    span = abs(sweep)
    if n < 2 or span <= 0:
        return distance_to_polylines(q, [poly])
    ang = np.arctan2(q[:, 1] - cy, q[:, 0] - cx)
    rel = np.mod((ang - start) if sweep >= 0 else (start - ang), 2 * math.pi)
    # the two vertices either side of the angle, both ends beyond the arc (or at the
    # seam of a closed one): the nearest of them, the lower index on ties, as the search
    low = np.minimum(np.floor(np.minimum(rel, span) / span * (n - 1)), n - 2).astype(np.intp)
    past = (rel > span) | (low == 0) | (low == n - 2)
    cand = np.stack((low, low + 1, np.where(past, 0, low), np.where(past, n - 1, low)), axis=1)
    cand.sort(axis=1)
    d = q[:, None, :] - poly[cand]
    dist = np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])
    pick = np.argmin(dist, axis=1)
    rows = np.arange(q.shape[0])
    k, best = cand[rows, pick], dist[rows, pick]
    ends = np.zeros_like(k), np.full_like(k, n - 1)
    return to_adjacent_segments(q, poly, k, best, *ends)


def fit_arc(cells: SurfaceCells, *, cell: float) -> Candidate | SurfaceFailure:
    """Circular arc through the cells: algebraic start, geometric refinement, one trim.

    See :func:`fit_circles` (this is its one-group case).
    """
    if cells.size < 3:
        return SurfaceFailure(f"arc: {cells.size} cells, need at least 3", cells.size)
    got = fit_circles(cells.x, cells.y, np.array([cells.size]), cell=cell)
    if not got.ok[0]:
        return SurfaceFailure("arc: no circle fits (collinear or degenerate cells)", cells.size)
    return arc_candidate(cells, got.centre[0], float(got.radius[0]), cell)

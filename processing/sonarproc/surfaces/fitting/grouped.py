"""Lines and circles through many groups of points at once, and the criterion's floor.

The surfaces of a room come as about a thousand groups of cells (or of echo points);
fitting them one by one costs a Python round trip and a small SVD or solve per group. The
fits here take all groups together: each group is a run of consecutive points, and every
sum a fit needs is one ``np.bincount`` over a group label per point, every 3 x 3 system
one closed-form solve per group in a vector. A group gives the same result alone or among
others (its sums are accumulated in the same order), so the one-group case is the
reference the surfaces' single fits use too.

* :func:`fit_lines`: total least squares, the principal axis of the group's scatter
  matrix (``theta = atan2(2 Sxy, Sxx - Syy) / 2``), refitted once without the points
  further than ``max(3 rms, 2 cells)`` from it, oriented from the group's first point
  towards its last, spanning all its points' projections.
* :func:`fit_circles`: Kasa's algebraic circle, refined by Gauss-Newton on the geometric
  distance (at most :data:`CIRCLE_ITERATIONS` steps, until a step moves nothing by more
  than 1e-10 of the radius), trimmed and refitted once like the line.
* :func:`floor_rms`: the points' RMS distance to their own means over bins of
  ``FLOOR_BIN_CELLS`` cells of arc length (a curve that follows the points about as
  closely as a flexible fit would).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "CIRCLE_ITERATIONS",
    "FLOOR_BIN_CELLS",
    "GroupedCircles",
    "GroupedLines",
    "fit_circles",
    "fit_lines",
    "floor_rms",
    "group_labels",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: Arc-length bins (cells) of the criterion's floor.
FLOOR_BIN_CELLS = 5
#: Most Gauss-Newton steps of a circle fit.
CIRCLE_ITERATIONS = 20


def group_labels(sizes: npt.ArrayLike) -> tuple[IntArray, IntArray]:
    """The group of each point and the index of each group's first point.

    Examples
    --------
    >>> gid, starts = group_labels([2, 3])
    >>> gid.tolist(), starts.tolist()
    ([0, 0, 1, 1, 1], [0, 2])
    """
    n = np.asarray(sizes, dtype=np.intp)
    return np.repeat(np.arange(n.size, dtype=np.intp), n), np.cumsum(n) - n


def _trim(resid: FloatArray, gid: IntArray, sizes: IntArray, cell: float) -> BoolArray:
    """Points within ``max(3 rms, 2 cell)`` of their group's fit."""
    g = sizes.size
    rms = np.sqrt(np.bincount(gid, weights=resid * resid, minlength=g) / np.maximum(sizes, 1))
    return np.asarray(np.abs(resid) <= np.maximum(3.0 * rms, 2.0 * cell)[gid])


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
    keep = _trim(resid, gid, sizes, cell).astype(np.float64)
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
        dx, dy = u - p[gid, 0], v - p[gid, 1]
        dist = np.maximum(np.hypot(dx, dy), 1e-12)
        jx, jy = -dx / dist, -dy / dist
        res = p[gid, 2] - dist
        jtj = np.stack(
            (
                np.stack((total(jx * jx), total(jx * jy), -total(jx)), 1),
                np.stack((total(jx * jy), total(jy * jy), -total(jy)), 1),
                np.stack((-total(jx), -total(jy), n), 1),
            ),
            1,
        )
        step, solvable = _solve3(jtj, np.stack((total(jx * res), total(jy * res), -total(res)), 1))
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
    keep = _trim(resid, gid, sizes, cell) & ok[gid]
    again = ok & (np.bincount(gid, weights=keep.astype(np.float64), minlength=g) >= 3)
    if again.any():
        c2, r2, ok2 = _circles(x, y, gid, (keep & again[gid]).astype(np.float64), g)
        better = again & ok2
        centre[better], radius[better] = c2[better], r2[better]
    return GroupedCircles(centre, radius, ok)


def floor_rms(
    x: FloatArray, y: FloatArray, s: FloatArray, sizes: IntArray, *, cell: float
) -> FloatArray:
    """RMS distance of each group's points to their means over bins of arc length (m).

    Examples
    --------
    Points zig-zagging 2 mm across a line, all in one bin (s below 5 cells): the floor
    is their RMS distance to the bin's mean point.

    >>> s = np.arange(4) * 0.01
    >>> floor_rms(0 * s, np.array([0.0, 0.002, 0.0, 0.002]), s, np.array([4]), cell=0.01).tolist()
    [0.001]
    """
    sizes = np.asarray(sizes, dtype=np.intp)
    g = int(sizes.size)
    if g == 0:
        return np.zeros(0)
    gid, starts = group_labels(sizes)
    b = np.floor(s / (FLOOR_BIN_CELLS * cell)).astype(np.int64)
    b -= np.minimum.reduceat(b, starts)[gid]
    key = gid.astype(np.int64) * (int(b.max()) + 1) + b
    _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    mx = np.bincount(inv, weights=x) / cnt
    my = np.bincount(inv, weights=y) / cnt
    d2 = (x - mx[inv]) ** 2 + (y - my[inv]) ** 2
    return np.asarray(np.sqrt(np.bincount(gid, weights=d2, minlength=g) / np.maximum(sizes, 1)))

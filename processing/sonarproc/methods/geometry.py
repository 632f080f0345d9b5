"""Beam geometry shared by the classic map-building methods (pure, vectorised).

* :func:`axis_points`: the naive line-of-sight point of each reading: at half the path
  along the sensor's axis for a sensor's own echo, and for a bistatic pair the point of
  the echo ellipse (foci the two transducers) on the ray from the ellipse's centre along
  the bisector of the two headings.
* :func:`ray_cells`: the grid cells a set of segments passes through (samples one cell
  apart), for free-space evidence along the beam axis.
* :func:`sector_counts`: how many circular sectors (apex, axis, half angle, radius) cover
  each cell centre, by row intervals and a difference array: the cost grows with the rows
  a sector spans, not with its area.
"""

from __future__ import annotations

import itertools

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid

__all__ = ["axis_points", "ray_cells", "sector_counts"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Work arrays are processed in chunks of about this many elements.
CHUNK = 1 << 21


def axis_points(
    tx_xy: npt.ArrayLike,
    tx_heading: npt.ArrayLike,
    rx_xy: npt.ArrayLike,
    rx_heading: npt.ArrayLike,
    path: npt.ArrayLike,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Line-of-sight echo point of each reading.

    Parameters
    ----------
    tx_xy, rx_xy : array_like, (N, 2)
        Transmitter and receiver positions (m).
    tx_heading, rx_heading : array_like, (N,)
        Beam axes (rad).
    path : array_like, (N,)
        Path length ``|TP| + |PR|`` (m).

    Returns
    -------
    apex : ndarray, (N, 2)
        Start of the line of sight: the transducer, or the midpoint of a pair.
    direction : ndarray, (N, 2)
        Unit vector along the (bisector) axis.
    dist : ndarray, (N,)
        Distance from ``apex`` to the echo point (NaN when ``path`` is shorter than the
        baseline, i.e. no ellipse).

    Examples
    --------
    >>> a, d, s = axis_points([[0.0, 0.0]], [np.pi / 2], [[0.0, 0.0]], [np.pi / 2], [2.0])
    >>> (a + s[:, None] * d).round(12).tolist()
    [[0.0, 1.0]]
    """
    t = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
    ht = np.asarray(tx_heading, dtype=np.float64).reshape(-1)
    hr = np.asarray(rx_heading, dtype=np.float64).reshape(-1)
    p = np.asarray(path, dtype=np.float64).reshape(-1)
    apex = 0.5 * (t + r)
    u = np.column_stack((np.cos(ht) + np.cos(hr), np.sin(ht) + np.sin(hr)))
    norm = np.hypot(u[:, 0], u[:, 1])
    opposite = norm < 1e-9  # headings pointing apart: fall back to the transmitter's
    u[opposite] = np.column_stack((np.cos(ht[opposite]), np.sin(ht[opposite])))
    norm[opposite] = 1.0
    u /= norm[:, None]
    a = 0.5 * p
    base = r - t
    c = 0.5 * np.hypot(base[:, 0], base[:, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(c[:, None] > 0, base / (2 * c[:, None]), np.array([1.0, 0.0]))
        ua = u[:, 0] * e[:, 0] + u[:, 1] * e[:, 1]
        b2 = a * a - c * c
        dist = 1.0 / np.sqrt(ua * ua / (a * a) + (1.0 - ua * ua) / b2)
    dist[~(b2 > 0)] = np.nan
    return apex, u, dist


def _chunks(sizes: IntArray, limit: int = CHUNK) -> list[tuple[int, int]]:
    """Split items into consecutive ranges whose ``sizes`` sum to about ``limit``."""
    if sizes.size == 0:
        return []
    ends = np.cumsum(sizes)
    cuts = np.searchsorted(ends, np.arange(limit, int(ends[-1]), limit), side="left")
    bounds = np.unique(np.concatenate(([0], cuts + 1, [sizes.size])))
    bounds = bounds[bounds <= sizes.size]
    return [(int(i), int(j)) for i, j in itertools.pairwise(bounds) if j > i]


def ray_cells(
    start: npt.ArrayLike, direction: npt.ArrayLike, length: npt.ArrayLike, grid: Grid
) -> npt.NDArray[np.int64]:
    """How many segment samples fall in each cell (flat counts, ``grid.ny * grid.nx``).

    Each segment ``start + s * direction`` for ``0 <= s <= length - cell`` is sampled
    every ``grid.cell``; the cell holding ``start + length * direction`` itself is never
    counted for that segment (it holds the echo).

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=1.0, nx=4, ny=1)
    >>> ray_cells([[0.0, 0.0]], [[1.0, 0.0]], [3.0], g).tolist()
    [1, 1, 1, 0]
    """
    s0 = np.asarray(start, dtype=np.float64).reshape(-1, 2)
    d = np.asarray(direction, dtype=np.float64).reshape(-1, 2)
    ln = np.asarray(length, dtype=np.float64).reshape(-1)
    out = np.zeros(grid.ny * grid.nx, dtype=np.int64)
    ok = np.isfinite(ln) & (ln >= grid.cell)
    s0, d, ln = s0[ok], d[ok], ln[ok]
    n = (np.floor((ln - grid.cell) / grid.cell) + 1).astype(np.intp)
    hy, hx = grid.to_index(s0[:, 0] + ln * d[:, 0], s0[:, 1] + ln * d[:, 1])
    for i, j in _chunks(n):
        ni = n[i:j]
        which = np.repeat(np.arange(i, j), ni)
        first = np.repeat(np.cumsum(ni) - ni, ni)
        k = (np.arange(which.size) - first).astype(np.float64) * grid.cell
        iy, ix = grid.to_index(s0[which, 0] + k * d[which, 0], s0[which, 1] + k * d[which, 1])
        keep = grid.contains_index(iy, ix) & ~((iy == hy[which]) & (ix == hx[which]))
        out += np.bincount(iy[keep] * grid.nx + ix[keep], minlength=out.size)
    return out


def _wrap(a: FloatArray) -> FloatArray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def sector_counts(
    apex: npt.ArrayLike,
    heading: npt.ArrayLike,
    half_angle: npt.ArrayLike,
    radius: npt.ArrayLike,
    grid: Grid,
) -> npt.NDArray[np.int64]:
    """Number of sectors covering each cell centre, shape ``grid.shape``.

    Sector ``k`` is the set of points within ``radius[k]`` of ``apex[k]`` whose bearing is
    within ``half_angle[k]`` (< pi/2) of ``heading[k]``. A row of cell centres crosses a
    convex sector in one interval, so each sector adds +1/-1 at its interval's ends in a
    difference array per row, and one cumulative sum finishes the map.

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=1.0, nx=5, ny=3)
    >>> sector_counts([[0.0, 1.0]], [0.0], [np.pi / 4], [3.0], g).tolist()
    [[0, 1, 1, 0, 0], [1, 1, 1, 1, 0], [0, 1, 1, 0, 0]]
    """
    a = np.asarray(apex, dtype=np.float64).reshape(-1, 2)
    n = a.shape[0]
    h = np.broadcast_to(np.asarray(heading, dtype=np.float64), (n,))
    b = np.broadcast_to(np.asarray(half_angle, dtype=np.float64), (n,))
    rad = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,))
    ok = np.isfinite(rad) & (rad > 0) & np.all(np.isfinite(a), axis=1)
    a, h, b, rad = a[ok], h[ok], b[ok], rad[ok]
    ax, ay = a[:, 0], a[:, 1]
    # y extent: the apex, both edge ends, and the top/bottom of the circle if in the wedge
    ys = np.column_stack((ay, ay + rad * np.sin(h - b), ay + rad * np.sin(h + b)))
    top = np.where(np.abs(_wrap(np.pi / 2 - h)) <= b, ay + rad, -np.inf)
    bottom = np.where(np.abs(_wrap(-np.pi / 2 - h)) <= b, ay - rad, np.inf)
    ymin = np.minimum(ys.min(axis=1), bottom)
    ymax = np.maximum(ys.max(axis=1), top)
    r0 = np.maximum(np.ceil((ymin - grid.y0) / grid.cell), 0).astype(np.intp)
    r1 = np.minimum(np.floor((ymax - grid.y0) / grid.cell), grid.ny - 1).astype(np.intp)
    rows = np.maximum(r1 - r0 + 1, 0)
    w = grid.nx + 1
    diff = np.zeros(grid.ny * w, dtype=np.int64)
    # wedge edges: right d_r = heading - half, left d_l = heading + half
    drx, dry = np.cos(h - b), np.sin(h - b)
    dlx, dly = np.cos(h + b), np.sin(h + b)
    for i, j in _chunks(rows):
        ni = rows[i:j]
        k = np.repeat(np.arange(i, j), ni)
        row = r0[k] + (np.arange(k.size) - np.repeat(np.cumsum(ni) - ni, ni))
        dy = grid.y0 + row * grid.cell - ay[k]
        half = np.sqrt(np.maximum(rad[k] ** 2 - dy * dy, 0.0))
        lo = -half
        hi = np.where(rad[k] ** 2 >= dy * dy, half, -np.inf)
        # cross(d_r, v) >= 0 <=> -dry * vx >= -drx * dy
        # cross(v, d_l) >= 0 <=> dly * vx >= dlx * dy
        for coef, rhs in ((-dry[k], -drx[k] * dy), (dly[k], dlx[k] * dy)):
            with np.errstate(divide="ignore", invalid="ignore"):
                bound = rhs / coef
            lo = np.where(coef > 0, np.maximum(lo, bound), lo)
            hi = np.where(coef < 0, np.minimum(hi, bound), hi)
            never = (coef == 0) & (rhs > 0)
            hi = np.where(never, -np.inf, hi)
        c0 = np.maximum(np.ceil((ax[k] + lo - grid.x0) / grid.cell - 1e-9), 0)
        c1 = np.minimum(np.floor((ax[k] + hi - grid.x0) / grid.cell + 1e-9), grid.nx - 1)
        keep = np.isfinite(c0) & np.isfinite(c1) & (c0 <= c1)
        base = row[keep] * w
        diff += np.bincount(base + c0[keep].astype(np.intp), minlength=diff.size)
        diff -= np.bincount(base + c1[keep].astype(np.intp) + 1, minlength=diff.size)
    return np.cumsum(diff.reshape(grid.ny, w), axis=1)[:, : grid.nx]

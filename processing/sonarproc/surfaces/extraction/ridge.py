"""A ridge of the arc-count map that keeps every wall: non-maximum suppression across it.

The per-column ``ridge`` of :mod:`sonarproc.morphology` keeps the crest of each *column*, so
of two walls one above the other (a corridor) only one survives, and a wall running
along y (a column of equal counts) is not thinned at all. Here the crest is found across
the ridge's own direction: the count map is smoothed, the Hessian of the smoothed map
gives at every cell the direction of strongest negative curvature (the ridge normal), and
a cell is kept when its smoothed count is at least the (bilinearly interpolated) smoothed
count one cell away on both sides along that normal. Two parallel walls are two separate
ridges, each a maximum along its own normal, so both survive, whatever their direction.

The filters are :func:`scipy.ndimage.gaussian_filter`'s and the sampling between cells
:func:`scipy.ndimage.map_coordinates`' (bilinear), run only inside the bounding box of the
set cells (plus a margin); the comparisons are made only at set cells.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy import ndimage

__all__ = ["RIDGE_SIGMA_CELLS", "ridge_directions", "ridge_nms"]

#: Gaussian smoothing of the count map (cells) before the suppression.
RIDGE_SIGMA_CELLS = 1.0
#: Smoothing (cells) of the map whose Hessian gives the ridge direction: wider, so that
#: the direction is that of the wall, not of the single arcs crossing it.
DIRECTION_SIGMA_CELLS = 2.0

#: Derivative orders (rows, columns) of the Hessian's terms d2/dx2, d2/dy2, d2/dxdy.
HESSIAN_ORDERS = [(0, 2), (2, 0), (1, 1)]

BoolArray = npt.NDArray[np.bool_]
FloatArray = npt.NDArray[np.float64]
FloatingArray = npt.NDArray[np.floating]
IntArray = npt.NDArray[np.intp]


def _crop(mask: BoolArray, margin: int) -> tuple[slice, slice] | None:
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    r0, r1 = max(int(rows[0]) - margin, 0), min(int(rows[-1]) + margin + 1, mask.shape[0])
    c0, c1 = max(int(cols[0]) - margin, 0), min(int(cols[-1]) + margin + 1, mask.shape[1])
    return slice(r0, r1), slice(c0, c1)


def _hessian(c: FloatingArray, sigma: float) -> list[FloatingArray]:
    """The Gaussian-smoothed map's second derivatives d2/dx2, d2/dy2, d2/dxdy."""
    return [ndimage.gaussian_filter(c, sigma, order=o) for o in HESSIAN_ORDERS]


def ridge_directions(
    counts: npt.ArrayLike, *, sigma: float = DIRECTION_SIGMA_CELLS
) -> tuple[FloatArray, FloatArray]:
    """The unit ridge normal ``(nx, ny)`` at every cell of a count map.

    It is the eigenvector of the Hessian of the Gaussian-smoothed map (``sigma`` cells)
    with the smaller (most negative) eigenvalue: across a crest the counts fall fastest.

    Examples
    --------
    >>> c = np.zeros((9, 9)); c[4, :] = 10.0          # a horizontal wall (along x)
    >>> nx, ny = ridge_directions(c)
    >>> round(abs(float(ny[4, 4])), 6), round(abs(float(nx[4, 4])), 6)
    (1.0, 0.0)
    """
    c = np.asarray(counts, dtype=np.float32)
    hxx, hyy, hxy = _hessian(c, sigma)
    # eigenvector of the larger eigenvalue at angle 0.5 atan2(2 hxy, hxx - hyy); the
    # normal is perpendicular to it
    theta = 0.5 * np.arctan2(2.0 * hxy, hxx - hyy) + 0.5 * np.pi
    return np.cos(theta).astype(np.float64), np.sin(theta).astype(np.float64)


def ridge_nms(
    mask: npt.ArrayLike,
    counts: npt.ArrayLike,
    *,
    sigma: float = RIDGE_SIGMA_CELLS,
    direction_sigma: float = DIRECTION_SIGMA_CELLS,
) -> BoolArray:
    """Keep the set cells of ``mask`` that are crests of ``counts`` across the ridge.

    Parameters
    ----------
    mask : array_like of bool, shape (ny, nx)
        The cells still kept (e.g. after ``vote:auto``); only these can survive.
    counts : array_like of int, shape (ny, nx)
        Arcs crossing each cell (:func:`sonarproc.arcs.rasterize`).
    sigma : float
        Gaussian smoothing (cells) of the counts compared along the normal.
    direction_sigma : float
        Gaussian smoothing (cells) of the counts whose Hessian gives the normal.

    Returns
    -------
    ndarray of bool, shape (ny, nx)
        A cell is kept when it is set in ``mask``, the smoothed counts curve down across
        the ridge there more than they curve along it (``lambda_min < 0`` and
        ``|lambda_min| > |lambda_max|``, the Hessian's eigenvalues), and its smoothed
        count is ``>=`` the smoothed count one cell away along the normal on one side
        and ``>`` on the other (so a plateau two cells wide keeps one of them).

    Examples
    --------
    Two parallel walls four cells apart (a corridor) both survive; the per-column ridge
    of :mod:`sonarproc.morphology` would keep only the stronger one:

    >>> c = np.zeros((12, 8), dtype=np.uint16)
    >>> c[2:5, :] = [[3], [9], [3]]; c[7:10, :] = [[2], [6], [2]]
    >>> kept = ridge_nms(c > 0, c)
    >>> np.flatnonzero(kept.any(axis=1)).tolist()
    [3, 8]
    """
    m = np.asarray(mask, dtype=bool)
    c = np.asarray(counts)
    if m.shape != c.shape or m.ndim != 2:
        raise ValueError(f"mask and counts must be 2-D of one shape, got {m.shape}, {c.shape}")
    out = np.zeros(m.shape, dtype=bool)
    margin = int(np.ceil(4.0 * max(sigma, direction_sigma))) + 2
    box = _crop(m, margin)
    if box is None:
        return out
    mc = m[box]
    cc = np.asarray(c[box], dtype=np.float32)
    flat = np.flatnonzero(mc)
    hxx, hyy, hxy = _hessian(cc, direction_sigma)
    a, b, d = (h.ravel()[flat].astype(np.float64) for h in (hxx, hxy, hyy))
    root = np.sqrt(0.25 * (a - d) ** 2 + b * b)
    lam_min, lam_max = 0.5 * (a + d) - root, 0.5 * (a + d) + root
    # the curvature test first: the comparisons along the normal only where it holds
    ridge = np.flatnonzero((lam_min < 0) & (-lam_min > np.abs(lam_max)))
    flat, a, b, d = flat[ridge], a[ridge], b[ridge], d[ridge]
    iy, ix = np.divmod(flat, mc.shape[1])
    theta = 0.5 * np.arctan2(2.0 * b, a - d) + 0.5 * np.pi
    nx, ny = np.cos(theta), np.sin(theta)
    smooth = ndimage.gaussian_filter(cc, sigma) if sigma > 0 else cc
    here = smooth.ravel()[flat]
    fy, fx = iy.astype(np.float64), ix.astype(np.float64)
    ahead = ndimage.map_coordinates(smooth, [fy + ny, fx + nx], order=1, mode="nearest")
    behind = ndimage.map_coordinates(smooth, [fy - ny, fx - nx], order=1, mode="nearest")
    crest = (here >= ahead) & (here > behind)
    hits = np.zeros(mc.size, dtype=bool)
    hits[flat[crest]] = True
    out[box] = hits.reshape(mc.shape)
    return out

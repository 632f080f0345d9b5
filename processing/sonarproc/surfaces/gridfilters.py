"""Gaussian filters and bilinear sampling of a 2-D map, with numpy alone.

The ridge of :mod:`sonarproc.surfaces.ridge` smooths the count map and takes its Hessian
with Gaussian derivative filters, then samples the smoothed map between cells. These
are the filters of :func:`scipy.ndimage.gaussian_filter` and the sampling of
:func:`scipy.ndimage.map_coordinates` (``order=1, mode="nearest"``), written here so that
the surface stage imports no scipy (any scipy subpackage costs a fifth of a second to
import, more than the filtering itself).

They compute what scipy computes, operation for operation: the same kernels (a Gaussian
cut at ``truncate * sigma``, its derivatives as a polynomial times it), the same edge
(the map mirrored about its border, scipy's ``"reflect"``), the same order of the sums
(a symmetric kernel adds the mirrored pair of samples before weighting them) in float64,
and the result stored in the input's dtype after each axis. So the results are scipy's
to the last bit on the maps tried, and a ridge cell is kept or dropped exactly as before.
Each filter is a sum over the kernel's taps of shifted views of the whole (padded) array:
a loop over at most ``2 * radius + 1`` taps, not over cells.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

__all__ = ["bilinear_nearest", "gaussian_filter", "gaussian_filters", "gaussian_kernel"]

FloatArray = npt.NDArray[np.float64]
FloatingArray = npt.NDArray[np.floating]
IntArray = npt.NDArray[np.intp]

#: Kernel radius in standard deviations (scipy's default ``truncate``).
TRUNCATE = 4.0
#: Side (cells) of the square tiles filtered at once: with their margins, a few
#: hundred kB of float64, in cache.
TILE = 128
#: Points sampled at once by :func:`bilinear_nearest` (temporaries of 128 kB).
CHUNK = 1 << 14


def gaussian_kernel(sigma: float, order: int, *, truncate: float = TRUNCATE) -> FloatArray:
    """The sampled Gaussian (``order`` 0) or its ``order``-th derivative, centred.

    The radius is ``int(truncate * sigma + 0.5)``; the Gaussian is normalised to sum 1
    and the derivative is ``q(x) * g(x)`` with the polynomial ``q`` built by repeated
    differentiation (``(q g)' = (q' - x q / sigma**2) g``), as scipy does.

    Parameters
    ----------
    sigma : float
        Standard deviation (cells), > 0.
    order : int
        0 (smoothing), 1 or 2 (derivatives), or higher.
    truncate : float
        Radius in standard deviations.

    Returns
    -------
    ndarray, shape (2 * radius + 1,)
        Weights at offsets ``-radius ... radius``.

    Examples
    --------
    >>> gaussian_kernel(1.0, 0).size, round(float(gaussian_kernel(1.0, 0).sum()), 12)
    (9, 1.0)
    >>> np.round(gaussian_kernel(1.0, 1), 4)[3:6].tolist()
    [0.242, 0.0, -0.242]
    """
    if not sigma > 0:
        raise ValueError(f"sigma must be > 0, got {sigma}")
    if order < 0:
        raise ValueError(f"order must be >= 0, got {order}")
    radius = int(truncate * float(sigma) + 0.5)
    sigma2 = float(sigma) * float(sigma)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / sigma2 * x**2)
    phi = phi / phi.sum()
    if order == 0:
        return np.asarray(phi, dtype=np.float64)
    powers = np.arange(order + 1)
    q = np.zeros(order + 1)
    q[0] = 1.0
    # d/dx of q(x) g(x) is (q'(x) - x q(x) / sigma**2) g(x): on the coefficients of q,
    # the derivative (upper diagonal) plus the multiplication by -x / sigma**2 (lower)
    step = np.diag(powers[1:].astype(np.float64), 1) + np.diag(np.full(order, -1.0 / sigma2), -1)
    for _ in range(order):
        q = step.dot(q)
    return np.asarray((x[:, None] ** powers).dot(q) * phi, dtype=np.float64)


def _symmetry(w: FloatArray) -> int:
    """1 if ``w`` is symmetric, -1 if antisymmetric, else 0 (scipy's test and tolerance)."""
    r = w.size // 2
    left, right, eps = w[:r][::-1], w[r + 1 :], np.finfo(np.float64).eps
    if np.all(np.abs(left - right) <= eps):
        return 1
    if np.all(np.abs(left + right) <= eps):
        return -1
    return 0


def _shifted(src: FloatArray, axis: int, lo: int, n: int) -> Callable[[int], FloatArray]:
    """``k -> src[lo + k : lo + k + n]`` along ``axis`` (a view, no copy)."""
    if axis == 0:
        return lambda k: src[lo + k : lo + k + n]
    return lambda k: src[:, lo + k : lo + k + n]


def _taps(
    view: Callable[[int], FloatArray], weights: dict[int, FloatArray]
) -> dict[int, FloatArray]:
    """``sum_k w[r + k] * view(k)`` for each weight vector ``w`` (``k = -r..r``).

    The sum is scipy's: the centre tap first, then the mirrored pairs from the outermost
    inwards, added (symmetric weights) or subtracted (antisymmetric) before they are
    weighted; the pair sums are shared by all weight vectors of one symmetry.
    """
    r = next(iter(weights.values())).size // 2
    centre = view(0)
    acc = {o: centre * w[r] for o, w in weights.items()}
    kind = {o: _symmetry(w) for o, w in weights.items()}
    for o in [o for o, k in kind.items() if k == 0]:
        w = weights[o]
        acc[o] = view(r) * w[2 * r]
        for k in range(-r, r):
            acc[o] += view(k) * w[r + k]
    pair = np.empty_like(centre)
    tmp = np.empty_like(centre)
    for sign, combine in ((1, np.add), (-1, np.subtract)):
        users = [o for o, k in kind.items() if k == sign]
        if not users:
            continue
        for k in range(-r, 0):
            combine(view(k), view(-k), out=pair)
            for o in users:
                np.multiply(pair, weights[o][r + k], out=tmp)
                acc[o] += tmp
    return acc


def gaussian_filters(
    a: npt.ArrayLike,
    sigma: float,
    orders: list[tuple[int, int]],
    *,
    where: npt.ArrayLike | None = None,
    truncate: float = TRUNCATE,
) -> list[FloatingArray]:
    """Several :func:`gaussian_filter` of one map and one ``sigma`` at once.

    The map is filtered in square tiles of :data:`TILE` cells a side (small enough to
    stay in the processor's cache), both axes per tile, and the pass along the rows is
    shared by the filters with the same order along them; the results are those of
    :func:`gaussian_filter`. Given ``where``, only the tiles holding a cell it sets are
    filtered, the others left 0 (a count map's walls leave most tiles out).

    Parameters
    ----------
    a : array_like, shape (ny, nx)
        The map.
    sigma : float
        Standard deviation (cells), > 0.
    orders : list of tuple of int
        Derivative orders (along axis 0, along axis 1) of each filter.
    where : array_like of bool, shape (ny, nx), optional
        The cells wanted (default: all).
    truncate : float
        Kernel radius in standard deviations.

    Returns
    -------
    list of ndarray, shape (ny, nx)
        One filtered map per entry of ``orders`` (exact at least where ``where`` is set).

    Examples
    --------
    >>> c = np.zeros((9, 9)); c[4, :] = 1.0
    >>> hyy, hxx = gaussian_filters(c, 1.0, [(2, 0), (0, 2)])
    >>> round(float(hyy[4, 4]), 6), float(np.abs(hxx).max()) < 1e-4
    (-0.398943, True)
    >>> hyy, = gaussian_filters(np.zeros((300, 300)) + c.max(), 1.0, [(2, 0)],
    ...                         where=np.eye(300, dtype=bool) & (np.arange(300) < 9))
    >>> float(np.abs(hyy[:9, :9]).max()) < 1e-4, float(np.abs(hyy[-9:, -9:]).max())
    (True, 0.0)
    """
    arr = np.asarray(a)
    if arr.ndim != 2:
        raise ValueError(f"the map must be 2-D, got shape {arr.shape}")
    dtype = arr.dtype if np.issubdtype(arr.dtype, np.floating) else np.dtype(np.float64)
    want = None if where is None else np.asarray(where, dtype=bool)
    if want is not None and want.shape != arr.shape:
        raise ValueError(f"where must have the map's shape {arr.shape}, got {want.shape}")
    maps = [np.zeros(arr.shape, dtype=dtype) for _ in orders]
    if arr.size and orders:
        _filter_tiles(arr, sigma, orders, want, truncate, maps)
    return maps


def _filter_tiles(
    arr: npt.NDArray[np.generic],
    sigma: float,
    orders: list[tuple[int, int]],
    want: npt.NDArray[np.bool_] | None,
    truncate: float,
    maps: list[FloatingArray],
) -> None:
    """:func:`gaussian_filters` into ``maps``, tile by tile (those holding a wanted cell)."""
    ny, nx = arr.shape
    dtype = maps[0].dtype
    kernels = {
        o: gaussian_kernel(sigma, o, truncate=truncate)[::-1]  # convolution: reversed
        for o in {o for pair in orders for o in pair}
    }
    r = next(iter(kernels.values())).size // 2
    # the map mirrored about its border (scipy's "reflect") on all sides: filtering
    # the mirrored columns along the rows gives the first pass's mirrored columns
    padded = np.pad(arr.astype(dtype, copy=False), r, mode="symmetric")
    first = {o0: kernels[o0] for o0, _ in orders}
    rows, cols = -(-ny // TILE), -(-nx // TILE)
    if want is None:
        tiles = np.arange(rows * cols)
    else:
        held = np.zeros((rows * TILE, cols * TILE), dtype=bool)
        held[:ny, :nx] = want
        tiles = np.flatnonzero(held.reshape(rows, TILE, cols, TILE).any(axis=(1, 3)))
    for tile in tiles.tolist():
        i0, j0 = (tile // cols) * TILE, (tile % cols) * TILE
        i1, j1 = min(i0 + TILE, ny), min(j0 + TILE, nx)
        src = padded[i0 : i1 + 2 * r, j0 : j1 + 2 * r].astype(np.float64)
        along0 = _taps(_shifted(src, 0, r, i1 - i0), first)
        for o0, v in along0.items():
            # scipy stores the first pass in the map's dtype before the second one
            stored = v.astype(dtype, copy=False).astype(np.float64, copy=False)
            second = {o1: kernels[o1] for p0, o1 in orders if p0 == o0}
            along1 = _taps(_shifted(stored, 1, r, j1 - j0), second)
            for j, (p0, o1) in enumerate(orders):
                if p0 == o0:
                    maps[j][i0:i1, j0:j1] = along1[o1]


def gaussian_filter(
    a: npt.ArrayLike, sigma: float, *, order: tuple[int, int] = (0, 0), truncate: float = TRUNCATE
) -> FloatingArray:
    """A 2-D map filtered with a Gaussian or its derivatives, one axis after the other.

    ``order`` is the derivative order along each axis (rows, then columns), as in
    :func:`scipy.ndimage.gaussian_filter` with ``mode="reflect"`` (the map mirrored about
    its border). A floating-point map keeps its dtype (rounded to it after each axis, as
    scipy stores it); any other map is filtered as float64.

    Parameters
    ----------
    a : array_like, shape (ny, nx)
        The map.
    sigma : float
        Standard deviation (cells), > 0, on both axes.
    order : tuple of int
        Derivative order along axis 0 and along axis 1.
    truncate : float
        Kernel radius in standard deviations.

    Returns
    -------
    ndarray, shape (ny, nx)

    Examples
    --------
    >>> c = np.zeros((7, 7)); c[3, 3] = 1.0
    >>> s = gaussian_filter(c, 1.0)
    >>> round(float(s.sum()), 12), bool(s[3, 3] == s.max())
    (1.0, True)
    >>> d = gaussian_filter(np.tile(np.arange(20.0), (5, 1)), 1.0, order=(0, 1))
    >>> np.round(d[2, 8:11], 4).tolist()   # the slope 1 along the columns (kernel cut at 4 sigma)
    [0.9999, 0.9999, 0.9999]
    """
    return gaussian_filters(a, sigma, [order], truncate=truncate)[0]


def bilinear_nearest(a: npt.ArrayLike, y: npt.ArrayLike, x: npt.ArrayLike) -> FloatingArray:
    """A 2-D map sampled at fractional ``(row, column)`` points, bilinearly, edges clamped.

    Points outside the map take the value at the nearest border point, as
    :func:`scipy.ndimage.map_coordinates` with ``order=1, mode="nearest"``, and the weights
    and sums are scipy's, so are the values (in the map's dtype if floating, else float64).

    Parameters
    ----------
    a : array_like, shape (ny, nx)
        The map.
    y, x : array_like of float, one shape
        Row and column of each point (cell centres are whole numbers).

    Returns
    -------
    ndarray, the shape of ``y``

    Examples
    --------
    >>> a = np.array([[0.0, 1.0], [2.0, 3.0]])
    >>> bilinear_nearest(a, [0.5, -1.0, 0.0], [0.5, 0.0, 9.0]).tolist()
    [1.5, 0.0, 1.0]
    """
    arr = np.asarray(a)
    if arr.ndim != 2:
        raise ValueError(f"the map must be 2-D, got shape {arr.shape}")
    dtype = arr.dtype if np.issubdtype(arr.dtype, np.floating) else np.dtype(np.float64)
    ny, nx = arr.shape
    yy = np.asarray(y, dtype=np.float64)
    xx = np.asarray(x, dtype=np.float64)
    if yy.shape != xx.shape:
        raise ValueError(f"y and x must have one shape, got {yy.shape} and {xx.shape}")
    out = np.empty(yy.shape, dtype=dtype)
    flat, fy, fx, fo = arr.ravel(), yy.ravel(), xx.ravel(), out.ravel()
    # in chunks: a few small temporaries, reused from the heap and in cache
    for c0 in range(0, fy.size, CHUNK):
        sl = slice(c0, c0 + CHUNK)
        fo[sl] = _bilinear(flat, ny, nx, fy[sl], fx[sl])
    return out


def _bilinear(
    flat: npt.NDArray[np.generic], ny: int, nx: int, yy: FloatArray, xx: FloatArray
) -> FloatArray:
    """:func:`bilinear_nearest` of the C-ordered map ``flat`` (ny x nx), in float64."""
    y0, x0 = np.floor(yy), np.floor(xx)
    # scipy's weights (the second one is 1 minus the first, not the fraction itself);
    # the coordinates are not clamped, the cells are: beyond an edge both cells are the
    # edge cell, and the weights still sum to 1 as scipy sums them
    wy0 = 1.0 - (yy - y0)
    wx0 = 1.0 - (xx - x0)
    wy1, wx1 = 1.0 - wy0, 1.0 - wx0
    iy = y0.astype(np.intp)
    ix = x0.astype(np.intp)
    r0 = np.minimum(np.maximum(iy, 0), ny - 1) * nx
    r1 = np.minimum(np.maximum(iy + 1, 0), ny - 1) * nx
    ix0 = np.minimum(np.maximum(ix, 0), nx - 1)
    ix1 = np.minimum(np.maximum(ix + 1, 0), nx - 1)
    # gathered in the map's own dtype, then widened: no float64 copy of the map
    out = flat[r0 + ix0].astype(np.float64) * wy0 * wx0
    out += flat[r0 + ix1].astype(np.float64) * wy0 * wx1
    out += flat[r1 + ix0].astype(np.float64) * wy1 * wx0
    out += flat[r1 + ix1].astype(np.float64) * wy1 * wx1
    return out

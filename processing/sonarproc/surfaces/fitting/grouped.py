"""What the line and circle fits of many groups share, and the criterion's floor.

The surfaces of a room come as about a thousand groups of cells (or of echo points);
fitting them one by one costs a Python round trip and a small SVD or solve per group. The
fits here take all groups together: each group is a run of consecutive points, and every
sum a fit needs is one ``np.bincount`` over a group label per point, every 3 x 3 system
one closed-form solve per group in a vector. A group gives the same result alone or among
others (its sums are accumulated in the same order), so the one-group case is the
reference the surfaces' single fits use too.

* :func:`group_labels` and :func:`trimmed`: the groups' labels, and the points a fit
  keeps for its one refit (within ``max(3 rms, 2 cells)`` of the first fit); used by
  :func:`~sonarproc.surfaces.fitting.lines.fit_lines` and
  :func:`~sonarproc.surfaces.fitting.arcs.fit_circles`.
* :func:`floor_rms`: the points' RMS distance to their own means over bins of
  ``FLOOR_BIN_CELLS`` cells of arc length (a curve that follows the points about as
  closely as a flexible fit would).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["FLOOR_BIN_CELLS", "floor_rms", "group_labels", "scatter_rms", "trimmed"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: Arc-length bins (cells) of the criterion's floor.
FLOOR_BIN_CELLS = 5


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


def trimmed(resid: FloatArray, gid: IntArray, sizes: IntArray, cell: float) -> BoolArray:
    """Points within ``max(3 rms, 2 cell)`` of their group's fit."""
    g = sizes.size
    rms = np.sqrt(np.bincount(gid, weights=resid * resid, minlength=g) / np.maximum(sizes, 1))
    return np.asarray(np.abs(resid) <= np.maximum(3.0 * rms, 2.0 * cell)[gid])


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


def scatter_rms(
    x: FloatArray, y: FloatArray, s: FloatArray, sizes: IntArray, point: FloatArray,
    direction: FloatArray,
) -> FloatArray:  # fmt: skip
    """The scatter of each group's points about their neighbours, as an RMS (m).

    Each point's distance across its group's line (``point``, ``direction``: one row per
    group) is compared with the straight interpolation, at its arc length ``s``, between
    its two neighbours along the group; that deviation, divided by the factor
    ``sqrt(1 + a**2 + b**2)`` by which the two neighbours' own scatter (interpolation
    weights ``a`` and ``b``) enlarges it, estimates the scatter of one point. The line
    and any smooth bend of the surface over two neighbours' spacing cancel out: what is
    left is the points' own noise (for echo points, the range noise and the range's
    quantum), which no model of the surface can explain. A group of fewer than three
    points has none (0).

    Examples
    --------
    Points alternating 1 cm either side of a line: each deviates 2 cm from its
    neighbours' mean, and the scatter of one point is 2 cm / sqrt(1.5).

    >>> s = np.arange(5) * 0.1
    >>> y = np.array([0.01, -0.01, 0.01, -0.01, 0.01])
    >>> r = scatter_rms(s, y, s, np.array([5]), np.zeros((1, 2)), np.array([[1.0, 0.0]]))
    >>> round(float(r[0]), 5)
    0.01633
    """
    sizes = np.asarray(sizes, dtype=np.intp)
    g = int(sizes.size)
    if g == 0:
        return np.zeros(0)
    gid, _ = group_labels(sizes)
    normal = np.stack((-direction[:, 1], direction[:, 0]), axis=1)
    across = (x - point[gid, 0]) * normal[gid, 0] + (y - point[gid, 1]) * normal[gid, 1]
    order = np.lexsort((s, gid))
    e, t, k = across[order], s[order], gid[order]
    inner = np.flatnonzero((k[1:-1] == k[:-2]) & (k[1:-1] == k[2:])) + 1
    h1, h2 = t[inner] - t[inner - 1], t[inner + 1] - t[inner]
    span = h1 + h2
    ok = span > 0
    inner, h1, h2, span = inner[ok], h1[ok], h2[ok], span[ok]
    a, b = h2 / span, h1 / span
    dev = e[inner] - a * e[inner - 1] - b * e[inner + 1]
    v = dev * dev / (1.0 + a * a + b * b)
    cnt = np.bincount(k[inner], minlength=g)
    tot = np.bincount(k[inner], weights=v, minlength=g)
    return np.asarray(np.sqrt(tot / np.maximum(cnt, 1)))

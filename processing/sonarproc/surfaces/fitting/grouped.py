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

__all__ = ["FLOOR_BIN_CELLS", "floor_rms", "group_labels", "trimmed"]

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

"""Numpy operations on many short runs of one array at once (the surfaces of one map).

The extraction handles a thousand surfaces at once: their values lie in one array, each
surface's a contiguous *run* given by ``bounds`` (run ``g`` is
``values[bounds[g]:bounds[g + 1]]``). These functions give, for every run at once, what
numpy gives for one array, with the same floating-point results as the one-array call
on each run (the same operations in the same order), so that a per-run loop and these
agree to the last bit.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "bounds_of",
    "ragged_arange",
    "run_cumsum",
    "run_interp",
    "run_median",
    "run_searchsorted",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def bounds_of(sorted_ids: npt.ArrayLike, ids: npt.ArrayLike) -> IntArray:
    """Run bounds of each id of ``ids`` in ``sorted_ids`` (ascending): shape ``(len(ids) + 1,)``.

    Only meaningful when ``ids`` holds every id present, in ascending order.

    Examples
    --------
    >>> bounds_of([0, 0, 2, 2, 2, 5], [0, 2, 5]).tolist()
    [0, 2, 5, 6]
    """
    s = np.asarray(sorted_ids)
    i = np.asarray(ids)
    return np.append(np.searchsorted(s, i, side="left"), s.size).astype(np.intp)


def ragged_arange(counts: npt.ArrayLike) -> tuple[IntArray, IntArray]:
    """For counts ``c``, the run of each element and its place in the run (``0 .. c-1``).

    Examples
    --------
    >>> run, k = ragged_arange([2, 0, 3])
    >>> run.tolist(), k.tolist()
    ([0, 0, 2, 2, 2], [0, 1, 0, 1, 2])
    """
    c = np.asarray(counts, dtype=np.intp)
    run = np.repeat(np.arange(c.size, dtype=np.intp), c)
    first = np.cumsum(c) - c
    return run, np.arange(run.size, dtype=np.intp) - first[run]


def run_cumsum(values: FloatArray, bounds: IntArray) -> FloatArray:
    """``np.cumsum`` of every run separately (each restarts at its first value).

    Runs are padded into rows of a few blocks (runs of similar length together) and
    summed along the rows: the sums are sequential, as ``np.cumsum`` of each run.

    Examples
    --------
    >>> run_cumsum(np.array([1.0, 2.0, 3.0, 10.0, 20.0]), np.array([0, 3, 5])).tolist()
    [1.0, 3.0, 6.0, 10.0, 30.0]
    """
    out = np.empty(values.size, dtype=np.float64)
    lengths = np.diff(bounds)
    nonempty = np.flatnonzero(lengths > 0)
    if nonempty.size == 0:
        return out
    size_class = np.ceil(np.log2(lengths[nonempty])).astype(np.intp)
    for c in np.unique(size_class).tolist():
        runs = nonempty[size_class == c]
        width = int(lengths[runs].max())
        col = np.arange(width, dtype=np.intp)
        idx = bounds[runs][:, None] + col
        inside = col < lengths[runs][:, None]
        block = np.where(inside, values[np.where(inside, idx, 0)], 0.0)
        out[idx[inside]] = np.cumsum(block, axis=1)[inside]
    return out


def run_searchsorted(
    knots: FloatArray, bounds: IntArray, queries: FloatArray, run: IntArray, *, side: str = "right"
) -> IntArray:
    """For each query, ``np.searchsorted`` into the knots of its run (sorted ascending).

    One ``searchsorted`` on complex keys ``run + 1j * value``: numpy orders complex
    numbers by real part, then imaginary part, so by run, then by value, exactly.

    Examples
    --------
    >>> knots = np.array([0.0, 1.0, 2.0, 0.0, 5.0])
    >>> run_searchsorted(knots, np.array([0, 3, 5]), np.array([1.0, 1.0, 9.0]),
    ...                  np.array([0, 1, 1])).tolist()
    [2, 1, 2]
    """
    n_knots = np.diff(bounds)
    keys = np.repeat(np.arange(n_knots.size, dtype=np.float64), n_knots) + 1j * knots
    at = np.searchsorted(keys, run + 1j * queries, side="right" if side == "right" else "left")
    return np.asarray(at - bounds[:-1][run], dtype=np.intp)


def run_interp(
    t: FloatArray, run: IntArray, xp: FloatArray, fp: FloatArray, bounds: IntArray
) -> FloatArray:
    """``np.interp(t, xp_g, fp_g)`` for each query with the knots of its run ``g``.

    ``fp`` may have columns (shape ``(K, C)``): each is interpolated, and the knots
    are searched once. Every run must have at least one knot. The formula is numpy's,
    so the results are bit for bit those of ``np.interp`` on each run.

    Examples
    --------
    >>> xp = np.array([0.0, 1.0, 0.0, 2.0]); fp = np.array([0.0, 10.0, 5.0, 7.0])
    >>> run_interp(np.array([0.5, 1.0, 3.0]), np.array([0, 1, 1]), xp, fp,
    ...            np.array([0, 2, 4])).tolist()
    [5.0, 6.0, 7.0]
    """
    lo, hi = bounds[:-1][run], bounds[1:][run]
    j = lo + run_searchsorted(xp, bounds, t, run, side="right") - 1
    j = np.clip(j, lo, np.maximum(hi - 2, lo))
    j1 = np.minimum(j + 1, hi - 1)
    f = fp if fp.ndim == 2 else fp[:, None]
    tt, x0, x1 = t[:, None], xp[j][:, None], xp[j1][:, None]
    f0, f1 = f[j], f[j1]
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (f1 - f0) / (x1 - x0)
        out = slope * (tt - x0) + f0
    over = t >= xp[hi - 1]
    out[over] = f[hi[over] - 1]
    under = t < xp[lo]
    out[under] = f[lo[under]]
    return out if fp.ndim == 2 else out[:, 0]


def run_median(values: FloatArray, bounds: IntArray) -> FloatArray:
    """``np.median`` of every run (NaN for an empty run).

    Examples
    --------
    >>> run_median(np.array([3.0, 1.0, 2.0, 4.0, 8.0]), np.array([0, 3, 5])).tolist()
    [2.0, 6.0]
    """
    lengths = np.diff(bounds)
    run = np.repeat(np.arange(lengths.size), lengths)
    # complex numbers sort by real part, then imaginary part: by run, then by value
    ordered = np.sort(run + 1j * values).imag
    out = np.full(lengths.size, np.nan)
    ok = lengths > 0
    lo, n = bounds[:-1][ok], lengths[ok]
    a = ordered[lo + (n - 1) // 2]
    b = ordered[lo + n // 2]
    # numpy's median: the middle value, or the mean of the two middle values
    out[ok] = np.where(n % 2 == 1, a, (a + b) / 2.0)
    return out

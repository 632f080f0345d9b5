"""A cubic smoothing spline at a given smoothing, built without a loop per point.

The spline minimises ``sum_i w_i (y_i - g(x_i))^2 + lam * integral g''(x)^2 dx``, the
criterion of :func:`scipy.interpolate.make_smoothing_spline`, and this is the same
computation (Eilers & Marx's natural-spline basis over B-splines, one banded solve),
giving the same knots and coefficients. scipy builds the penalty's bands one data point
at a time in Python (each a divided difference of five abscissae) and reads the design
matrix's bands by sparse slicing; here both are array operations. A profile has one
point per grid column, up to thousands, and ``--auto`` fits a hundred of them per log:
this is about ten times faster at that size.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["smoothing_bspline"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def _divided_difference_weights(windows: FloatArray) -> FloatArray:
    """``1 / prod_{k != i} (x_i - x_k)`` for each row of abscissae ``windows`` (m, w)."""
    diff = windows[:, :, None] - windows[:, None, :]
    i = np.arange(windows.shape[1])
    diff[:, i, i] = 1.0
    return np.asarray(1.0 / diff.prod(axis=2), dtype=np.float64)


def smoothing_bspline(
    x: FloatArray, y: FloatArray, w: FloatArray, lam: float
) -> tuple[FloatArray, FloatArray]:
    """Knots and coefficients of the cubic smoothing spline of ``y(x)`` at smoothing ``lam``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Strictly increasing abscissae, ``n >= 5``.
    y, w : ndarray, shape (n,)
        Ordinates and their positive weights.
    lam : float
        Roughness penalty, ``>= 0``.

    Returns
    -------
    knots : ndarray, shape (n + 6,)
    coef : ndarray, shape (n + 2,)
        Of the degree-3 B-spline, as ``make_smoothing_spline(x, y, w, lam)`` gives them.

    Raises
    ------
    ValueError
        Fewer than 5 points, abscissae not increasing, a weight not positive, a negative
        ``lam``.
    numpy.linalg.LinAlgError
        A singular system.

    Examples
    --------
    >>> from scipy.interpolate import BSpline
    >>> x = np.linspace(0.0, 1.0, 6)
    >>> knots, coef = smoothing_bspline(x, 2 * x + 1, np.ones(6), 0.1)
    >>> bool(np.allclose(BSpline(knots, coef, 3)(x), 2 * x + 1))
    True
    """
    # imported here, as fit_spline does: scipy.interpolate is slow to import
    from scipy.interpolate import BSpline
    from scipy.linalg import solve_banded

    n = x.size
    if n < 5 or y.shape != x.shape or w.shape != x.shape:
        raise ValueError("x, y and w must be 1-D arrays of one length, at least 5")
    if np.any(np.diff(x) <= 0):
        raise ValueError("x must be strictly increasing")
    if np.any(w <= 0):
        raise ValueError("weights must be positive")
    if lam < 0:
        raise ValueError("the smoothing must be non-negative")
    t = np.r_[[x[0]] * 3, x, [x[-1]] * 3]
    design = BSpline.design_matrix(x, t, 3)
    # k + 1 = 4 stored entries per row, in consecutive columns from the row's first
    values = design.data.reshape(n, 4)
    first = design.indices.reshape(n, 4)[:, 0]

    def b(row: IntArray | int, col: IntArray | int) -> FloatArray:
        k = np.asarray(col) - first[row]
        inside = (k >= 0) & (k < 4)
        return np.asarray(np.where(inside, values[row, np.clip(k, 0, 3)], 0.0), dtype=np.float64)

    # the design matrix in the natural-spline basis, as 5 bands
    basis = np.zeros((5, n))
    k = np.arange(n - 4)
    for i in range(1, 4):
        basis[i, 2:-2] = b(i + k, 3 + k)
    b00, b11, b12, b22 = (float(b(r, c)) for r, c in ((0, 0), (1, 1), (1, 2), (2, 2)))
    e33, e22, e23, e11 = (float(b(n - r, n + 2 - c)) for r, c in ((3, 3), (2, 2), (2, 3), (1, 1)))
    basis[1, 1] = b00
    basis[2, :2] = ((x[2] + x[1] - 2 * x[0]) * b00, b11 + b12)
    basis[3, :2] = ((x[2] - x[0]) * b11, b22)
    basis[1, -2:] = (e33, (x[-1] - x[-3]) * e22)
    basis[2, -2:] = (e23 + e22, (2 * x[-1] - x[-2] - x[-3]) * e11)
    basis[3, -2] = e11
    # the penalty over the weights, W^-1 E, as 5 bands
    penalty = np.zeros((5, n))
    penalty[2:, 0] = _divided_difference_weights(x[None, :3])[0] / w[:3]
    penalty[1:, 1] = _divided_difference_weights(x[None, :4])[0] / w[:4]
    xs = np.lib.stride_tricks.sliding_window_view(x, 5)
    ws = np.lib.stride_tricks.sliding_window_view(w, 5)
    inner = (xs[:, 4] - xs[:, 0])[:, None] * _divided_difference_weights(xs) / ws
    penalty[:, 2:-2] = inner.T
    penalty[:-1, -2] = -_divided_difference_weights(x[None, -4:])[0] / w[-4:]
    penalty[:-2, -1] = _divided_difference_weights(x[None, -3:])[0] / w[-3:]
    penalty *= 6
    c = solve_banded((2, 2), basis + lam * penalty, y)
    # back from the natural-spline basis to the B-spline one
    coef = np.r_[
        c[0] * (t[5] + t[4] - 2 * t[3]) + c[1],
        c[0] * (t[5] - t[3]) + c[1],
        c[1:-1],
        c[-1] * (t[-4] - t[-6]) + c[-2],
        c[-1] * (2 * t[-4] - t[-5] - t[-6]) + c[-2],
    ]
    return t, np.asarray(coef, dtype=np.float64)

"""Cubic smoothing splines over few knots, the smoothing chosen by GCV (our kernel, kept).

The spline ``g`` minimises ``sum_i w_i (y_i - g(t_i))^2 + lam * integral g''(t)^2 dt``
(the criterion of :func:`scipy.interpolate.make_smoothing_spline`). It is the natural
cubic spline through its own values at the knots, found in the Reinsch form of Green &
Silverman (*Nonparametric Regression and Generalized Linear Models*, 1994, ch. 2):
``g = (W + lam K)^-1 W y`` with ``K = Q R^-1 Q^T`` from the knot spacings.

Surfaces are fitted over at most a few dozen arc-length bins, so the matrices are small
and dense, and one eigendecomposition of ``W^-1/2 K W^-1/2`` gives the fit and the
trace of the hat matrix for every ``lam`` at once. The smoothing is the minimum of the
GCV score ``n * sum (y - g)^2 / (n - tr H)^2`` (unweighted residuals and ``lam`` at most
``n``, as scipy's choice) over a logarithmic grid, refined once around its best point:
no per-trial Python loop and no banded solver per trial, and no import of
:mod:`scipy.interpolate`.

It is kept, for the surfaces' splines in arc length (at most 64 bins, two series),
because ``./scripts/bench`` (``tests/benchmarks/test_bench_surface_splines.py``) measures it
far faster than :func:`scipy.interpolate.make_smoothing_spline` on them: ratios of 0.002 at
20 bins and 0.003 at 64 (about 0.5 and 1.4 ms against 230 and 420 ms), the two splines at
most 0.15 mm apart. The dense eigendecomposition is cubic in the knots, so the paper's
profile spline (one knot per map column, up to thousands) stays scipy's
(:func:`sonarproc.fit.fit_spline`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["SmoothingSpline", "smoothing_spline"]

FloatArray = npt.NDArray[np.float64]

#: Points of the coarse and of the fine grid of log(lam).
_GRID = 64


class SmoothingSpline:
    """A fitted natural cubic smoothing spline of one or several series.

    Attributes
    ----------
    knots : ndarray, shape (n,)
    values : ndarray, shape (n, k)
        The spline's values at the knots.
    second : ndarray, shape (n, k)
        Its second derivatives there (zero at both ends: a natural spline).
    lam : ndarray, shape (k,)
        The smoothing of each series.
    """

    def __init__(self, knots: FloatArray, values: FloatArray, second: FloatArray, lam: FloatArray):
        self.knots, self.values, self.second, self.lam = knots, values, second, lam

    def __call__(self, t: npt.ArrayLike) -> FloatArray:
        """Values at ``t`` (clipped to the knots' span), shape ``(len(t), k)``."""
        tk, g, gam = self.knots, self.values, self.second
        q = np.clip(np.asarray(t, dtype=np.float64).ravel(), tk[0], tk[-1])
        i = np.clip(np.searchsorted(tk, q, side="right") - 1, 0, tk.size - 2)
        h = (tk[i + 1] - tk[i])[:, None]
        a = (q - tk[i])[:, None]
        b = (tk[i + 1] - q)[:, None]
        linear = (a * g[i + 1] + b * g[i]) / h
        bend = a * b / 6.0 * ((1.0 + a / h) * gam[i + 1] + (1.0 + b / h) * gam[i])
        return np.asarray(linear - bend, dtype=np.float64)


def _reinsch(t: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Green & Silverman's Q (n, n-2) and R (n-2, n-2) for knots ``t``."""
    n = t.size
    h = np.diff(t)
    q = np.zeros((n, n - 2))
    j = np.arange(n - 2)
    q[j, j] = 1.0 / h[:-1]
    q[j + 1, j] = -1.0 / h[:-1] - 1.0 / h[1:]
    q[j + 2, j] = 1.0 / h[1:]
    r = np.diag((h[:-1] + h[1:]) / 3.0)
    off = h[1:-1] / 6.0
    r[j[:-1], j[:-1] + 1] = off
    r[j[:-1] + 1, j[:-1]] = off
    return q, r


def smoothing_spline(
    t: npt.ArrayLike, y: npt.ArrayLike, w: npt.ArrayLike | None = None, *, lam: float | None = None
) -> SmoothingSpline:
    """Fit a cubic smoothing spline to each column of ``y`` (see the module notes).

    Parameters
    ----------
    t : array_like, shape (n,)
        Strictly increasing abscissae, n >= 3.
    y : array_like, shape (n,) or (n, k)
        One series per column; each gets its own smoothing.
    w : array_like, shape (n,), optional
        Positive weights (default 1).
    lam : float, optional
        The smoothing for every series; default: chosen by GCV per series.

    Returns
    -------
    SmoothingSpline

    Raises
    ------
    ValueError
        Fewer than 3 points, abscissae not strictly increasing, weights not positive.

    Examples
    --------
    Points on a straight line are fitted exactly, whatever the smoothing:

    >>> t = np.linspace(0.0, 1.0, 6)
    >>> f = smoothing_spline(t, 2 * t + 1)
    >>> np.round(f([0.25, 0.5]).ravel(), 9).tolist()
    [1.5, 2.0]
    """
    tt = np.asarray(t, dtype=np.float64).ravel()
    yy = np.asarray(y, dtype=np.float64)
    yy = yy.reshape(tt.size, -1)
    n = tt.size
    if n < 3:
        raise ValueError(f"a smoothing spline needs at least 3 points, got {n}")
    if not np.all(np.diff(tt) > 0):
        raise ValueError("the abscissae must be strictly increasing")
    ww = np.ones(n) if w is None else np.broadcast_to(np.asarray(w, dtype=np.float64), (n,))
    if not np.all(ww > 0):
        raise ValueError("the weights must be positive")
    q, r = _reinsch(tt)
    k_mat = q @ np.linalg.solve(r, q.T)
    root = np.sqrt(ww)
    kappa, u = np.linalg.eigh(k_mat / root[:, None] / root[None, :])
    kappa = np.maximum(kappa, 0.0)
    z = u.T @ (root[:, None] * yy)  # (n, k)
    if lam is None:
        lams = np.array([_gcv_lam(kappa, u, z[:, c], root, n) for c in range(yy.shape[1])])
    else:
        lams = np.full(yy.shape[1], float(lam))
    shrink = 1.0 / (1.0 + lams[None, :] * kappa[:, None])  # (n, k)
    values = (u @ (shrink * z)) / root[:, None]
    second = np.zeros_like(values)
    second[1:-1] = np.linalg.solve(r, q.T @ values)
    return SmoothingSpline(tt, values, second, lams)


def _gcv_lam(kappa: FloatArray, u: FloatArray, z: FloatArray, root: FloatArray, n: int) -> float:
    """The GCV choice of ``lam`` in (0, n] for one series (eigen form)."""
    top = float(np.log(n))
    positive = kappa[kappa > 1e-12 * max(float(kappa.max()), 1e-300)]
    # below 1e-3 / max(kappa) every eigenvalue is left unshrunk: interpolation
    bottom = float(np.log(1e-3 / positive.max())) if positive.size else top - 1.0
    bottom = min(bottom, top - 1.0)

    def scores(log_lam: FloatArray) -> FloatArray:
        lam = np.exp(log_lam)
        damp = (lam[None, :] * kappa[:, None]) / (1.0 + lam[None, :] * kappa[:, None])
        resid = (u @ (damp * z[:, None])) / root[:, None]  # (n, L) unweighted residuals
        trace = np.sum(1.0 - damp, axis=0)
        return np.asarray(n * np.sum(resid**2, axis=0) / np.maximum(n - trace, 1e-12) ** 2)

    grid = np.linspace(bottom, top, _GRID)
    best = int(np.argmin(scores(grid)))
    step = grid[1] - grid[0]
    fine = np.linspace(max(grid[best] - step, bottom), min(grid[best] + step, top), _GRID)
    return float(np.exp(fine[int(np.argmin(scores(fine)))]))

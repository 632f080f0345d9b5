"""Beyond the paper: a Huber-robust polynomial over the points, and its order chosen
by cross-validation over columns (no ground truth)."""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

from sonarproc.fit._curves import solve_normal
from sonarproc.fit._models import FitFailure, FloatArray, PolyFit, as_floats

__all__ = ["HUBER_C", "fit_polynomial_robust", "select_order_cv"]

log = logging.getLogger(__name__)


#: Huber's tuning constant: 95 % efficiency for Gaussian residuals.
HUBER_C = 1.345
#: Smallest residual scale (m) the Huber weights use, so points exactly on a curve do not
#: make every residual an outlier.
SCALE_FLOOR = 1e-4


def _vander(x: FloatArray, lo: float, hi: float, order: int) -> FloatArray:
    u = (2.0 * x - (lo + hi)) / (hi - lo)
    return as_floats(np.polynomial.chebyshev.chebvander(u, order))


def _mad_scale(r: FloatArray) -> float:
    return max(1.4826 * float(np.median(np.abs(r - np.median(r)))), SCALE_FLOOR)


def _irls(
    v: FloatArray, y: FloatArray, w: FloatArray, *, robust: bool, max_iter: int, tol: float
) -> tuple[FloatArray, float] | None:
    """Weighted (Huber-IRLS when ``robust``) least squares; ``(coef, scale)`` or ``None``."""
    weights = w.copy()
    coef: FloatArray | None = None
    scale = SCALE_FLOOR
    for _ in range(max_iter if robust else 1):
        sw = np.sqrt(weights)
        # normal equations in the well-conditioned Chebyshev basis: no threaded BLAS
        # start-up per solve (these systems are thousands x at most 16)
        new = solve_normal(v * sw[:, None], y * sw)
        if new is None:
            return None
        r = y - v @ new
        scale = _mad_scale(r)
        if coef is not None and float(np.max(np.abs(new - coef))) <= tol:
            coef = new
            break
        coef = new
        k = HUBER_C * scale
        a = np.abs(r)
        weights = w * np.where(a <= k, 1.0, k / np.maximum(a, 1e-300))
    assert coef is not None
    return coef, scale


def fit_polynomial_robust(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    weights: npt.ArrayLike,
    *,
    order: int,
    robust: bool = True,
    max_iter: int = 50,
    tol: float = 1e-7,
) -> PolyFit | FitFailure:
    """Polynomial of order ``order`` over individual points, Huber-robust and weighted.

    Minimises ``sum_j w_j rho(p(x_j) - y_j)`` with Huber's ``rho`` (quadratic within
    ``1.345 s`` of the curve, linear beyond; ``s`` the MAD scale of the residuals, at least
    0.1 mm) by iteratively reweighted least squares, in the Chebyshev basis on the points'
    x-range. ``weights`` are prior weights, e.g. how many arcs cross each cell; with
    ``robust=False`` and unit weights this is the paper's Eq. 2 exactly.

    Parameters
    ----------
    x, y : array_like, shape (P,)
        Points (m).
    weights : array_like, shape (P,)
        Prior weight of each point (>= 0; points with 0 are ignored).
    order : int
        Polynomial order (>= 0).
    robust : bool
        Huber IRLS (default) or one weighted least-squares solve.
    max_iter, tol : int, float
        IRLS stops after ``max_iter`` solves or when no coefficient moves more than ``tol``.

    Returns
    -------
    PolyFit or FitFailure

    Examples
    --------
    >>> x = np.linspace(0.0, 1.0, 50); y = 2.0 * x; y[10] = 9.0   # one wild point
    >>> f = fit_polynomial_robust(x, y, np.ones(50), order=1)
    >>> round(float(f(1.0)[()]), 3)
    2.0
    """
    if order < 0:
        raise ValueError(f"polynomial order must be >= 0, got {order}")
    xa, ya, wa = as_floats(x), as_floats(y), as_floats(weights)
    if xa.ndim != 1 or xa.shape != ya.shape or xa.shape != wa.shape:
        raise ValueError("x, y and weights must be 1-D arrays of one length")
    keep = wa > 0
    xk, yk, wk = xa[keep], ya[keep], wa[keep]
    if xk.size == 0:
        return FitFailure("poly", "no points left in the processed map", order)
    distinct = np.unique(xk).size
    if distinct < order + 1:
        return FitFailure(
            "poly",
            f"only {distinct} distinct column(s) hold points; order {order} needs {order + 1}",
            order,
        )
    lo, hi = float(xk.min()), float(xk.max())
    if hi <= lo:
        hi = lo + 1.0
    out = _irls(_vander(xk, lo, hi, order), yk, wk, robust=robust, max_iter=max_iter, tol=tol)
    if out is None:
        return FitFailure("poly", f"rank-deficient system (order {order})", order)
    method = "huber irls" if robust else "weighted least squares"
    return PolyFit(order=order, coef=out[0], domain=(lo, hi), method=method)


def select_order_cv(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    weights: npt.ArrayLike,
    *,
    orders: range = range(0, 16),
    folds: int = 5,
    seed: int = 0,
    robust: bool = True,
    tolerance: float = 0.02,
) -> tuple[int, dict[int, float]]:
    """Choose the polynomial order by ``folds``-fold cross-validation over columns.

    The distinct x values (map columns) are dealt at random (seeded) into ``folds``
    groups; each order is fitted (:func:`fit_polynomial_robust`) without one group and
    scored on it with the Huber loss (threshold ``1.345 s``, ``s`` the residual scale of
    the highest-order fit on all points), weighted by ``weights``. Orders are tried while
    every training set keeps at least ``2 (m + 1)`` columns. The chosen order is the
    smallest whose score is within ``tolerance`` (relative) of the best: as good, simpler.
    No ground truth is involved.

    Returns
    -------
    (order, scores)
        The chosen order and the mean held-out loss (m^2) of every order tried.

    Raises
    ------
    ValueError
        Fewer than ``2 (min(orders) + 1)`` columns per training set, or ``folds < 2``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = np.repeat(np.linspace(-1.0, 1.0, 60), 3)
    >>> y = 0.3 * x**3 - x + 0.01 * rng.standard_normal(x.size)
    >>> select_order_cv(x, y, np.ones(x.size), orders=range(0, 9))[0]
    3
    """
    if folds < 2:
        raise ValueError(f"folds must be >= 2, got {folds}")
    xa, ya, wa = as_floats(x), as_floats(y), as_floats(weights)
    keep = wa > 0
    xa, ya, wa = xa[keep], ya[keep], wa[keep]
    cols, col_of = np.unique(xa, return_inverse=True)
    group = np.random.default_rng(seed).permutation(cols.size) % folds
    fold = group[col_of]
    train_cols = cols.size - int(np.max(np.bincount(group, minlength=folds)))
    usable = [m for m in orders if train_cols >= 2 * (m + 1)]
    if not usable:
        raise ValueError(
            f"{cols.size} column(s) with points are too few to choose an order by "
            f"{folds}-fold cross-validation"
        )
    lo, hi = float(xa.min()), float(xa.max())
    if hi <= lo:
        hi = lo + 1.0
    top = _irls(_vander(xa, lo, hi, usable[-1]), ya, wa, robust=robust, max_iter=30, tol=1e-6)
    scale = top[1] if top is not None else _mad_scale(ya - np.median(ya))
    k = HUBER_C * scale
    scores: dict[int, float] = {}
    total_w = float(wa.sum())
    for m in usable:
        v = _vander(xa, lo, hi, m)
        loss = 0.0
        for g in range(folds):
            test = fold == g
            if not test.any():
                continue
            fit = _irls(v[~test], ya[~test], wa[~test], robust=robust, max_iter=20, tol=1e-6)
            if fit is None:
                loss = np.inf
                break
            a = np.abs(ya[test] - v[test] @ fit[0])
            rho = np.where(a <= k, 0.5 * a * a, k * (a - 0.5 * k))
            loss += float(np.sum(wa[test] * rho))
        scores[m] = loss / total_w
    best = min(scores.values())
    chosen = min(m for m, s in scores.items() if s <= best * (1.0 + tolerance))
    return chosen, scores

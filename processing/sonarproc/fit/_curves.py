"""Least-squares fits of binned points (section 3.2 of the paper).

Every fit takes the points grouped by column (or by angular bin): the bin positions, the
mean ordinate of the points in each bin and the number of points. Eq. 2 sums the squared
residuals over every point, and for points sharing an abscissa
``sum_j (p(x_i) - f_ij)**2 = M_i (p(x_i) - mean_i)**2 + const``, so a fit to the bin means
weighted by ``M_i`` is exactly the paper's fit over every point, at the cost of one row
per column instead of one per point.
"""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

from sonarproc.fit._models import FitFailure, FloatArray, PolarFit, PolyFit, SplineFit, as_floats
from sonarproc.fit._smoothing import smoothing_bspline

__all__ = ["check_bins", "fit_polar", "fit_polynomial", "fit_spline", "solve_normal"]

log = logging.getLogger(__name__)


def check_bins(
    kind: str, x: FloatArray, y: FloatArray, w: FloatArray, needed: int, order: int
) -> FitFailure | None:
    if x.shape != y.shape or x.shape != w.shape or x.ndim != 1:
        raise ValueError("x, y and counts must be 1-D arrays of one length")
    used = int(np.count_nonzero(w > 0))
    if used == 0:
        return FitFailure(kind, "no points left in the processed map", order)
    distinct = np.unique(x[w > 0]).size
    if distinct < needed:
        return FitFailure(
            kind,
            f"only {distinct} distinct column(s) hold points; order {order} needs {needed}",
            order,
        )
    return None


def solve_normal(a: FloatArray, b: FloatArray) -> FloatArray | None:
    """Least squares ``min |a x - b|`` by the (Jacobi-scaled) normal equations.

    The Gram matrix is formed with ``einsum`` rather than BLAS: for these tall, narrow
    systems (thousands of bins, tens of parameters) a threaded BLAS call costs more in
    start-up than the arithmetic. Returns ``None`` when the system is numerically
    rank-deficient. Fine for the near-orthogonal Fourier basis; not a general solver.
    """
    gram = np.einsum("ij,ik->jk", a, a)
    rhs = np.einsum("ij,i->j", a, b)
    d = np.sqrt(np.diag(gram))
    if np.any(d == 0):
        return None
    scaled = gram / np.outer(d, d)
    eig = np.linalg.eigvalsh(scaled)
    if eig[0] <= 1e-10 * eig[-1]:
        return None
    return as_floats(np.linalg.solve(scaled, rhs / d) / d)


def fit_polynomial(
    x: npt.ArrayLike, y: npt.ArrayLike, counts: npt.ArrayLike, *, order: int
) -> PolyFit | FitFailure:
    """Least-squares polynomial of order ``order`` over every point (Eq. 2 of the paper).

    Parameters
    ----------
    x : array_like, shape (K,)
        Column centres (m).
    y : array_like, shape (K,)
        Mean ordinate of the points in each column (m).
    counts : array_like, shape (K,)
        Number of points in each column (``M_i``); columns with 0 are ignored.
    order : int
        Polynomial order ``m`` (>= 0).

    Returns
    -------
    PolyFit or FitFailure

    Examples
    --------
    >>> x = np.linspace(0.0, 2.0, 21)
    >>> f = fit_polynomial(x, 1.0 + 0.5 * x**2, np.ones(21), order=2)
    >>> round(float(f(3.0)[()]), 6)
    5.5
    """
    if order < 0:
        raise ValueError(f"polynomial order must be >= 0, got {order}")
    xa, ya, wa = as_floats(x), as_floats(y), as_floats(counts)
    failure = check_bins("poly", xa, ya, wa, order + 1, order)
    if failure is not None:
        return failure
    keep = wa > 0
    xk, yk, wk = xa[keep], ya[keep], wa[keep]
    lo, hi = float(xk.min()), float(xk.max())
    if hi <= lo:
        hi = lo + 1.0  # order 0 with one column: any non-empty domain will do
    cheb, (_resid, rank, _sv, _rcond) = np.polynomial.Chebyshev.fit(
        xk, yk, order, domain=[lo, hi], w=np.sqrt(wk), full=True
    )
    if rank < order + 1:
        return FitFailure("poly", f"rank-deficient system (rank {rank} < {order + 1})", order)
    return PolyFit(order=order, coef=as_floats(cheb.coef), domain=(lo, hi))


def fit_spline(
    x: npt.ArrayLike, y: npt.ArrayLike, counts: npt.ArrayLike, *, lam: float | None = None
) -> SplineFit | FitFailure:
    """Cubic smoothing spline through the column means, weighted by the column counts.

    Parameters
    ----------
    x, y, counts : array_like, shape (K,)
        As for :func:`fit_polynomial`.
    lam : float, optional
        Roughness penalty; ``None`` chooses it by generalised cross-validation
        (:func:`scipy.interpolate.make_smoothing_spline`). A given one is fitted by
        :func:`~sonarproc.fit._smoothing.smoothing_bspline`, the same spline.

    Returns
    -------
    SplineFit or FitFailure
    """
    from scipy.interpolate import make_smoothing_spline

    xa, ya, wa = as_floats(x), as_floats(y), as_floats(counts)
    failure = check_bins("spline", xa, ya, wa, 5, 3)
    if failure is not None:
        return failure
    keep = wa > 0
    order = np.argsort(xa[keep], kind="stable")
    xk, yk, wk = xa[keep][order], ya[keep][order], wa[keep][order]
    try:
        if lam is None:
            spl = make_smoothing_spline(xk, yk, w=wk, lam=lam)
            knots, coef = as_floats(spl.t), as_floats(spl.c)
        else:
            knots, coef = smoothing_bspline(xk, yk, wk, lam)
    except (ValueError, np.linalg.LinAlgError) as err:
        return FitFailure("spline", f"smoothing spline failed: {err}", 3)
    return SplineFit(
        knots=knots,
        coef=coef,
        degree=3,
        domain=(float(xk[0]), float(xk[-1])),
        lam=lam,
    )


def fit_polar(
    phi: npt.ArrayLike,
    r: npt.ArrayLike,
    counts: npt.ArrayLike,
    *,
    centre: tuple[float, float],
    order: int,
) -> PolarFit | FitFailure:
    """Least-squares Fourier series r(phi) of ``order`` harmonics about ``centre``.

    Parameters
    ----------
    phi : array_like, shape (K,)
        Angular bin centres (rad).
    r : array_like, shape (K,)
        Mean radius of the points in each bin (m).
    counts : array_like, shape (K,)
        Number of points in each bin; bins with 0 are ignored.
    centre : (float, float)
        The centre the angles and radii are measured about (m).
    order : int
        Number of harmonics (>= 0); the fit has ``2 * order + 1`` parameters.

    Returns
    -------
    PolarFit or FitFailure
    """
    if order < 0:
        raise ValueError(f"polar order must be >= 0, got {order}")
    pa, ra, wa = as_floats(phi), as_floats(r), as_floats(counts)
    failure = check_bins("polar", pa, ra, wa, 2 * order + 1, order)
    if failure is not None:
        return failure
    keep = wa > 0
    pk, rk, sw = pa[keep], ra[keep], np.sqrt(wa[keep])
    k = np.arange(1, order + 1, dtype=np.float64)
    ang = np.multiply.outer(pk, k)
    design = np.hstack((np.ones((pk.size, 1)), np.cos(ang), np.sin(ang)))
    sol = solve_normal(design * sw[:, None], rk * sw)
    if sol is None:
        return FitFailure("polar", "rank-deficient system (bins too unevenly spread)", order)
    return PolarFit(
        centre=(float(centre[0]), float(centre[1])),
        order=order,
        a0=float(sol[0]),
        a=as_floats(sol[1 : order + 1]),
        b=as_floats(sol[order + 1 :]),
    )


# --- beyond the paper: robust fit over the points, order chosen from the data -------------

"""Curve fitting of the processed map (section 3.2 of the paper).

Three fits, each a pure function from points to a small immutable fit object:

* :func:`fit_polynomial`: the paper's least-squares polynomial of order ``m`` (Eq. 2),
  expressed in the Chebyshev basis on the domain scaled to [-1, 1] so high orders stay
  well conditioned.
* :func:`fit_spline`: a cubic smoothing spline (penalised least squares, the smoothing
  chosen by generalised cross-validation unless given).
* :func:`fit_polar`: for a map around the robot (a room), a truncated Fourier series
  r(phi) about a centre, periodic by construction.

Every fit takes the points grouped by column (or by angular bin): the bin positions,
the mean ordinate of the points in each bin and the number of points. Eq. 2 sums the
squared residuals over every point, and for points sharing an abscissa
``sum_j (p(x_i) - f_ij)**2 = M_i (p(x_i) - mean_i)**2 + const``, so a fit to the bin means
weighted by ``M_i`` is *exactly* the paper's fit over every point, at the cost of one
row per column instead of one per point.

Degenerate input (no points, fewer distinct bins than parameters, a rank-deficient
system) returns a :class:`FitFailure` that says why, never a curve.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

__all__ = [
    "Fit",
    "FitFailure",
    "FitKind",
    "PolarFit",
    "PolyFit",
    "SplineFit",
    "fit_polar",
    "fit_polynomial",
    "fit_polynomial_robust",
    "fit_spline",
    "select_order_cv",
]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
FitKind = Literal["poly", "spline", "polar"]


def _floats(a: npt.ArrayLike) -> FloatArray:
    return np.asarray(a, dtype=np.float64)


@dataclass(frozen=True)
class FitFailure:
    """A fit that could not be made, and why (shown in the report instead of a curve)."""

    kind: str
    reason: str
    order: int | None = None
    ok: bool = False

    def to_json(self) -> dict[str, Any]:
        """Return the JSON-ready description used in ``report.json``."""
        return {"kind": self.kind, "ok": False, "order": self.order, "reason": self.reason}


@dataclass(frozen=True)
class PolyFit:
    """A polynomial y = p(x) of order ``order`` in the Chebyshev basis.

    ``p(x) = sum_k coef[k] * T_k(u)`` with ``u = (2x - (a + b)) / (b - a)`` and
    ``(a, b) = domain``; ``numpy.polynomial.Chebyshev(coef, domain=domain)`` evaluates it.
    """

    order: int
    coef: FloatArray
    domain: tuple[float, float]
    kind: str = "poly"
    ok: bool = True
    method: str = "least squares"
    #: Set when ``order`` was chosen from the data: ``{"method", "scores"}``.
    selection: dict[str, Any] | None = None

    def __call__(self, x: npt.ArrayLike) -> FloatArray:
        """Evaluate the polynomial at ``x`` (extrapolating outside the domain)."""
        cheb = np.polynomial.Chebyshev(self.coef, domain=list(self.domain))
        return _floats(cheb(_floats(x)))

    def sample(self, step: float) -> FloatArray:
        """Return ``(K, 2)`` points ``(x, p(x))`` every ``step`` across the domain, x sorted."""
        return _sample_x(self, self.domain, step)

    def to_json(self) -> dict[str, Any]:
        """Return the JSON-ready description used in ``report.json``."""
        doc: dict[str, Any] = {
            "kind": "poly",
            "ok": True,
            "order": self.order,
            "basis": "chebyshev",
            "domain": list(self.domain),
            "window": [-1.0, 1.0],
            "coefficients": self.coef.tolist(),
        }
        if self.method != "least squares":
            doc["method"] = self.method
        if self.selection is not None:
            doc["order_selection"] = self.selection
        return doc


@dataclass(frozen=True)
class SplineFit:
    """A cubic smoothing spline y = s(x): B-spline knots, coefficients and degree."""

    knots: FloatArray
    coef: FloatArray
    degree: int
    domain: tuple[float, float]
    lam: float | None
    kind: str = "spline"
    order: int = 3
    ok: bool = True

    def __call__(self, x: npt.ArrayLike) -> FloatArray:
        """Evaluate the spline at ``x`` (extrapolating outside the domain)."""
        from scipy.interpolate import BSpline

        return _floats(BSpline(self.knots, self.coef, self.degree, extrapolate=True)(_floats(x)))

    def sample(self, step: float) -> FloatArray:
        """Return ``(K, 2)`` points ``(x, s(x))`` every ``step`` across the domain, x sorted."""
        return _sample_x(self, self.domain, step)

    def to_json(self) -> dict[str, Any]:
        """Return the JSON-ready description used in ``report.json``."""
        return {
            "kind": "spline",
            "ok": True,
            "order": self.degree,
            "basis": "bspline",
            "domain": list(self.domain),
            "knots": self.knots.tolist(),
            "coefficients": self.coef.tolist(),
            "smoothing_lambda": self.lam,
        }


@dataclass(frozen=True)
class PolarFit:
    """A closed profile r(phi) = a0 + sum_k a_k cos(k phi) + b_k sin(k phi) about ``centre``."""

    centre: tuple[float, float]
    order: int
    a0: float
    a: FloatArray
    b: FloatArray
    kind: str = "polar"
    ok: bool = True

    @property
    def domain(self) -> tuple[float, float]:
        """The angular domain, always the full turn ``(-pi, pi)``."""
        return (-np.pi, np.pi)

    def __call__(self, phi: npt.ArrayLike) -> FloatArray:
        """Evaluate the radius r(phi) (m) at angles ``phi`` (rad)."""
        phi = _floats(phi)
        k = np.arange(1, self.order + 1, dtype=np.float64)
        ang = np.multiply.outer(phi, k)
        return _floats(self.a0 + np.cos(ang) @ self.a + np.sin(ang) @ self.b)

    def sample(self, step: float) -> FloatArray:
        """Return a closed ``(K + 1, 2)`` polyline of world points, ``step`` apart on average.

        The points run counter-clockwise from phi = -pi; the last repeats the first.
        """
        mean_r = max(abs(self.a0), step)
        count = max(int(np.ceil(2.0 * np.pi * mean_r / step)), 8)
        phi = np.linspace(-np.pi, np.pi, count, endpoint=False)
        r = self(phi)
        pts = np.column_stack((self.centre[0] + r * np.cos(phi), self.centre[1] + r * np.sin(phi)))
        return np.vstack((pts, pts[:1]))

    def to_json(self) -> dict[str, Any]:
        """Return the JSON-ready description used in ``report.json``."""
        return {
            "kind": "polar",
            "ok": True,
            "order": self.order,
            "basis": "fourier",
            "centre": list(self.centre),
            "domain": [-np.pi, np.pi],
            "coefficients": {"a0": self.a0, "a": self.a.tolist(), "b": self.b.tolist()},
        }


Fit = PolyFit | SplineFit | PolarFit | FitFailure


def _sample_x(f: PolyFit | SplineFit, domain: tuple[float, float], step: float) -> FloatArray:
    if not step > 0:
        raise ValueError(f"sample step must be > 0, got {step}")
    lo, hi = domain
    count = int(np.floor((hi - lo) / step + 1e-9)) + 1
    x = lo + step * np.arange(count, dtype=np.float64)
    return np.column_stack((x, f(x)))


def _check_bins(
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


def _solve_normal(a: FloatArray, b: FloatArray) -> FloatArray | None:
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
    return _floats(np.linalg.solve(scaled, rhs / d) / d)


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
    xa, ya, wa = _floats(x), _floats(y), _floats(counts)
    failure = _check_bins("poly", xa, ya, wa, order + 1, order)
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
    return PolyFit(order=order, coef=_floats(cheb.coef), domain=(lo, hi))


def fit_spline(
    x: npt.ArrayLike, y: npt.ArrayLike, counts: npt.ArrayLike, *, lam: float | None = None
) -> SplineFit | FitFailure:
    """Cubic smoothing spline through the column means, weighted by the column counts.

    Parameters
    ----------
    x, y, counts : array_like, shape (K,)
        As for :func:`fit_polynomial`.
    lam : float, optional
        Roughness penalty; ``None`` chooses it by generalised cross-validation.

    Returns
    -------
    SplineFit or FitFailure
    """
    from scipy.interpolate import make_smoothing_spline

    xa, ya, wa = _floats(x), _floats(y), _floats(counts)
    failure = _check_bins("spline", xa, ya, wa, 5, 3)
    if failure is not None:
        return failure
    keep = wa > 0
    order = np.argsort(xa[keep], kind="stable")
    xk, yk, wk = xa[keep][order], ya[keep][order], wa[keep][order]
    try:
        spl = make_smoothing_spline(xk, yk, w=wk, lam=lam)
    except (ValueError, np.linalg.LinAlgError) as err:
        return FitFailure("spline", f"smoothing spline failed: {err}", 3)
    return SplineFit(
        knots=_floats(spl.t),
        coef=_floats(spl.c),
        degree=int(spl.k),
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
    pa, ra, wa = _floats(phi), _floats(r), _floats(counts)
    failure = _check_bins("polar", pa, ra, wa, 2 * order + 1, order)
    if failure is not None:
        return failure
    keep = wa > 0
    pk, rk, sw = pa[keep], ra[keep], np.sqrt(wa[keep])
    k = np.arange(1, order + 1, dtype=np.float64)
    ang = np.multiply.outer(pk, k)
    design = np.hstack((np.ones((pk.size, 1)), np.cos(ang), np.sin(ang)))
    sol = _solve_normal(design * sw[:, None], rk * sw)
    if sol is None:
        return FitFailure("polar", "rank-deficient system (bins too unevenly spread)", order)
    return PolarFit(
        centre=(float(centre[0]), float(centre[1])),
        order=order,
        a0=float(sol[0]),
        a=_floats(sol[1 : order + 1]),
        b=_floats(sol[order + 1 :]),
    )


# --- beyond the paper: robust fit over the points, order chosen from the data -------------

#: Huber's tuning constant: 95 % efficiency for Gaussian residuals.
HUBER_C = 1.345
#: Smallest residual scale (m) the Huber weights use, so points exactly on a curve do not
#: make every residual an outlier.
SCALE_FLOOR = 1e-4


def _vander(x: FloatArray, lo: float, hi: float, order: int) -> FloatArray:
    u = (2.0 * x - (lo + hi)) / (hi - lo)
    return _floats(np.polynomial.chebyshev.chebvander(u, order))


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
        new = _solve_normal(v * sw[:, None], y * sw)
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
    xa, ya, wa = _floats(x), _floats(y), _floats(weights)
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
    xa, ya, wa = _floats(x), _floats(y), _floats(weights)
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

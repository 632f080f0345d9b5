"""The fitted curves: polynomial, smoothing spline, polar series, and the failure record.

Each is a small immutable object that evaluates itself, samples itself at a step and
says what it is as JSON; a fit that could not be made is a :class:`FitFailure` that says
why, never a curve.
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
    "as_floats",
    "sample_x",
]

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
FitKind = Literal["poly", "spline", "polar"]


def as_floats(a: npt.ArrayLike) -> FloatArray:
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
        return as_floats(cheb(as_floats(x)))

    def sample(self, step: float) -> FloatArray:
        """Return ``(K, 2)`` points ``(x, p(x))`` every ``step`` across the domain, x sorted."""
        return sample_x(self, self.domain, step)

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

        return as_floats(
            BSpline(self.knots, self.coef, self.degree, extrapolate=True)(as_floats(x))
        )

    def sample(self, step: float) -> FloatArray:
        """Return ``(K, 2)`` points ``(x, s(x))`` every ``step`` across the domain, x sorted."""
        return sample_x(self, self.domain, step)

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
        phi = as_floats(phi)
        k = np.arange(1, self.order + 1, dtype=np.float64)
        ang = np.multiply.outer(phi, k)
        return as_floats(self.a0 + np.cos(ang) @ self.a + np.sin(ang) @ self.b)

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


def sample_x(f: PolyFit | SplineFit, domain: tuple[float, float], step: float) -> FloatArray:
    if not step > 0:
        raise ValueError(f"sample step must be > 0, got {step}")
    lo, hi = domain
    count = int(np.floor((hi - lo) / step + 1e-9)) + 1
    x = lo + step * np.arange(count, dtype=np.float64)
    return np.column_stack((x, f(x)))

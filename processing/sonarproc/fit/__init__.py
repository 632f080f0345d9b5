"""Curve fitting of the processed map (section 3.2 of the paper), and beyond.

* :func:`fit_polynomial`: the paper's least-squares polynomial of order ``m`` (Eq. 2),
  in the Chebyshev basis on the domain scaled to [-1, 1] so high orders stay well
  conditioned.
* :func:`fit_spline`: a cubic smoothing spline (penalised least squares, the smoothing
  chosen by generalised cross-validation unless given).
* :func:`smoothing_spline`: the same criterion over few knots and several series at once
  (the surfaces' splines in arc length), solved densely.
* :func:`fit_polar`: for a map around the robot (a room), a truncated Fourier series
  r(phi) about a centre, periodic by construction.
* :func:`fit_polynomial_robust` and :func:`select_order_cv`: a Huber fit over the points
  and an order chosen without ground truth.

Degenerate input returns a :class:`FitFailure` that says why, never a curve.
"""

from sonarproc.fit._curves import fit_polar, fit_polynomial, fit_spline
from sonarproc.fit._gcv import SmoothingSpline, smoothing_spline
from sonarproc.fit._models import Fit, FitFailure, FitKind, PolarFit, PolyFit, SplineFit
from sonarproc.fit._robust import HUBER_C, fit_polynomial_robust, select_order_cv

__all__ = [
    "HUBER_C",
    "Fit",
    "FitFailure",
    "FitKind",
    "PolarFit",
    "PolyFit",
    "SmoothingSpline",
    "SplineFit",
    "fit_polar",
    "fit_polynomial",
    "fit_polynomial_robust",
    "fit_spline",
    "select_order_cv",
    "smoothing_spline",
]

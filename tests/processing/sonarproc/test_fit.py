"""Tests for sonarproc.fit: the paper's polynomial (Eq. 2), the spline and the polar fit."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.fit import (
    FitFailure,
    PolarFit,
    PolyFit,
    SplineFit,
    fit_polar,
    fit_polynomial,
    fit_spline,
)
from sonarproc.metrics import bin_stats


def test_polynomial_recovers_exact_polynomial() -> None:
    x = np.linspace(-3.0, 5.0, 50)
    y = 0.2 - 0.4 * x + 0.05 * x**3
    f = fit_polynomial(x, y, np.ones_like(x), order=3)
    assert isinstance(f, PolyFit)
    np.testing.assert_allclose(f(x), y, atol=1e-10)
    assert f.domain == (-3.0, 5.0)
    cheb = np.polynomial.Chebyshev(f.coef, domain=list(f.domain))
    np.testing.assert_allclose(cheb(1.7), f(1.7))


def test_polynomial_high_order_stays_stable_far_from_origin() -> None:
    # a raw power basis at x ~ 1000 with order 15 is hopeless; the scaled basis is not
    x = np.linspace(1000.0, 1005.0, 400)
    y = np.sin(x)
    f = fit_polynomial(x, y, np.ones_like(x), order=15)
    assert isinstance(f, PolyFit)
    assert np.max(np.abs(f(x) - y)) < 1e-6


def test_column_means_weighted_by_counts_equal_fit_over_every_point() -> None:
    rng = np.random.default_rng(3)
    col = rng.integers(0, 40, 600)
    x_pts = col * 0.05
    y_pts = 0.3 * x_pts**2 + rng.normal(0.0, 0.1, col.size)
    direct = np.polynomial.Chebyshev.fit(x_pts, y_pts, 4)
    bins = bin_stats(col, y_pts, np.arange(40) * 0.05)
    f = fit_polynomial(bins.centres, np.nan_to_num(bins.mean), bins.count, order=4)
    assert isinstance(f, PolyFit)
    xs = np.linspace(0.0, 1.95, 30)
    np.testing.assert_allclose(f(xs), direct(xs), atol=1e-9)


@pytest.mark.parametrize(
    ("counts", "reason"),
    [(np.zeros(10), "no points"), (np.r_[np.ones(3), np.zeros(7)], "distinct column")],
)
def test_polynomial_degenerate_returns_failure(counts: np.ndarray, reason: str) -> None:
    x = np.arange(10.0)
    f = fit_polynomial(x, x, counts, order=5)
    assert isinstance(f, FitFailure)
    assert not f.ok
    assert reason in f.reason
    assert f.to_json()["ok"] is False
    json.dumps(f.to_json())


def test_polynomial_negative_order_is_an_error() -> None:
    with pytest.raises(ValueError, match="order"):
        fit_polynomial([0.0, 1.0], [0.0, 1.0], [1, 1], order=-1)


def test_sample_is_sorted_at_step_across_domain() -> None:
    f = fit_polynomial([0.0, 0.5, 1.0], [1.0, 1.0, 1.0], [1, 1, 1], order=1)
    assert isinstance(f, PolyFit)
    pts = f.sample(0.01)
    assert pts.shape == (101, 2)
    assert np.all(np.diff(pts[:, 0]) > 0)
    np.testing.assert_allclose(pts[:, 1], 1.0, atol=1e-12)
    with pytest.raises(ValueError):
        f.sample(0.0)


def test_spline_smooths_noisy_curve_and_serialises() -> None:
    rng = np.random.default_rng(0)
    x = np.linspace(0.0, 4.0, 200)
    truth = 0.3 * np.sin(2 * x)
    f = fit_spline(x, truth + rng.normal(0, 0.01, x.size), np.full(x.size, 3))
    assert isinstance(f, SplineFit)
    assert np.sqrt(np.mean((f(x) - truth) ** 2)) < 0.01
    doc = json.loads(json.dumps(f.to_json()))
    assert doc["kind"] == "spline" and doc["order"] == 3 and len(doc["knots"]) > 0


def test_spline_too_few_columns_fails() -> None:
    f = fit_spline([0.0, 1.0, 2.0], [0.0, 1.0, 0.0], [1, 1, 1])
    assert isinstance(f, FitFailure)
    assert f.kind == "spline"


def test_polar_fits_an_offset_circle_and_closes() -> None:
    # a circle of radius 1 centred at (0.2, 0) seen from the origin: r(phi) is smooth
    t = np.linspace(-np.pi, np.pi, 720, endpoint=False)
    px, py = 0.2 + np.cos(t), np.sin(t)
    phi, r = np.arctan2(py, px), np.hypot(px, py)
    f = fit_polar(phi, r, np.ones_like(phi), centre=(0.0, 0.0), order=12)
    assert isinstance(f, PolarFit)
    assert np.max(np.abs(f(phi) - r)) < 1e-6
    poly = f.sample(0.01)
    np.testing.assert_array_equal(poly[0], poly[-1])
    assert np.max(np.abs(np.hypot(poly[:, 0] - 0.2, poly[:, 1]) - 1.0)) < 1e-5
    doc = json.loads(json.dumps(f.to_json()))
    assert doc["centre"] == [0.0, 0.0] and len(doc["coefficients"]["a"]) == 12


def test_polar_too_few_bins_fails() -> None:
    f = fit_polar([0.0, 1.0, 2.0], [1.0, 1.0, 1.0], [1, 1, 1], centre=(0.0, 0.0), order=2)
    assert isinstance(f, FitFailure)
    assert "needs 5" in f.reason


@settings(max_examples=30, deadline=None)
@given(
    coef=st.lists(st.floats(-2, 2), min_size=1, max_size=6),
    shift=st.floats(-50, 50),
    scale=st.floats(0.1, 10),
)
def test_polynomial_reproduces_any_polynomial_of_its_order(
    coef: list[float], shift: float, scale: float
) -> None:
    x = shift + scale * np.linspace(0.0, 1.0, 40)
    u = (x - shift) / scale
    y = np.polynomial.polynomial.polyval(u, coef)
    f = fit_polynomial(x, y, np.ones_like(x), order=len(coef) - 1)
    assert isinstance(f, PolyFit)
    np.testing.assert_allclose(f(x), y, atol=1e-7 * (1 + np.max(np.abs(y))))


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(5, 60),
    seed=st.integers(0, 2**31 - 1),
    lam=st.floats(0.0, 50.0),
)
def test_smoothing_bspline_is_scipys_spline(n: int, seed: int, lam: float) -> None:
    """The vectorised smoothing spline gives scipy's knots and coefficients."""
    from scipy.interpolate import make_smoothing_spline

    from sonarproc.fit._smoothing import smoothing_bspline

    rng = np.random.default_rng(seed)
    x = np.cumsum(rng.uniform(0.01, 1.0, n))
    y = np.sin(x) + rng.normal(0.0, 0.2, n)
    w = rng.uniform(0.5, 20.0, n)
    want = make_smoothing_spline(x, y, w=w, lam=lam)
    knots, coef = smoothing_bspline(x, y, w, lam)
    np.testing.assert_array_equal(knots, want.t)
    np.testing.assert_allclose(coef, want.c, rtol=1e-9, atol=1e-9 * np.abs(want.c).max())


@pytest.mark.parametrize(
    ("x", "w", "lam", "message"),
    [
        (np.arange(4.0), np.ones(4), 1.0, "at least 5"),
        (np.array([0.0, 1.0, 1.0, 2.0, 3.0]), np.ones(5), 1.0, "strictly increasing"),
        (np.arange(5.0), np.r_[1.0, 0.0, 1.0, 1.0, 1.0], 1.0, "positive"),
        (np.arange(5.0), np.ones(5), -1.0, "non-negative"),
    ],
)
def test_smoothing_bspline_refuses_bad_input(
    x: np.ndarray, w: np.ndarray, lam: float, message: str
) -> None:
    from sonarproc.fit._smoothing import smoothing_bspline

    with pytest.raises(ValueError, match=message):
        smoothing_bspline(x, np.zeros_like(x), w, lam)

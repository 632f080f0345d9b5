"""Tests for the beyond-the-paper fits: Huber IRLS over points and order by cross-validation."""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.fit import (
    FitFailure,
    PolyFit,
    fit_polynomial,
    fit_polynomial_robust,
    select_order_cv,
)
from sonarproc.metrics import bin_stats


def _cubic(x: np.ndarray) -> np.ndarray:
    return 2.0 + 0.3 * x - 0.2 * x**2 + 0.05 * x**3


def test_huber_ignores_outliers_that_pull_least_squares_off() -> None:
    rng = np.random.default_rng(1)
    x = np.repeat(np.linspace(0.0, 4.0, 200), 2)
    y = _cubic(x) + 0.003 * rng.standard_normal(x.size)
    bad = rng.random(x.size) < 0.15
    y[bad] += rng.uniform(0.1, 0.4, int(bad.sum()))  # one-sided blobs above the surface
    w = np.ones(x.size)
    grid = np.linspace(0.0, 4.0, 81)
    robust = fit_polynomial_robust(x, y, w, order=3)
    plain = fit_polynomial_robust(x, y, w, order=3, robust=False)
    assert isinstance(robust, PolyFit) and isinstance(plain, PolyFit)
    assert robust.method == "huber irls" and plain.method == "weighted least squares"
    assert np.max(np.abs(robust(grid) - _cubic(grid))) < 0.006
    assert np.max(np.abs(plain(grid) - _cubic(grid))) > 0.02
    doc = robust.to_json()
    assert doc["method"] == "huber irls" and doc["domain"] == [0.0, 4.0]


def test_unweighted_plain_fit_is_the_papers_eq2() -> None:
    rng = np.random.default_rng(2)
    col = rng.integers(0, 60, 500)
    x = 0.01 * col
    y = np.sin(3 * x) + 0.05 * rng.standard_normal(x.size)
    ours = fit_polynomial_robust(x, y, np.ones(x.size), order=7, robust=False)
    b = bin_stats(col, y, 0.01 * np.arange(60))
    paper = fit_polynomial(b.centres, np.nan_to_num(b.mean), b.count, order=7)
    assert isinstance(ours, PolyFit) and isinstance(paper, PolyFit)
    assert ours.domain == paper.domain
    np.testing.assert_allclose(ours.coef, paper.coef, atol=1e-9)


def test_weights_count_like_repeated_points() -> None:
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    y = np.array([0.0, 1.2, 1.9, 3.3, 3.9])
    w = np.array([1.0, 3.0, 1.0, 2.0, 1.0])
    a = fit_polynomial_robust(x, y, w, order=1, robust=False)
    b = fit_polynomial_robust(np.repeat(x, 3 * w.astype(int)), np.repeat(y, 3 * w.astype(int)),
                              np.ones(int(3 * w.sum())), order=1, robust=False)  # fmt: skip
    assert isinstance(a, PolyFit) and isinstance(b, PolyFit)
    np.testing.assert_allclose(a.coef, b.coef, atol=1e-12)


def test_robust_fit_failures() -> None:
    f = fit_polynomial_robust([1.0, 1.0, 2.0], [0.0, 1.0, 2.0], [1.0, 1.0, 1.0], order=2)
    assert isinstance(f, FitFailure) and "2 distinct column(s)" in f.reason
    g = fit_polynomial_robust([1.0, 2.0], [0.0, 1.0], [0.0, 0.0], order=0)
    assert isinstance(g, FitFailure) and "no points" in g.reason
    with pytest.raises(ValueError, match="order must be >= 0"):
        fit_polynomial_robust([1.0], [1.0], [1.0], order=-1)


def test_cv_picks_the_true_order_and_is_seeded() -> None:
    rng = np.random.default_rng(4)
    x = np.repeat(np.linspace(0.0, 4.0, 120), 3)
    y = _cubic(x) + 0.005 * rng.standard_normal(x.size)
    m, scores = select_order_cv(x, y, np.ones(x.size), orders=range(0, 10))
    assert m == 3
    assert sorted(scores) == list(range(10))
    assert scores[3] < 0.1 * scores[2]
    assert select_order_cv(x, y, np.ones(x.size), orders=range(0, 10)) == (m, scores)


def test_cv_needs_a_wiggly_order_for_a_sinusoid() -> None:
    x = np.repeat(np.linspace(0.0, 2.5, 250), 2)  # two periods of 1.25 m
    y = 2.0 + 0.15 * np.sin(2 * np.pi * x / 1.25)
    m, _ = select_order_cv(x, y, np.ones(x.size), orders=range(0, 16))
    assert 7 <= m <= 15
    f = fit_polynomial_robust(x, y, np.ones(x.size), order=m)
    assert isinstance(f, PolyFit)
    assert np.max(np.abs(f(x) - y)) < 0.005


def test_cv_refuses_too_few_columns() -> None:
    with pytest.raises(ValueError, match="too few to choose an order"):
        select_order_cv([0.0, 1.0, 1.0], [0.0, 1.0, 2.0], [1.0, 1.0, 1.0])
    # three columns: one held out at a time leaves two, enough for order 0 only
    assert select_order_cv([0.0, 1.0, 2.0], [1.0, 1.0, 1.0], [1.0, 1.0, 1.0])[0] == 0
    with pytest.raises(ValueError, match="folds must be >= 2"):
        select_order_cv([0.0, 1.0], [0.0, 1.0], [1.0, 1.0], folds=1)

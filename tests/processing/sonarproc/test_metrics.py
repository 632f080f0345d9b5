"""Tests for sonarproc.metrics: Eq. 1, f_c, Eqs. 3-4 and the bin statistics."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.metrics import (
    bin_stats,
    polar_bins,
    profile_metrics,
    truth_on_columns,
    truth_on_polar_bins,
)


def test_bin_stats_matches_numpy_median_per_bin() -> None:
    rng = np.random.default_rng(1)
    idx = rng.integers(0, 12, 300)
    val = rng.normal(size=300)
    b = bin_stats(idx, val, np.arange(12.0))
    for k in range(12):
        sel = val[idx == k]
        assert b.count[k] == sel.size
        if sel.size:
            assert b.median[k] == pytest.approx(np.median(sel))
            assert b.mean[k] == pytest.approx(np.mean(sel))
        else:
            assert np.isnan(b.median[k])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 5), st.integers(-20, 20)), max_size=60))
def test_presorted_cells_give_same_stats(cells: list[tuple[int, int]]) -> None:
    arr = np.array(sorted(set(cells)), dtype=np.int64).reshape(-1, 2)
    a = bin_stats(arr[:, 0], arr[:, 1], np.arange(6.0), presorted=True)
    rng = np.random.default_rng(0)
    perm = rng.permutation(arr.shape[0])
    b = bin_stats(arr[perm, 0], arr[perm, 1], np.arange(6.0))
    np.testing.assert_array_equal(a.count, b.count)
    np.testing.assert_array_equal(a.median, b.median)


def test_truth_on_columns_nan_outside() -> None:
    truth = np.array([[1.0, 0.0], [0.0, 1.0], [2.0, 3.0]])  # unsorted on purpose
    out = truth_on_columns(truth, [-0.5, 0.0, 0.5, 1.5, 2.5])
    np.testing.assert_allclose(out[1:4], [1.0, 0.5, 1.5])
    assert np.isnan(out[0]) and np.isnan(out[4])
    with pytest.raises(ValueError):
        truth_on_columns(np.zeros((1, 2)), [0.0])


def test_metrics_hand_computed() -> None:
    # 4 truth columns y = 0, 1, 2, 3 (sigma = sqrt(1.25)); column 2 empty; medians off by 0.1
    centres = np.arange(6.0)
    truth = np.array([0.0, 1.0, 2.0, 3.0, np.nan, np.nan])
    b = bin_stats([0, 1, 1, 1, 3, 4], [0.1, 0.0, 1.1, 9.0, 3.1, 7.0], centres)
    m = profile_metrics(b, truth=truth, fit=lambda x: x + 0.2)
    sigma = np.sqrt(1.25)
    assert m.N == 4 and m.N_k == 3
    assert m.f_c == pytest.approx(0.75)
    assert m.e == pytest.approx(0.1 / sigma)
    assert m.E1_m == pytest.approx(0.2)
    assert pytest.approx(0.2 / sigma) == m.E2
    assert m.sigma_y_m == pytest.approx(sigma)


def test_metrics_without_truth_or_fit() -> None:
    b = bin_stats([0, 2], [1.0, 1.0], np.arange(4.0))
    m = profile_metrics(b, truth=None, fit=None, spanned=[True, True, True, False])
    assert (m.e, m.E1_m, m.E2) == (None, None, None)
    assert m.f_c == pytest.approx(2 / 3)
    m2 = profile_metrics(b, truth=[1.0, 1.0, 1.0, 1.0], fit=None)
    assert m2.e is None  # flat truth: sigma = 0, e undefined
    assert m2.E1_m is None
    empty = bin_stats([], [], np.arange(4.0))
    m3 = profile_metrics(empty, truth=[0.0, 1.0, 2.0, 3.0], fit=None)
    assert m3.f_c == 0.0 and m3.e is None and m3.N == 4


def test_polar_bins_and_truth_of_a_circle() -> None:
    t = np.linspace(-np.pi, np.pi, 2000, endpoint=False)
    circle = np.column_stack((2.0 * np.cos(t), 2.0 * np.sin(t)))
    b = polar_bins(circle[:, 0], circle[:, 1], centre=(0.0, 0.0), nbins=100)
    assert b.count.sum() == 2000
    np.testing.assert_allclose(b.median, 2.0)
    closed = np.vstack((circle[::20], circle[:1]))
    tr = truth_on_polar_bins(closed, centre=(0.0, 0.0), nbins=100, step=0.01)
    assert np.all(np.isfinite(tr))
    np.testing.assert_allclose(tr, 2.0, atol=2e-3)
    m = profile_metrics(b, truth=tr, fit=lambda p: np.full_like(p, 2.01))
    assert m.f_c == 1.0
    assert m.E1_m == pytest.approx(0.01, abs=2.5e-3)

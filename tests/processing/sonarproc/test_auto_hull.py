"""``--auto``'s guard-rail hull (the sensors' side, the readings' echo points), and its
paired errors over firings."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import sonarproc.auto.echo_refit as echo_refit
from sonarproc.auto.echo_refit import choose_refit
from sonarproc.auto.holdout import hull_excess, local_hull
from sonarproc.auto.hull import data_hull_excess, sensor_side
from sonarproc.auto.score import HULL_CELLS, clustered_paired_se, paired_se
from sonarproc.fit import PolyFit, SplineFit, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods.testing import beams_facing
from sonarproc.metrics import Bins, bin_stats
from sonarproc.pipeline.selection import Beams

CELL = 0.01


def _wave(x: np.ndarray) -> np.ndarray:
    return 1.8 + 0.08 * np.sin(2 * np.pi * x / 1.5)


def _sensors_facing_wave(seed: int, n: int, sign: float) -> Beams:
    """``n`` random monostatic sensors on the sensors' side of the wave (``sign`` +1:
    below it, looking up; -1: the mirror image), 3 mm range noise."""
    rng = np.random.default_rng(seed)
    xs = np.linspace(-1.0, 6.0, 7001)
    surface = np.column_stack((xs, sign * _wave(xs)))
    at = np.column_stack((rng.uniform(0.2, 4.3, n), sign * rng.uniform(0.3, 1.0, n)))
    heading = sign * np.pi / 2 + rng.uniform(-0.5, 0.5, n)
    beams, _ = beams_facing(at, heading, surface)
    beams.path[:] += rng.normal(0.0, 0.003, beams.path.size)
    beams.readings["t"] = np.arange(beams.path.size)  # one firing per reading
    return beams


points_1d = arrays(np.float64, st.integers(2, 30), elements=st.floats(0.0, 5.0))


@settings(max_examples=60, deadline=None)
@given(
    px=points_1d,
    data=st.data(),
    cx=arrays(np.float64, st.integers(1, 40), elements=st.floats(-0.5, 5.5)),
)
def test_the_sided_hull_is_never_stricter_and_mirrors(
    px: np.ndarray, data: st.DataObject, cx: np.ndarray
) -> None:
    py = data.draw(arrays(np.float64, px.size, elements=st.floats(1.0, 2.0)))
    cy = data.draw(arrays(np.float64, cx.size, elements=st.floats(0.5, 2.5)))
    curve = np.column_stack((cx, cy))
    both = hull_excess(curve, px, py, window=0.1)
    below = hull_excess(curve, px, py, window=0.1, side=1)
    above = hull_excess(curve, px, py, window=0.1, side=-1)
    assert below <= both + 1e-12 and above <= both + 1e-12
    mirrored = np.column_stack((cx, -cy))
    assert hull_excess(mirrored, px, -py, window=0.1, side=-1) == pytest.approx(below, abs=1e-12)
    # towards the sensors (below) the local hull holds: a curve under it is caught
    lo, _ = local_hull(cx, px, py, window=0.1)
    under = np.column_stack((cx, lo - 0.05))
    assert hull_excess(under, px, py, window=0.1, side=1) == pytest.approx(0.05, abs=1e-9)


@settings(max_examples=60, deadline=None)
@given(px=points_1d, data=st.data())
def test_the_local_hull_holds_every_point(px: np.ndarray, data: st.DataObject) -> None:
    py = data.draw(arrays(np.float64, px.size, elements=st.floats(-3.0, 3.0)))
    lo, hi = local_hull(px, px, py, window=0.1)
    assert np.all(lo <= py) and np.all(py <= hi)


def test_the_sensors_side_of_a_profile() -> None:
    xs = np.linspace(-1.0, 6.0, 701)
    curve = np.column_stack((xs, _wave(xs)))
    assert sensor_side(_sensors_facing_wave(0, 40, 1.0), curve) == 1
    mirrored = np.column_stack((xs, -_wave(xs)))
    assert sensor_side(_sensors_facing_wave(0, 40, -1.0), mirrored) == -1
    # a curve between the sensors: half of them on each side
    assert sensor_side(_sensors_facing_wave(0, 40, 1.0), np.column_stack((xs, 0.65 + 0 * xs))) == 0
    assert sensor_side(None, curve) == 0


def test_the_readings_echo_points_fill_a_stretch_the_map_misses() -> None:
    """A map with no point across a trough of the wave (x = 2.2-3.05 m): the wave leaves
    the hull its points draw across the gap by the trough's depth; the readings that
    echo from the trough put it back. A fit that swings 20 cm about the wave stays
    outside."""
    beams = _sensors_facing_wave(1, 120, 1.0)
    x = np.linspace(0.3, 4.2, 400)
    mapped = x[(x < 2.2) | (x > 3.05)]
    px, py = mapped, _wave(mapped)
    wave_fit = fit_spline(x, _wave(x), np.ones(x.size), lam=1e-9)
    assert data_hull_excess(wave_fit, px, py, None, CELL) > 0.08
    assert data_hull_excess(wave_fit, px, py, beams, CELL) <= HULL_CELLS * CELL
    swing = fit_spline(x, _wave(x) + 0.2 * np.sin(2 * np.pi * x / 0.7), np.ones(x.size), lam=1e-9)
    assert data_hull_excess(swing, px, py, beams, CELL) > 0.1


def test_a_refit_may_follow_the_crests_its_echo_points_miss(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """About 40 monostatic readings of a 1.5 m wave (from below, or the mirror image from
    above) and a biased sparse map, eight cases: the first echoes miss the far crests,
    so the refits that follow them leave their echo points' local hull there. Held to
    the local hull on the sensors' side only, fewer refits are excluded, and the refit
    kept follows the wave far closer than when it is held on both sides."""
    sided, both = [], []
    for sign in (1.0, -1.0):
        for seed in (1, 2, 3, 4):
            case = _refit_case(seed, sign)
            got = choose_refit(*case, chosen_residual=0.05, cap=0.05)
            with monkeypatch.context() as m:
                m.setattr(echo_refit, "sensor_side", lambda beams, curve: 0)
                held = choose_refit(*case, chosen_residual=0.05, cap=0.05)
            assert len(got.excluded) < len(held.excluded)
            sided.append(_worst(got, sign))
            both.append(_worst(held, sign))
    assert np.median(sided) < 0.015 and max(sided) < 0.025
    assert sum(sided) < 0.3 * sum(both)


def _refit_case(seed: int, sign: float) -> tuple[SplineFit, Bins, Beams, Grid]:
    beams = _sensors_facing_wave(seed, 70, sign)
    rng = np.random.default_rng(seed)
    grid = Grid.covering(-0.2, 4.7, -2.5, 2.5, cell=CELL)
    cx = grid.centres_x()
    seen = (cx > 0.3) & (cx < 4.2) & (rng.random(cx.size) < 0.15)
    y = sign * (_wave(cx[seen]) - 0.01)
    bins = bin_stats(np.flatnonzero(seen), y, cx, presorted=True)
    start = fit_spline(cx[seen], y, np.ones(seen.sum()), lam=1e-3)
    assert isinstance(start, SplineFit)
    return start, bins, beams, grid


def _worst(got: echo_refit.RefitChoice, sign: float) -> float:
    """The refit's largest distance (m) from the wave between its outermost echo points."""
    assert got.applied and isinstance(got.fit, PolyFit | SplineFit) and got.echo_span
    x = np.linspace(*got.echo_span, 300)
    return float(np.max(np.abs(got.fit(x) - sign * _wave(x))))


@settings(max_examples=40, deadline=None)
@given(
    a=arrays(np.float64, st.integers(2, 120), elements=st.floats(0.0, 0.05)),
    data=st.data(),
)
def test_paired_errors_over_clusters(a: np.ndarray, data: st.DataObject) -> None:
    """One reading per cluster: the paired error over readings. Cluster labels are names
    only: renaming them (in the same order, so the seeded draws pick the same clusters)
    changes nothing."""
    b = data.draw(arrays(np.float64, a.size, elements=st.floats(0.0, 0.05)))
    labels = data.draw(arrays(np.int64, a.size, elements=st.integers(0, 6)))
    single = clustered_paired_se(a, b, np.arange(a.size))
    assert single == pytest.approx(paired_se(a, b), rel=1e-9, abs=1e-15)
    renamed = clustered_paired_se(a, b, 11 + 3 * labels)
    assert renamed == pytest.approx(clustered_paired_se(a, b, labels), rel=1e-9, abs=1e-15) or (
        np.isnan(renamed) and np.isnan(clustered_paired_se(a, b, labels))
    )

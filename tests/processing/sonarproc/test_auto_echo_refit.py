"""``--auto``'s echo refit: echo points on the surface, the refit, and its record."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.auto import run_auto
from sonarproc.auto.echo_refit import (
    END_GAP_M,
    END_SHARE,
    MIN_ECHO_POINTS,
    NOISE_MAX,
    NOISE_WIDTHS,
    ROUNDS_M,
    TIE_SE,
    RefitChoice,
    RefitSetting,
    choose_refit,
    echo_points,
    hull_tolerance,
    main_body,
    range_noise,
    references,
    refit_profile,
    simplest_agreeing,
    tie_reasons,
    tied_settings,
    tolerances,
    undominated,
)
from sonarproc.auto.score import paired_se, robust_residual
from sonarproc.fit import PolyFit, SplineFit, fit_polynomial, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods.echo_model import first_echo_path
from sonarproc.methods.testing import beams_facing
from sonarproc.metrics import Bins, bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.pipeline.selection import Beams, TransducerPoses
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]
LENGTHS = (0.1, 0.2, 0.4, 0.8, 1.6)


def _splines(*lengths: float) -> tuple[RefitSetting, ...]:
    return tuple(RefitSetting("spline", k) for k in lengths)


def _wave(x: np.ndarray) -> np.ndarray:
    return 1.5 + 0.08 * np.sin(2 * np.pi * x / 1.3)


def _wave_curve() -> np.ndarray:
    xs = np.linspace(-0.5, 4.5, 5001)
    return np.column_stack((xs, _wave(xs)))


def _bistatic_beams(rng: np.random.Generator, n: int, noise: float = 0.0) -> Beams:
    """Random transmitter/receiver pairs below the wave, their first echoes off it
    (``noise``: the paths' Gaussian noise, m)."""
    from sonarlog.schema import empty_readings
    from sonarproc.arcs import arcs_of

    t = np.column_stack((rng.uniform(0.3, 3.7, n), rng.uniform(0.0, 0.6, n)))
    r = t + np.column_stack((rng.uniform(-0.3, 0.3, n), rng.uniform(-0.05, 0.05, n)))
    ht = rng.uniform(np.radians(70), np.radians(110), n)
    hr = ht + rng.uniform(-0.1, 0.1, n)
    half = np.full(n, np.radians(25.0))
    path = first_echo_path(t, ht, half, r, hr, half, _wave_curve())
    ok = np.isfinite(path)
    t, r, ht, hr, half, path = t[ok], r[ok], ht[ok], hr[ok], half[ok], path[ok]
    m = int(ok.sum())
    path = path + rng.normal(0.0, noise, m)
    readings = empty_readings(m)
    readings["t"] = np.arange(m)
    readings["x"], readings["y"], readings["theta"] = t[:, 0], t[:, 1], ht
    readings["tof"] = path / 343.3
    poses = TransducerPoses(t, ht, r, hr, half, half.copy(), np.zeros(m), np.full(m, 10.0))
    return Beams(readings, poses, path, arcs_of(poses, path))


@settings(max_examples=25, deadline=None)
@given(
    offset=st.floats(-0.03, 0.03),
    tilt=st.floats(-0.02, 0.02),
    seed=st.integers(0, 2**16),
)
def test_echo_points_of_a_displaced_wall_lie_on_the_wall(
    offset: float, tilt: float, seed: int
) -> None:
    # a flat wall y = 1.2, sensors below looking up; the profile is shifted and tilted
    rng = np.random.default_rng(seed)
    xs = np.linspace(-2.0, 6.0, 801)
    wall = np.column_stack((xs, np.full_like(xs, 1.2)))
    xy = np.column_stack((rng.uniform(0.0, 4.0, 40), rng.uniform(0.0, 0.5, 40)))
    heading = rng.uniform(np.radians(75), np.radians(105), 40)
    beams, _ = beams_facing(xy, heading, wall)
    near = PolyFit(1, np.array([1.2 + offset, 2.0 * tilt]), (0.0, 4.0))
    rows, pts = echo_points(near, beams, (-1.0, 5.0), step=0.005, tol=0.08)
    assert rows.size >= 0.8 * len(beams.path)
    # on the wall to well under a millimetre (the profile was centimetres off)
    assert np.max(np.abs(pts[:, 1] - 1.2)) < 5e-4
    # and at the measured range from the sensor (monostatic: along the normal)
    d = np.hypot(*(pts - beams.poses.tx_xy[rows]).T)
    np.testing.assert_allclose(d, beams.path[rows] / 2, atol=5e-4)


def test_bistatic_echo_points_lie_on_a_wave() -> None:
    beams = _bistatic_beams(np.random.default_rng(5), 600)
    x = np.linspace(0.0, 4.0, 401)
    near = fit_polynomial(x, _wave(x) - 0.02, np.ones_like(x), order=12)  # 2 cm short
    assert isinstance(near, PolyFit)
    rows, pts = echo_points(near, beams, (0.0, 4.0), step=0.005, tol=0.08)
    assert rows.size > 0.7 * len(beams.path)
    err = pts[:, 1] - _wave(pts[:, 0])
    assert np.percentile(np.abs(err), 90) < 1e-3


def test_refit_recovers_a_wave_a_biased_profile_missed() -> None:
    from sonarproc.grid import Grid

    beams = _bistatic_beams(np.random.default_rng(9), 1500)
    grid = Grid.covering(0.0, 4.0, 0.0, 2.0, cell=0.01)
    # the "map": points 1.5 cm short of the wave, one per column (the sensors below see
    # the troughs and the crests, not the flanks: there the spline interpolates)
    cx = grid.centres_x()
    ix = np.arange(cx.size)
    bins = bin_stats(ix, _wave(cx) - 0.015, cx, presorted=True)
    start = fit_polynomial(cx, _wave(cx) - 0.015, np.ones_like(cx), order=15)
    assert isinstance(start, PolyFit)
    fit, rows, pts = refit_profile(
        start, bins, beams, grid, (0.2, 3.8), RefitSetting("spline", 0.2)
    )
    x = np.linspace(0.5, 3.5, 301)
    before = np.sqrt(np.mean((start(x) - _wave(x)) ** 2))
    after = np.sqrt(np.mean((fit(x) - _wave(x)) ** 2))
    assert before > 0.0145 and after < 0.75 * before
    xe = pts[:, 0]
    at_echoes = np.median(np.abs(fit(xe) - _wave(xe)))
    assert at_echoes < 0.1 * before
    assert rows.size > 500 and len(ROUNDS_M) == 2


def test_the_map_fills_only_beyond_the_echo_points() -> None:
    from sonarproc.grid import Grid

    # a flat wall y = 1.2 seen from below by sensors between x = 1 and 3 m
    rng = np.random.default_rng(4)
    xs = np.linspace(-1.0, 5.0, 1201)
    wall = np.column_stack((xs, np.full_like(xs, 1.2)))
    xy = np.column_stack((rng.uniform(1.0, 3.0, 200), rng.uniform(0.0, 0.4, 200)))
    beams, _ = beams_facing(xy, np.full(200, np.pi / 2), wall)
    grid = Grid.covering(0.0, 4.0, 0.0, 2.0, cell=0.01)
    cx = grid.centres_x()
    # the map: 5 cm short of the wall where the sensors are, 3 cm beyond it elsewhere
    among = (cx > 1.0) & (cx < 3.0)
    bins = bin_stats(np.arange(cx.size), np.where(among, 1.15, 1.23), cx, presorted=True)
    start = PolyFit(0, np.array([1.18]), (0.0, 4.0))
    fit, rows, pts = refit_profile(
        start, bins, beams, grid, (0.0, 4.0), RefitSetting("spline", 0.2)
    )
    assert rows.size > 150 and np.percentile(np.abs(pts[:, 1] - 1.2), 95) < 1e-3
    lo, hi = pts[:, 0].min(), pts[:, 0].max()
    # between the echo points the map is not used; beyond them it carries the profile
    # (a smoothing length from the step between the two)
    inner = np.linspace(lo + 0.3, hi - 0.3, 200)
    np.testing.assert_allclose(fit(inner), 1.2, atol=1e-3)
    np.testing.assert_allclose(fit(np.array([0.2, 0.5, 3.5, 3.8])), 1.23, atol=5e-3)


def test_a_column_mean_sits_at_its_points_mean_x() -> None:
    from sonarproc.grid import Grid

    # a wall sloping at 45 degrees seen along its normal: each echo point is exact, and
    # a column's points cluster on one side of it; the refit must not be biased by that
    rng = np.random.default_rng(8)
    xs = np.linspace(-1.0, 5.0, 1201)
    wall = np.column_stack((xs, 1.0 + xs))
    along = rng.uniform(1.0, 3.0, 300)
    foot = np.column_stack((along, 1.0 + along))
    normal = np.array([1.0, -1.0]) / np.sqrt(2.0)
    xy = foot + rng.uniform(0.8, 1.2, 300)[:, None] * normal
    beams, _ = beams_facing(xy, np.full(300, 3 * np.pi / 4), wall)
    grid = Grid.covering(0.0, 4.0, 0.0, 6.0, cell=0.01)
    cx = grid.centres_x()
    bins = bin_stats(np.arange(cx.size), 1.0 + cx, cx, presorted=True)
    start = PolyFit(1, np.array([0.99 + 1.0 * 2.0, 2.0]), (0.0, 4.0))  # 1 cm off, same slope
    fit, rows, _ = refit_profile(start, bins, beams, grid, (0.0, 4.0), RefitSetting("spline", 0.2))
    assert rows.size > 250
    x = np.linspace(1.2, 2.8, 161)
    np.testing.assert_allclose(fit(x), 1.0 + x, atol=1e-3)


def test_choose_refit_scores_lengths_and_applies_only_a_better_one() -> None:
    from sonarproc.grid import Grid

    beams = _bistatic_beams(np.random.default_rng(21), 1200)
    grid = Grid.covering(0.0, 4.0, 0.0, 2.0, cell=0.01)
    cx = grid.centres_x()
    bins = bin_stats(np.arange(cx.size), _wave(cx) - 0.015, cx, presorted=True)
    start = fit_polynomial(cx, _wave(cx) - 0.015, np.ones_like(cx), order=15)
    assert isinstance(start, PolyFit)
    got = choose_refit(
        start, bins, beams, grid, chosen_residual=0.01, cap=0.05, settings=_splines(*LENGTHS)
    )
    assert set(got.residuals) | set(got.excluded) == set(_splines(*LENGTHS))
    assert got.applied and got.setting is not None and got.fit is not None
    assert got.residuals[got.setting] == min(got.residuals.values()) < 0.01
    doc = got.to_json()
    assert doc["applied"] is True and doc["smoothing_length_m"] == got.setting.value
    assert doc["polynomial_order"] is None and doc["setting"] == got.setting.short
    assert "held-out" in doc["criterion"] and "below the chosen" in doc["reason"]
    # a chosen candidate that already predicts better keeps its own fit
    kept = choose_refit(
        start, bins, beams, grid, chosen_residual=1e-9, cap=0.05, settings=_splines(*LENGTHS)
    )
    assert not kept.applied and kept.fit is None and "not below" in kept.reason


def _refit_case() -> tuple[PolyFit, Bins, Beams, Grid]:
    beams = _bistatic_beams(np.random.default_rng(21), 1200, noise=0.001)
    grid = Grid.covering(0.0, 4.0, 0.0, 2.0, cell=0.01)
    cx = grid.centres_x()
    bins = bin_stats(np.arange(cx.size), _wave(cx) - 0.015, cx, presorted=True)
    start = fit_polynomial(cx, _wave(cx) - 0.015, np.ones_like(cx), order=15)
    assert isinstance(start, PolyFit)
    return start, bins, beams, grid


def test_lengths_the_readings_cannot_tell_apart_are_averaged() -> None:
    start, bins, beams, grid = _refit_case()
    # two all but equal lengths are tied; a far smoother one is not
    # (the default tolerances: the start's own error would widen them, see below)
    got = choose_refit(
        start, bins, beams, grid, chosen_residual=0.01, cap=0.05,
        settings=_splines(0.2, 0.2001, 1.6), noise=0.0,
    )  # fmt: skip
    assert got.averaged == _splines(0.2, 0.2001) and got.applied and got.fit is not None
    best = min(got.residuals, key=lambda k: got.residuals[k])
    assert got.setting == got.best == best and got.tied == got.averaged
    for k, res in got.residuals.items():
        tied = res - got.residuals[best] <= TIE_SE * paired_se(got.losses[best], got.losses[k])
        assert tied == (k in got.averaged)
    # the applied profile is the pointwise mean of the tied refits, between their echo points
    x0, x1 = got.echo_span or (0.0, 0.0)
    assert x0 == max(got.spans[k][0] for k in got.averaged)
    assert x1 == min(got.spans[k][1] for k in got.averaged)
    x = np.linspace(x0, x1, 200)
    mean = np.mean([got.fits[k](x) for k in got.averaged], axis=0)
    np.testing.assert_allclose(got.fit(x), mean, atol=1e-5)
    doc = got.to_json()
    assert doc["averaged_lengths_m"] == [0.2, 0.2001]
    assert doc["fit_short"] == "mean of splines L=0.2, 0.2001 m"
    assert doc["residual_m"] == pytest.approx(got.residual) and got.residual is not None
    assert got.residual < 0.01 and got.residual < got.residuals[RefitSetting("spline", 1.6)]


def test_a_neighbouring_length_better_on_the_shared_readings_is_tied() -> None:
    # 40 firings of 10 readings. The 0.1 m spline predicts every reading to 2 cm; the
    # 0.2 m and 0.4 m splines have no specular point for 3 readings of each firing (the
    # cap) and predict the other 7 to 1.6 cm. The 0.1 m spline wins the trimmed mean by
    # the same margin in every firing (no standard error to tie them by), but only by
    # predicting more readings: its neighbour is tied with it, the 0.4 m spline is not.
    cap = 0.1
    firings = np.repeat(np.arange(40), 10)
    missed = np.tile(np.arange(10) < 3, 40)
    s1, s2, s4 = _splines(0.1, 0.2, 0.4)
    rough = np.full(400, 0.02)
    smooth = np.where(missed, cap, 0.016)
    losses = {s1: rough, s2: smooth, s4: smooth.copy()}
    residuals = {k: robust_residual(v) for k, v in losses.items()}
    assert residuals[s1] == pytest.approx(0.02) and residuals[s2] == pytest.approx(0.0216)
    assert undominated(rough, smooth, cap) and not undominated(smooth, rough, cap)
    assert tied_settings(residuals, losses, firings, cap) == (s1, s2)
    assert tied_settings(residuals, losses, firings) == (s1,)
    assert tie_reasons(residuals, losses, firings, cap)[s2] == (
        "next to the best; better on the 280 readings both predict (1.6 cm against 2 cm), "
        "the best predicts 120 more"
    )
    # a neighbour that predicts as many readings is judged by the residuals alone
    worse = {s1: rough, s2: np.full(400, 0.03), s4: smooth}
    res = {k: robust_residual(v) for k, v in worse.items()}
    assert tied_settings(res, worse, firings, cap) == (s1,)


def test_a_refit_within_two_paired_errors_of_the_candidate_is_applied() -> None:
    start, bins, beams, grid = _refit_case()
    one = _splines(0.2)
    alone = choose_refit(start, bins, beams, grid, chosen_residual=0.01, cap=0.05, settings=one)
    assert alone.residual is not None and alone.averaged == one
    mine = alone.losses[one[0]]
    # a candidate a hair better, reading by reading as scattered as the refit: the
    # readings cannot tell them apart
    close = np.random.default_rng(3).permutation(mine) * (1.0 - 1e-3)
    got = choose_refit(
        start, bins, beams, grid, chosen_residual=robust_residual(close), chosen_losses=close,
        cap=0.05, settings=one,
    )  # fmt: skip
    assert got.applied and "within 2 paired standard errors" in got.reason
    # a candidate clearly better keeps its own fit
    far = mine * 0.2
    kept = choose_refit(
        start, bins, beams, grid, chosen_residual=robust_residual(far), chosen_losses=far,
        cap=0.05, settings=one,
    )  # fmt: skip
    assert not kept.applied and kept.fit is None and "nor within" in kept.reason


def test_noisy_ranges_widen_the_tolerances_and_keep_the_noisy_echoes() -> None:
    # range noise 2.5 cm (5 cm on the path), close to the default second round's 3 cm
    beams = _bistatic_beams(np.random.default_rng(30), 600, noise=0.05)
    start, bins, _, grid = _refit_case()
    noise = range_noise(start, beams, grid.cell)
    # the estimate includes the start's 1.5 cm offset: between the noise and their sum
    assert 0.025 * 0.9 < noise < np.hypot(0.025, 0.015) * 1.1
    tols = tolerances(noise)
    assert tols == pytest.approx(tuple(k * noise for k in NOISE_WIDTHS))
    x = np.linspace(0.5, 3.5, 301)
    kept, rms = [], []
    for t in (ROUNDS_M, tols):
        fit, rows, _ = refit_profile(
            start, bins, beams, grid, (0.2, 3.8), RefitSetting("spline", 0.4), tols=t
        )
        kept.append(rows.size)
        rms.append(np.sqrt(np.mean((fit(x) - _wave(x)) ** 2)))
    # the default rounds drop the readings whose noise is above 3 cm, a fifth of them
    assert kept[1] > 1.1 * kept[0] and kept[1] > 0.75 * len(beams.path)
    assert rms[1] < rms[0]
    got = choose_refit(
        start, bins, beams, grid, chosen_residual=0.05, cap=0.1, settings=_splines(0.4)
    )
    doc = got.to_json()
    assert doc["range_noise_m"] == pytest.approx(noise, rel=0.05)
    assert doc["tolerances_m"] == pytest.approx(list(tolerances(doc["range_noise_m"])))
    # a clean log about a close profile keeps the default rounds; so does an estimate no
    # sensor's noise explains
    _, _, clean, _ = _refit_case()
    cx = grid.centres_x()
    exact = fit_spline(cx, _wave(cx), np.ones_like(cx), lam=1e-9)
    assert isinstance(exact, SplineFit)
    assert range_noise(exact, clean, grid.cell) < 0.002
    assert tolerances(range_noise(exact, clean, grid.cell)) == ROUNDS_M
    assert tolerances(1.0) == ROUNDS_M


def test_a_noise_estimate_the_starts_error_inflates_is_made_again_about_the_refit() -> None:
    """Range noise 5 cm and a start 7 cm below the wave: about the start the estimate is
    above NOISE_MAX (as for a profile that misses most readings), and the default 8 and
    3 cm rounds keep the readings whose noise happens to lie on the start's side. About
    the best refit the estimate comes down to the noise; the refits are made again with
    its tolerances."""
    _, _, _, grid = _refit_case()
    beams = _bistatic_beams(np.random.default_rng(40), 1200, noise=0.10)
    cx = grid.centres_x()
    far = fit_polynomial(cx, _wave(cx) - 0.07, np.ones_like(cx), order=15)
    assert isinstance(far, PolyFit)
    far_bins = bin_stats(np.arange(cx.size), _wave(cx) - 0.07, cx, presorted=True)
    assert range_noise(far, beams, grid.cell) > NOISE_MAX
    got = choose_refit(
        far, far_bins, beams, grid, chosen_residual=0.2, cap=0.2, settings=_splines(0.4, 0.8)
    )
    assert got.noise_start == pytest.approx(range_noise(far, beams, grid.cell))
    assert got.noise is not None and 0.05 < got.noise < NOISE_MAX
    assert got.tolerances == pytest.approx(tolerances(got.noise))
    doc = got.to_json()
    assert doc["range_noise_start_m"] == pytest.approx(got.noise_start)
    assert doc["range_noise_m"] == pytest.approx(got.noise)
    x = np.linspace(0.5, 3.5, 301)
    assert got.applied and got.fit is not None
    err = np.sqrt(np.mean((got.fit(x) - _wave(x)) ** 2))
    for setting in _splines(0.4, 0.8):
        fixed, _, _ = refit_profile(far, far_bins, beams, grid, (0.2, 3.8), setting, tols=ROUNDS_M)
        assert err < 0.7 * np.sqrt(np.mean((fixed(x) - _wave(x)) ** 2))
    # a clean log's refits are not made again
    start, bins, clean, _ = _refit_case()
    once = choose_refit(
        start, bins, clean, grid, chosen_residual=0.2, cap=0.2, settings=_splines(0.4)
    )
    assert once.noise_start is None and once.to_json()["range_noise_start_m"] is None


@pytest.mark.parametrize("seed", [0, 2, 3])
def test_noisy_echo_points_widen_the_refits_hull_tolerance(
    seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """150 readings with 4 cm of range noise: a smooth refit passes outside a few scattered
    echo points by more than 3 cells; the hull tolerance follows the noise (2 sigma)."""
    import sonarproc.auto.echo_refit as echo_refit
    import sonarproc.auto.refit_rounds as refit_rounds

    # the local hull on both sides: the far side's looser hull would hide the tolerance
    monkeypatch.setattr(echo_refit, "sensor_side", lambda beams, curve: 0)
    beams = _bistatic_beams(np.random.default_rng(seed), 150, noise=0.08)
    start, bins, _, grid = _refit_case()
    lengths = _splines(0.2, 0.4, 0.8, 1.6)
    got = choose_refit(start, bins, beams, grid, chosen_residual=0.05, cap=0.1, settings=lengths)
    assert got.noise is not None and 0.03 < got.noise < 0.06
    assert hull_tolerance(got.noise, grid.cell) == pytest.approx(2 * got.noise)
    assert not got.excluded and set(got.residuals) == set(lengths)
    # with the fixed 3-cell tolerance some of those lengths would have been excluded
    monkeypatch.setattr(refit_rounds, "HULL_NOISE_WIDTH", 0.0)
    fixed = choose_refit(start, bins, beams, grid, chosen_residual=0.05, cap=0.1, settings=lengths)
    assert fixed.excluded and set(fixed.residuals) < set(lengths)


def _quartic(x: np.ndarray) -> np.ndarray:
    u = x - 2.0
    return 2.0 + 0.06 * u**2 + 0.01 * u**3 - 0.012 * u**4


def test_a_tied_polynomial_carries_the_curvature_across_a_stretch_that_echoes_nothing() -> None:
    """Sensors below a quartic wall except under x = 1.3-2.8 m: the splines and the
    polynomials predict the held-out readings alike; the lowest-order polynomial that
    agrees with the most flexible spline where readings echo is taken, and it is the
    closer one across the stretch no reading sees."""
    xs = np.linspace(-1.0, 5.0, 6001)
    rng = np.random.default_rng(5)
    sx = np.repeat(np.r_[np.linspace(0.3, 1.3, 50), np.linspace(2.8, 4.0, 60)], 3)
    heading = np.pi / 2 + rng.uniform(-0.25, 0.25, sx.size)
    beams, _ = beams_facing(
        np.column_stack((sx, np.zeros_like(sx))), heading, np.column_stack((xs, _quartic(xs)))
    )
    beams.path[:] += rng.normal(0.0, 0.002, beams.path.size)
    beams.readings["t"] = np.arange(beams.path.size)  # one firing per reading
    grid = Grid.covering(0.0, 4.3, 0.0, 3.0, cell=0.01)
    cx = grid.centres_x()
    seen = (cx > 0.3) & (cx < 4.0)
    bins = bin_stats(np.flatnonzero(seen), _quartic(cx[seen]) - 0.02, cx, presorted=True)
    start = fit_polynomial(cx[seen], _quartic(cx[seen]) - 0.02, np.ones(seen.sum()), order=6)
    got = choose_refit(start, bins, beams, grid, chosen_residual=0.05, cap=0.05)
    assert got.applied and isinstance(got.fit, PolyFit) and got.setting is not None
    assert got.setting.family == "poly" and got.fit.order == got.setting.value
    assert len(got.tied) > 1 and got.setting in got.tied and got.averaged == (got.setting,)
    # no tied polynomial of a lower order agrees with the reference
    reference = references(got.tied, got.best or got.setting)[0]
    assert reference.family == "spline"
    lower = tuple(k for k in got.tied if k.family == "spline" or k < got.setting)
    assert simplest_agreeing(lower, reference, got.fits, got.echo_x, got.spans, 0.01) is None
    gap = np.linspace(1.3, 2.8, 151)
    err = {k: np.abs(got.fits[k](gap) - _quartic(gap)).max() for k in got.tied}
    assert err[got.setting] < 0.002 and err[got.setting] < err[reference]
    doc = got.to_json()
    assert doc["polynomial_order"] == int(got.setting.value) and doc["smoothing_length_m"] is None
    assert doc["fit_short"] == doc["setting"] == got.setting.short
    assert doc["averaged_lengths_m"] == [] and got.setting.short in doc["tied"]
    assert f"lowest-order polynomial among the {len(got.tied)} tied refits" in doc["reason"]


def test_a_polynomial_that_misses_a_dent_the_readings_see_does_not_agree() -> None:
    x = np.linspace(0.0, 4.0, 401)
    y = 2.0 - 0.08 * np.exp(-(((x - 2.0) / 0.15) ** 2))
    one = np.ones_like(x)
    spline, p2, p4 = RefitSetting("spline", 0.1), RefitSetting("poly", 2), RefitSetting("poly", 4)
    fits = {spline: fit_spline(x, y, one, lam=1e-8)}
    fits |= {k: fit_polynomial(x, y, one, order=int(k.value)) for k in (p2, p4)}
    spans = dict.fromkeys(fits, (0.0, 4.0))
    tied = (p2, p4, spline)
    assert simplest_agreeing(tied, spline, fits, {spline: x}, spans, 0.01) is None
    # the same polynomials agree where the readings see no dent (echoes only beyond it)...
    far = x[np.abs(x - 2.0) > 0.6]
    got = simplest_agreeing(tied, spline, fits, {spline: far}, spans, 0.03)
    assert got is not None and got[0] == p2 and got[1] <= 0.03
    # ... and the reference's echoes beyond a polynomial's own echo span do not count
    fits[p2] = fit_polynomial(x[x > 2.5], y[x > 2.5], one[x > 2.5], order=2)
    spans[p2] = (2.5, 4.0)
    got = simplest_agreeing((p2, spline), spline, fits, {spline: x}, spans, 0.01)
    assert got is not None and got[0] == p2


def test_a_profile_few_readings_echo_from_is_not_refitted() -> None:
    _, bins, beams, grid = _refit_case()
    # a profile a metre above the wave: no reading's path comes near it
    far = PolyFit(0, np.array([float(np.mean(_wave(grid.centres_x()))) + 1.0]), (0.0, 4.0))
    got = choose_refit(far, bins, beams, grid, chosen_residual=0.01, cap=0.05)
    assert not got.applied and got.fit is None and not got.residuals
    assert f"(at least {MIN_ECHO_POINTS} needed)" in got.reason


def _refit_with(residual: float | None, losses: np.ndarray | None) -> RefitChoice:
    out = RefitChoice("echo")
    out.residual, out.heldout = residual, losses
    return out


def test_the_winners_start_is_kept_unless_another_refit_is_clearly_better() -> None:
    from sonarproc.auto.select import _pick_start

    rng = np.random.default_rng(8)
    mine = np.abs(rng.normal(0.0, 0.01, 400))
    # a hair better, as scattered: tied, the winner's start is kept
    close = rng.permutation(mine) * 0.999
    tied = [_refit_with(robust_residual(mine), mine), _refit_with(robust_residual(close), close)]
    assert _pick_start(tied) == 0
    # half the loss on every reading: many paired errors better, that start is taken
    better = mine * 0.5
    refits = [*tied, _refit_with(robust_residual(better), better)]
    assert _pick_start(refits) == 2
    # the winner's own start found no refit: the best other one is taken
    assert _pick_start([_refit_with(None, None), refits[1], refits[2]]) == 2
    assert _pick_start([_refit_with(None, None), _refit_with(None, None)]) == 0


def test_run_auto_records_the_refit_and_measures_what_it_returns(tmp_path: Path) -> None:
    path = tmp_path / "fig02.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig02.yaml", path)
    res, chosen, choice = run_auto(load_log(path), RunParams())
    rec = choice.to_json(chosen)["echo_refit"]
    assert rec is not None and set(rec) >= {"criterion", "residuals_m", "applied", "reason"}
    # the refit starts from the winner and from at most two runners-up, and says which won
    starts = [s["start"] for s in rec["starts"]]
    assert 1 <= len(starts) <= 3 and starts[0].startswith(chosen.candidate.name + " (")
    assert rec["start"] in starts
    assert ("started from" in rec["reason"]) == (rec["start"] != starts[0])
    # every tied refit says why it is tied; the best is one of them
    assert set(rec["tied_why"]) == set(rec["tied"]) and "the best" in rec["tied_why"].values()
    r = res.run
    if rec["applied"]:
        assert r.params.fit == r.fit.kind in ("spline", "poly")
        assert (r.fit.kind == "poly") == (rec["polynomial_order"] is not None)
        assert min(v for v in rec["residuals_m"].values() if v is not None) < chosen.residual_m
    # E1 is that of the profile returned, on the judged columns
    x = r.bins.centres[r.bins.occupied]
    assert r.metrics.E1_m is not None and np.isfinite(r.fit(x)).all()
    if rec["applied"]:
        # reported only between the outermost echo points (the map carries it beyond)
        x0, x1 = rec["echo_span_m"]
        assert x.min() >= x0 - r.grid.cell and x.max() <= x1 + r.grid.cell
        assert x.size < int(res.run.bins.centres.size)


@settings(max_examples=200, deadline=None)
@given(
    body=st.lists(st.floats(0.0, 5.0), min_size=1, max_size=300),
    left=st.lists(st.floats(0.0, 0.3), max_size=12),
    right=st.lists(st.floats(0.0, 0.3), max_size=12),
    gap=st.floats(0.0, 0.5),
)
def test_main_body_drops_only_small_end_clusters_beyond_a_gap(
    body: list[float], left: list[float], right: list[float], gap: float
) -> None:
    b = np.array(body)
    x = np.concatenate((b.min() - gap - np.array(left), b, b.max() + gap + np.array(right)))
    keep = main_body(x)
    n, limit = x.size, END_SHARE * x.size
    # what goes is at the ends: every kept point lies between the dropped ones
    if (~keep).any() and keep.any():
        lo, hi = x[keep].min(), x[keep].max()
        assert np.all((x[~keep] < lo) | (x[~keep] > hi))
        # each end's dropped points are few, and cut off by a gap
        for side in (x[~keep] < lo, x[~keep] > hi):
            assert side.sum() <= limit
        dropped_left = x[~keep][x[~keep] < lo]
        if dropped_left.size:
            assert lo - dropped_left.max() > END_GAP_M
        dropped_right = x[~keep][x[~keep] > hi]
        if dropped_right.size:
            assert dropped_right.min() - hi > END_GAP_M
    # a body with no gap inside loses its small end clusters exactly when they are cut off
    spread = np.diff(np.sort(b))
    if b.size >= 2 and (spread.size == 0 or spread.max() <= END_GAP_M) and n > 0:
        clusters = [c for c in (left, right) if c]
        if gap > END_GAP_M + 0.3 and all(len(c) <= limit for c in clusters):
            assert keep.sum() == b.size
    assert keep.sum() >= 1


def test_the_record_shows_the_refit_in_the_terminal_and_the_page() -> None:
    from rich.console import Console

    from sonarproc.auto.record import record_table
    from sonarproc.report.auto_record import auto_record_html

    rec = {
        "criterion": "held-out", "choice": "a", "fit_short": "poly m=2", "residual_m": 0.004,
        "folds": 4, "runners_up": [],
        "echo_refit": {"criterion": "echo", "residuals_m": {"0.2": 0.0021, "0.4": 0.003},
                       "excluded": {}, "smoothing_length_m": 0.2, "applied": True,
                       "reason": "held-out residual 0.21 cm below the chosen candidate's 0.4 cm"},
    }  # fmt: skip
    console = Console(width=200, record=True)
    console.print(record_table(rec))
    text = console.export_text()
    assert "echo refit" in text and "spline L=0.2 m" in text and "0.21 cm" in text
    page = auto_record_html(rec)
    assert "<td>echo refit</td>" in page and "applied: held-out residual" in page


def test_a_best_polynomial_no_tied_spline_agrees_with_is_kept(tmp_path: Path) -> None:
    """A linear array under a narrow dip: the order-15 refit predicts the held-out ranges
    best and follows the dip; the one spline tied with it (L=0.8 m) smooths the dip
    away. The polynomial is kept, not replaced by the tied splines' average."""
    path = tmp_path / "dip.h5"
    simulate_to_log(ROOT / "tests/data/scenarios/auto13-linear-dip.yaml", path)
    res, chosen, choice = run_auto(load_log(path), RunParams())
    rec = choice.to_json(chosen)["echo_refit"]
    assert rec["applied"] and rec["polynomial_order"] == 15 and rec["smoothing_length_m"] is None
    assert res.run.params.fit == "poly" and res.run.params.order == 15
    # by the truth, which auto never sees: the dip is followed (the 0.8 m spline is 2.7 cm off)
    assert res.run.metrics.E1_m is not None and res.run.metrics.E1_m < 0.01


def test_when_every_candidate_is_excluded_the_record_says_so_and_the_fallback_is_refitted(
    tmp_path: Path,
) -> None:
    """A ring walk with 7 cm of range noise: every candidate's fit leaves its hull or
    covers too few columns. The best ranked is returned, the record says why, and it is
    refitted through the echo points (whose own hull guard judges the refit)."""
    import html

    from sonarproc.auto.record import chosen_note
    from sonarproc.report.auto_record import auto_record_html

    path = tmp_path / "noisy.h5"
    simulate_to_log(ROOT / "tests/data/scenarios/auto14-noisy-ring-walk.yaml", path)
    res, chosen, choice = run_auto(load_log(path), RunParams())
    rec = choice.to_json(chosen)
    assert chosen.excluded is not None and all(r["excluded"] for r in rec["runners_up"])
    assert rec["fallback"] == (
        "every candidate was excluded by the guard rails; the best ranked is returned "
        f"({chosen.excluded})"
    )
    assert chosen_note(rec).startswith("chosen: every candidate was excluded")
    assert html.escape(rec["fallback"]) in auto_record_html(rec)
    refit = rec["echo_refit"]
    assert refit is not None and refit["applied"] and refit["residual_m"] < chosen.residual_m
    assert res.run.fit.kind == res.run.params.fit and rec["profile_columns"] is not None

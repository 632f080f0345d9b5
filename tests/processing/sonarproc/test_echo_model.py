"""The first-echo model's windows: each reading looks only at the samples its beams reach."""

from __future__ import annotations

from unittest.mock import patch

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import sonarproc.methods.echo_model as echo_model
from sonarproc.methods.echo_model import beam_x_bounds, first_echo


@settings(max_examples=200, deadline=None)
@given(
    apex=st.tuples(st.floats(-5, 5), st.floats(-3, 5)),
    heading=st.floats(-np.pi, np.pi),
    half=st.floats(0.01, 1.8),
    band=st.tuples(st.floats(-2, 3), st.floats(0.0, 2.0)),
    seed=st.integers(0, 2**16),
)
def test_every_point_of_a_wedge_in_the_band_lies_within_its_x_bounds(
    apex: tuple[float, float],
    heading: float,
    half: float,
    band: tuple[float, float],
    seed: int,
) -> None:
    ymin, ymax = band[0], band[0] + band[1]
    lo, hi = beam_x_bounds(np.array([apex]), np.array([heading]), np.array([half]), ymin, ymax)
    rng = np.random.default_rng(seed)
    # points of the wedge: directions within the half beamwidth, distances up to 50 m
    ang = heading + rng.uniform(-half, half, 4000)
    dist = rng.uniform(0.0, 50.0, 4000)
    x = apex[0] + dist * np.cos(ang)
    y = apex[1] + dist * np.sin(ang)
    inside = (y >= ymin) & (y <= ymax)
    assert np.all(x[inside] >= lo[0] - 1e-9) and np.all(x[inside] <= hi[0] + 1e-9)


def _profile(rng: np.random.Generator, m: int) -> np.ndarray:
    xs = np.unique(np.sort(rng.uniform(-3.0, 3.0, m)))
    ys = 2.0 + 0.2 * np.sin(rng.uniform(0.5, 5.0) * xs + rng.uniform(0.0, 6.0))
    return np.column_stack((xs, ys))


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    m=st.integers(5, 600),
    n=st.integers(1, 300),
    bistatic=st.booleans(),
    ranked=st.booleans(),
)
def test_a_profile_gives_the_same_echoes_as_the_whole_curve(
    seed: int, m: int, n: int, bistatic: bool, ranked: bool
) -> None:
    """On a profile y(x) each reading looks at its beams' window of samples; the same
    curve in the other order (x decreasing: no window) is searched whole. Both find the
    same path lengths, each at a sample with that path."""
    rng = np.random.default_rng(seed)
    curve = _profile(rng, m)
    t = np.column_stack((rng.uniform(-4, 4, n), rng.uniform(-1, 3.5, n)))
    # most beams look up at the profile (narrow windows), some anywhere (wide ones)
    up = rng.random(n) < 0.8
    ht = np.where(up, rng.uniform(0.3, 2.8, n), rng.uniform(-np.pi, np.pi, n))
    wt = np.where(up, rng.uniform(0.05, 0.8, n), rng.uniform(0.05, 1.7, n))
    if bistatic:
        r, hr, wr = t + rng.normal(0, 0.5, (n, 2)), ht + rng.normal(0, 0.3, n), wt[::-1].copy()
    else:
        r, hr, wr = t, ht, wt
    rank = rng.integers(0, 3, n) if ranked else None
    with patch.object(echo_model, "_WINDOW_MIN_WORK", 0):  # windows however small the work
        path, at = first_echo(t, ht, wt, r, hr, wr, curve, rank)
    whole, at_whole = first_echo(t, ht, wt, r, hr, wr, curve[::-1], rank)
    np.testing.assert_array_equal(np.isnan(path), np.isnan(whole))
    np.testing.assert_allclose(path[~np.isnan(path)], whole[~np.isnan(whole)], rtol=0, atol=1e-12)
    hit = at >= 0
    np.testing.assert_array_equal(hit, at_whole >= 0)
    p = curve[at[hit]]
    via = np.hypot(*(p - t[hit]).T) + np.hypot(*(p - r[hit]).T)
    np.testing.assert_allclose(via, path[hit], rtol=0, atol=1e-9)


def test_a_bistatic_pairs_echo_point_is_its_specular_point_not_the_midpoints_foot() -> None:
    """A pair 0.4 m apart under a wall along y = 1 with a slope: the echo point is where
    the wall's normal bisects the directions to both ends (the mirror image of the
    receiver), found from a curve 2 cm short of the wall, and a reading 10 cm off the
    predicted path is not one of the wall's echoes."""
    from sonarproc.methods.echo_model import curve_echo_points

    slope = 0.1
    tx, rx = np.array([0.0, 0.0]), np.array([0.4, 0.0])
    normal = np.array([-slope, 1.0]) / np.hypot(slope, 1.0)
    # the mirror image of the receiver in the wall y = 1 + slope * x
    image = rx + 2 * (1.0 - (rx @ normal) * np.hypot(slope, 1.0)) / np.hypot(slope, 1.0) * normal
    d = image - tx
    t = (1.0 - tx[1] + slope * tx[0]) / (d[1] - slope * d[0])
    specular = tx + t * d
    path = float(np.hypot(*(specular - tx)) + np.hypot(*(specular - rx)))
    xs = np.linspace(-1.0, 1.5, 2501)
    short = np.column_stack((xs, 0.98 + slope * xs))
    up, half = np.pi / 2, 0.6
    rows, pts = curve_echo_points(
        [tx, tx], [up, up], [half, half], [rx, rx], [up, up], [half, half],
        [path, path + 0.2], short, tol=0.05,
    )  # fmt: skip
    assert rows.tolist() == [0]
    np.testing.assert_allclose(pts[0], specular, atol=2e-3)
    above_midpoint = np.array([0.2, 1.0 + slope * 0.2])
    assert np.hypot(*(specular - above_midpoint)) > 0.01

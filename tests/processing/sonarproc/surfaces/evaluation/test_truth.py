"""Multi-surface truth: split, the truth the sonars saw, precision and completeness."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces import (
    distance_to_polylines,
    join_polylines,
    seen_truth,
    split_polylines,
    surface_metrics,
    truth_is_function,
    truth_points,
)


def test_split_and_join_round_trip() -> None:
    parts = [np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 1.0], [0.0, 2.0], [1, 2]])]
    joined = join_polylines(parts)
    assert np.isnan(joined[2]).all() and joined.shape == (6, 2)
    back = split_polylines(joined)
    assert len(back) == 2 and all(np.array_equal(a, b) for a, b in zip(back, parts, strict=True))


@settings(max_examples=40, deadline=None)
@given(
    st.floats(-5, 5), st.floats(-5, 5), st.floats(0.01, 3.0), st.floats(-np.pi, np.pi),
    st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),
)  # fmt: skip
def test_distance_to_a_segment_is_exact(
    x0: float, y0: float, length: float, ang: float, u: float, v: float
) -> None:
    a = np.array([x0, y0])
    d = np.array([np.cos(ang), np.sin(ang)])
    seg = np.stack((a, a + length * d))
    q = a + u * length * d + v * np.array([-d[1], d[0]])
    t = np.clip(u, 0.0, 1.0)
    want = np.hypot(*(q - (a + t * length * d)))
    got = distance_to_polylines(q[None], [seg])[0]
    assert abs(got - want) <= 1e-9


def test_seen_truth_monostatic_beam_and_range() -> None:
    wall = truth_points(np.array([[-2.0, 1.0], [2.0, 1.0]]), 0.01)[0]
    seen = seen_truth(wall, [[0.0, 0.0]], [np.pi / 2], [[0.0, 0.0]], [np.pi / 2], [2.0],
                      tx_half_beamwidth=np.deg2rad(12.5), rx_half_beamwidth=np.deg2rad(12.5),
                      tol=0.02)  # fmt: skip
    x = wall[seen, 0]
    # |p| <= 1.02 m: |x| <= sqrt(1.02^2 - 1) ~ 0.2 m
    assert x.size and np.abs(x).max() <= np.sqrt(1.02**2 - 1) + 1e-9
    assert np.abs(x).max() >= 0.19


def test_seen_truth_bistatic_uses_the_ellipse_and_both_beams() -> None:
    wall = truth_points(np.array([[-2.0, 1.0], [2.0, 1.0]]), 0.005)[0]
    tx, rx = np.array([-0.2, 0.0]), np.array([0.2, 0.0])
    path = 2 * np.hypot(0.2, 1.0)  # specular point at (0, 1)
    wide = np.deg2rad(40.0)
    seen = seen_truth(wall, [tx], [np.pi / 2], [rx], [np.pi / 2], [path],
                      tx_half_beamwidth=wide, rx_half_beamwidth=wide, tol=0.01)  # fmt: skip
    x = wall[seen, 0]
    assert x.size and abs(float(np.mean(x))) <= 0.01
    s_all = np.hypot(*(wall - tx).T) + np.hypot(*(wall - rx).T)
    assert np.all(np.abs(s_all[seen] - path) <= 0.02)
    narrow = seen_truth(wall, [tx], [np.pi / 2 + 0.6], [rx], [np.pi / 2], [path],
                        tx_half_beamwidth=0.1, rx_half_beamwidth=0.1, tol=0.01)  # fmt: skip
    assert not narrow.any()


def test_seen_truth_matches_brute_force_on_many_readings() -> None:
    rng = np.random.default_rng(7)
    truth = join_polylines([np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]),
                            np.array([[1.0, 2.0], [2.0, 2.5]])])  # fmt: skip
    pts = np.concatenate(truth_points(truth, 0.02))
    n = 3000
    txy = rng.uniform([0.5, 0.5], [3.5, 2.0], (n, 2))
    rxy = txy + rng.normal(0, 0.1, (n, 2))
    th = rng.uniform(-np.pi, np.pi, n)
    rh = th + rng.normal(0, 0.1, n)
    path = rng.uniform(0.5, 6.0, n)
    beam = np.deg2rad(12.5)
    got = seen_truth(pts, txy, th, rxy, rh, path, tx_half_beamwidth=beam,
                     rx_half_beamwidth=beam, tol=0.03)  # fmt: skip
    vt = pts[None] - txy[:, None]
    vr = pts[None] - rxy[:, None]

    def wrap(a: np.ndarray) -> np.ndarray:
        return (a + np.pi) % (2 * np.pi) - np.pi

    hit = (
        (np.abs(wrap(np.arctan2(vt[..., 1], vt[..., 0]) - th[:, None])) <= beam)
        & (np.abs(wrap(np.arctan2(vr[..., 1], vr[..., 0]) - rh[:, None])) <= beam)
        & (np.abs(np.hypot(vt[..., 0], vt[..., 1]) + np.hypot(vr[..., 0], vr[..., 1])
                  - path[:, None]) <= 0.06)
    )  # fmt: skip
    assert got.any()
    assert np.array_equal(got, hit.any(axis=0))


def test_metrics_precision_and_completeness() -> None:
    truth = join_polylines([np.array([[0.0, 0.0], [2.0, 0.0]]), np.array([[0.0, 1.0], [2, 1]])])
    fitted = [np.array([[0.0, 0.02], [1.0, 0.02]])]
    m = surface_metrics(fitted, truth, step=0.01)
    assert abs(m.precision_m - 0.02) < 1e-9  # type: ignore[operator]
    # x = 0 .. 1.04 of the first wall lies within 5 cm of the fitted piece: 105 points
    assert m.truth_points == 402 and m.found_points == 105
    seen = np.zeros(402, bool)
    seen[:150] = True  # only the first wall's points 0..149 were seen
    m2 = surface_metrics(fitted, truth, seen=seen, step=0.01)
    assert m2.seen_points == 150 and abs(m2.completeness - 105 / 150) < 1e-12  # type: ignore[operator]
    assert surface_metrics([], truth).precision_m is None


def test_truth_is_function() -> None:
    x = np.linspace(0, 1, 50)
    assert truth_is_function(np.column_stack((x, np.sin(x))))
    assert not truth_is_function(np.column_stack((np.cos(4 * x), np.sin(4 * x))))

"""The truth the sonars saw: the chunked, seen-skipping search against every pair tested."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces import join_polylines, seen_truth, truth_points
from sonarproc.surfaces.evaluation import seen

Floats = npt.NDArray[np.float64]


def brute_force(
    pts: Floats,
    txy: Floats,
    th: Floats,
    rxy: Floats,
    rh: Floats,
    path: Floats,
    tb: Floats,
    rb: Floats,
    tol: float,
) -> npt.NDArray[np.bool_]:
    """Every (reading, point) pair tested: the definition of seen."""
    vt = pts[None] - txy[:, None]
    vr = pts[None] - rxy[:, None]

    def wrap(a: Floats) -> Floats:
        return np.asarray((a + np.pi) % (2 * np.pi) - np.pi, dtype=np.float64)

    hit = (
        (np.abs(wrap(np.arctan2(vt[..., 1], vt[..., 0]) - th[:, None])) <= tb[:, None])
        & (np.abs(wrap(np.arctan2(vr[..., 1], vr[..., 0]) - rh[:, None])) <= rb[:, None])
        & (np.abs(np.hypot(vt[..., 0], vt[..., 1]) + np.hypot(vr[..., 0], vr[..., 1])
                  - path[:, None]) <= 2.0 * tol)
    )  # fmt: skip
    return np.asarray(hit.any(axis=0))


def random_scene(
    seed: int, n: int, pieces: int, bistatic: bool, beam: float
) -> tuple[Floats, tuple[Floats, ...]]:
    """Truth polylines in a 4 m square and readings whose paths often land on them."""
    rng = np.random.default_rng(seed)
    parts = [rng.uniform(0.0, 4.0, (int(rng.integers(2, 6)), 2)) for _ in range(pieces)]
    pts = np.concatenate(truth_points(join_polylines(parts), 0.02))
    txy = rng.uniform(-0.5, 4.5, (n, 2))
    rxy = txy + (rng.normal(0.0, 0.3, (n, 2)) if bistatic else 0.0)
    # aim most readings at a truth point so that something is seen
    aim = pts[rng.integers(0, len(pts), n)] + rng.normal(0.0, 0.05, (n, 2))
    th = np.arctan2(*(aim - txy).T[::-1]) + rng.normal(0.0, 0.2, n)
    rh = np.arctan2(*(aim - rxy).T[::-1]) + rng.normal(0.0, 0.2, n)
    path = np.hypot(*(aim - txy).T) + np.hypot(*(aim - rxy).T)
    tb = np.full(n, beam) * rng.uniform(0.5, 1.5, n)
    rb = np.full(n, beam) * rng.uniform(0.5, 1.5, n)
    return pts, (txy, th, rxy, rh, path, tb, rb)


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 80),
    pieces=st.integers(1, 3),
    bistatic=st.booleans(),
    beam=st.floats(0.02, 3.5),
    tol=st.floats(0.0, 0.2),
    pairs=st.sampled_from([1, 200, seen.PAIRS_PER_CHUNK]),
    stride=st.sampled_from([1, 3, seen.FIRST_PASS_STRIDE]),
)
def test_seen_truth_equals_every_pair_tested(
    seed: int,
    n: int,
    pieces: int,
    bistatic: bool,
    beam: float,
    tol: float,
    pairs: int,
    stride: int,
) -> None:
    pts, (txy, th, rxy, rh, path, tb, rb) = random_scene(seed, n, pieces, bistatic, beam)
    want = brute_force(pts, txy, th, rxy, rh, path, tb, rb, tol)
    # a tiny pair budget forces one reading a chunk and many rebuilds of the truth tree;
    # the first pass's sample (any stride) changes the order of the pairs, not the answer
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(seen, "PAIRS_PER_CHUNK", pairs)
        mp.setattr(seen, "FIRST_PASS_STRIDE", stride)
        got = seen_truth(pts, txy, th, rxy, rh, path, tx_half_beamwidth=tb,
                         rx_half_beamwidth=rb, tol=tol)  # fmt: skip
    assert got.dtype == np.bool_ and got.shape == (len(pts),)
    assert np.array_equal(got, want)


def test_seen_truth_many_chunks_equal_one_chunk() -> None:
    pts, (txy, th, rxy, rh, path, tb, rb) = random_scene(11, 400, 3, True, 0.3)
    want = brute_force(pts, txy, th, rxy, rh, path, tb, rb, 0.03)
    assert 0 < want.sum() < len(pts)
    for pairs in (50, 5_000, 10_000_000):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(seen, "PAIRS_PER_CHUNK", pairs)
            got = seen_truth(pts, txy, th, rxy, rh, path, tx_half_beamwidth=tb,
                             rx_half_beamwidth=rb, tol=0.03)  # fmt: skip
        assert np.array_equal(got, want), pairs


def test_seen_truth_ignores_readings_without_a_finite_ball() -> None:
    wall = truth_points(np.array([[-2.0, 1.0], [2.0, 1.0]]), 0.01)[0]
    up = np.pi / 2
    good = seen_truth(wall, [[0.0, 0.0]], [up], [[0.0, 0.0]], [up], [2.0],
                      tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)  # fmt: skip
    got = seen_truth(
        wall,
        [[0.0, 0.0], [np.nan, 0.0], [0.0, 0.0], [0.0, 0.0]],
        [up, up, np.nan, up],
        [[0.0, 0.0]] * 4,
        [up] * 4,
        [2.0, 2.0, 2.0, np.inf],
        tx_half_beamwidth=[0.2, 0.2, 0.2, 0.2],
        rx_half_beamwidth=0.2,
    )
    assert good.sum() > 10 and np.array_equal(got, good)


def test_seen_truth_without_points_or_readings() -> None:
    none = np.zeros((0, 2))
    assert seen_truth(none, [[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [1.0],
                      tx_half_beamwidth=0.2, rx_half_beamwidth=0.2).shape == (0,)  # fmt: skip
    got = seen_truth([[1.0, 0.0]], none, [], none, [], [],
                     tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)  # fmt: skip
    assert got.tolist() == [False]

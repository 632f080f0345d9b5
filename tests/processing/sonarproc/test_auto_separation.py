"""--auto's profile columns: stray clusters are left out of a y(x) profile, a wave is not cut."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.auto.separation import SPLIT_GAP_M, STEP_M, profile_columns
from sonarproc.grid import Grid

GRID = Grid.covering(0.0, 6.0, 0.0, 6.0, cell=0.02)


def _map(points: list[tuple[float, float]]) -> np.ndarray:
    m = np.zeros(GRID.shape, dtype=bool)
    for x, y in points:
        iy, ix = GRID.to_index(np.array([x]), np.array([y]))
        m[iy[0], ix[0]] = True
    return m


def _columns(xs: np.ndarray) -> set[int]:
    return {int(np.rint((x - GRID.centres_x()[0]) / GRID.cell)) for x in xs}


def test_a_wave_seen_at_its_crests_and_troughs_is_one_profile() -> None:
    # specular points only: a crest at y = 2.4 and a trough at y = 2.0 every 0.5 m, the
    # flanks unseen (gaps of 0.35 m, a step of 0.4 m: steeper than 45 degrees, under STEP_M)
    xs = np.arange(0.5, 5.5, 0.02)
    phase = (xs // 0.5) % 2
    seen = (xs % 0.5) < 0.15
    m = _map([(x, 2.0 + 0.4 * p) for x, p, s in zip(xs, phase, seen, strict=True) if s])
    assert profile_columns(m, GRID).all()


def test_a_cluster_behind_the_end_of_a_wall_is_left_out() -> None:
    wall = [(x, 1.5 - 0.02 * x) for x in np.arange(0.2, 2.0, 0.02)]
    stray = [(x, 3.8 - 0.3 * (x - 3.0)) for x in np.arange(3.0, 3.6, 0.02)]
    keep = profile_columns(_map(wall + stray), GRID)
    cols = np.flatnonzero(keep)
    assert _columns(np.array([p[0] for p in wall])) <= set(cols.tolist())
    assert not (_columns(np.array([p[0] for p in stray])) & set(cols.tolist()))


@settings(max_examples=40, deadline=None)
@given(
    wall_y=st.floats(0.8, 2.5),
    slope=st.floats(-0.2, 0.2),
    behind=st.floats(STEP_M + 0.6, 3.0),
    at=st.floats(1.5, 3.5),
    width=st.floats(0.05, 0.4),
    seed=st.integers(0, 2**31 - 1),
)
def test_a_cluster_interrupting_a_wall_does_not_cut_it(
    wall_y: float, slope: float, behind: float, at: float, width: float, seed: int
) -> None:
    """The wall's columns on both sides of a stray cluster stay; the cluster's go."""
    rng = np.random.default_rng(seed)
    gap = SPLIT_GAP_M + 0.05
    xs = np.arange(0.2, 5.8, 0.02)
    left = xs[xs < at - gap]
    right = xs[xs > at + width + gap]
    wall_x = np.r_[left, right]
    wall = [(x, wall_y + slope * (x - 3.0) + rng.normal(0, 0.005)) for x in wall_x]
    stray_x = np.arange(at, at + width, 0.02)
    stray = [(x, wall_y + behind + rng.normal(0, 0.02)) for x in stray_x]
    keep = set(np.flatnonzero(profile_columns(_map(wall + stray), GRID)).tolist())
    assert _columns(wall_x) <= keep
    assert not (_columns(stray_x) & keep)

"""Joining the pieces of one wall, and dropping surfaces the sound passed through."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from sonarproc.surfaces.batchfit import fit_surface
from sonarproc.surfaces.extract import SurfaceCells
from sonarproc.surfaces.merge import merge_collinear
from sonarproc.surfaces.models import SurfaceFit
from sonarproc.surfaces.occlusion import contradicted, segment_crossings

CELL = 0.01


def _piece(x0: float, x1: float, y: float, angle_deg: float = 0.0) -> SurfaceCells:
    u = np.arange(0.0, x1 - x0, CELL)
    a = np.deg2rad(angle_deg)
    x, yy = x0 + u * np.cos(a), y + u * np.sin(a)
    return SurfaceCells(x, yy, u, np.ones_like(u), False)


def _fits(pieces: list[SurfaceCells]) -> list[SurfaceFit]:
    out = [fit_surface(p, cell=CELL) for p in pieces]
    assert all(isinstance(f, SurfaceFit) for f in out)
    return out  # type: ignore[return-value]


def test_three_pieces_of_one_wall_become_one_line() -> None:
    pieces = [_piece(0.0, 1.0, 2.0), _piece(1.1, 1.9, 2.002), _piece(2.15, 3.0, 1.998)]
    merged, cells = merge_collinear(_fits(pieces), pieces, cell=CELL)
    assert [f.model for f in merged] == ["line"]
    ends = merged[0].polyline[[0, -1]]
    np.testing.assert_allclose(sorted(ends[:, 0]), [0.0, 2.99], atol=0.015)
    np.testing.assert_allclose(ends[:, 1], 2.0, atol=0.005)
    assert cells[0].size == sum(p.size for p in pieces)
    assert np.all(np.diff(cells[0].s) >= 0)


@pytest.mark.parametrize(
    ("second", "why"),
    [
        (_piece(1.8, 3.0, 2.0), "a doorway: 0.8 m gap"),
        (_piece(0.0, 1.0, 3.6), "the other wall of a corridor"),
        (_piece(1.05, 2.0, 2.0, angle_deg=10.0), "a turn of 10 degrees"),
    ],
)
def test_separate_surfaces_stay_apart(second: SurfaceCells, why: str) -> None:
    pieces = [_piece(0.0, 1.0, 2.0), second]
    merged, _ = merge_collinear(_fits(pieces), pieces, cell=CELL)
    assert len(merged) == 2, why


def _wall(y: float, x0: float = -1.0, x1: float = 1.0) -> np.ndarray:
    x = np.arange(x0, x1 + CELL / 2, CELL)
    return np.stack((x, np.full_like(x, y)), axis=1)


def test_a_phantom_behind_a_wall_goes_and_the_wall_stays() -> None:
    xs = np.linspace(-0.9, 0.9, 40)
    xp = np.linspace(-0.4, 0.4, 6)
    drop = contradicted(
        [_wall(1.0), _wall(1.6)],
        [np.c_[xs, 0 * xs], np.c_[xp, 0 * xp]],
        [np.c_[xs, 1 + 0 * xs], np.c_[xp, 1.6 + 0 * xp]],
        cell=CELL,
    )
    assert drop == [1]


def test_a_phantom_in_free_space_goes_when_the_sound_crossed_its_middle() -> None:
    xs = np.linspace(-0.9, 0.9, 40)
    xp = np.linspace(-0.3, 0.3, 6)
    drop = contradicted(
        [_wall(2.0), _wall(1.0, -0.5, 0.5)],  # the short one stands across the wall's paths
        [np.c_[xs, 0 * xs], np.c_[xp, 0.2 + 0 * xp]],
        [np.c_[xs, 2 + 0 * xs], np.c_[xp, 1.0 + 0 * xp]],
        cell=CELL,
    )
    assert drop == [1]


def test_crossings_near_a_surfaces_end_do_not_drop_it() -> None:
    # the wall's paths cross only the last 20 cm of the short surface (its stretched end)
    xs = np.linspace(0.35, 0.5, 10)
    xp = np.linspace(-0.3, 0.3, 6)
    drop = contradicted(
        [_wall(2.0), _wall(1.0, -0.5, 0.5)],
        [np.c_[xs, 0 * xs], np.c_[xp, 0.2 + 0 * xp]],
        [np.c_[xs, 2 + 0 * xs], np.c_[xp, 1.0 + 0 * xp]],
        cell=CELL,
    )
    assert drop == []


def _crosses(p: np.ndarray, q: np.ndarray, r: np.ndarray, s: np.ndarray) -> bool:
    def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> float:
        return float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    return orient(p, q, r) * orient(p, q, s) < 0 and orient(r, s, p) * orient(r, s, q) < 0


coords = st.floats(-5.0, 5.0, allow_nan=False).map(lambda v: round(v, 3))
segments = st.lists(st.tuples(coords, coords, coords, coords), min_size=1, max_size=6)


@settings(max_examples=300, deadline=None)
@example([(1.004, 0.0, 0.0, 1.0)], [(-3.0, 0.0, 0.0, 1.0)])  # touching ends do not cross
@given(segments, segments)
def test_crossings_agree_with_the_orientation_test(
    a: list[tuple[float, ...]], b: list[tuple[float, ...]]
) -> None:
    aa, bb = np.array(a), np.array(b)
    rows, cols, u = segment_crossings(aa[:, :2], aa[:, 2:], bb[:, :2], bb[:, 2:])
    want = {
        (i, j)
        for i in range(len(aa))
        for j in range(len(bb))
        if _crosses(aa[i, :2], aa[i, 2:], bb[j, :2], bb[j, 2:])
    }
    assert set(zip(rows.tolist(), cols.tolist(), strict=True)) == want
    # the crossing lies on both segments
    p = bb[cols, :2] + u[:, None] * (bb[cols, 2:] - bb[cols, :2])
    da = aa[rows, 2:] - aa[rows, :2]
    off = (p[:, 0] - aa[rows, 0]) * da[:, 1] - (p[:, 1] - aa[rows, 1]) * da[:, 0]
    assert np.all((u >= -1e-9) & (u <= 1 + 1e-9))
    np.testing.assert_allclose(off / np.maximum(np.hypot(*da.T), 1e-12), 0.0, atol=1e-6)

"""Joining the pieces of one wall, and dropping surfaces the sound passed through."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from sonarproc.surfaces.echoes import occlusion
from sonarproc.surfaces.echoes.occlusion import contradicted, corner_extensions, segment_crossings
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.merge import merge_collinear
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample

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


def _line(a: tuple[float, float], b: tuple[float, float]) -> np.ndarray:
    return resample(np.array([a, b], dtype=float), CELL)


def test_walls_found_short_of_their_corner_are_completed_to_it() -> None:
    owner, start, end = corner_extensions(
        [_line((0.7, 0.0), (4.5, 0.0)), _line((0.0, 5.3), (0.0, 0.7))]
    )
    assert owner.tolist() == [0, 1]
    np.testing.assert_allclose(start, [[0.7, 0.0], [0.0, 0.7]], atol=1e-12)
    np.testing.assert_allclose(end, [[0.0, 0.0], [0.0, 0.0]], atol=1e-12)


@pytest.mark.parametrize(
    ("second", "why"),
    [
        (((5.5, 0.0), (9.0, 0.0)), "the wall beyond a doorway: collinear, no corner"),
        (((-4.0, 0.8), (-0.5, 0.1)), "meeting at 11 degrees: less than a corner"),
        (((-1.5, 5.3), (-1.5, 0.5)), "a corner 1.5 m beyond the first wall's start"),
        (((0.0, 6.5), (0.0, 5.0)), "a corner 5 m beyond the second one's end"),
        (((0.0, 1.5), (0.0, 0.7)), "a second surface shorter than a metre"),
    ],
)
def test_no_completion_without_a_near_corner(second: tuple, why: str) -> None:
    owner, _, _ = corner_extensions([_line((0.0, 0.0), (4.5, 0.0)), _line(*second)])
    assert owner.size == 0, why


def test_a_wall_ending_on_another_is_completed_alone() -> None:
    # a T: the stem stops 0.4 m short of the wall it meets; the wall goes on both sides
    owner, start, end = corner_extensions(
        [_line((-3.0, 0.0), (3.0, 0.0)), _line((0.0, 3.0), (0.0, 0.4))]
    )
    assert owner.tolist() == [1]
    np.testing.assert_allclose(start, [[0.0, 0.4]], atol=1e-12)
    np.testing.assert_allclose(end, [[0.0, 0.0]], atol=1e-12)


def test_a_phantom_seen_past_the_ends_of_two_walls_into_their_corner_goes(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # walls y = 0 and x = 0 found from 0.7 m on; a phantom just behind the corner whose
    # eight paths pass between the walls' ends
    bottom, left = _line((0.7, 0.0), (4.5, 0.0)), _line((0.0, 5.3), (0.0, 0.7))
    phantom = _line((0.3, -0.4), (0.1, -0.1))
    xb = np.linspace(1.0, 4.0, 30)
    yl = np.linspace(1.0, 5.0, 30)
    sensors = [np.c_[xb, 1.5 + 0 * xb], np.c_[1.5 + 0 * yl, yl],
               np.c_[np.linspace(1.2, 2.0, 8), np.linspace(1.5, 2.5, 8)]]  # fmt: skip
    points = [np.c_[xb, 0 * xb], np.c_[0 * yl, yl],
              np.c_[np.linspace(0.3, 0.1, 8), np.linspace(-0.4, -0.1, 8)]]  # fmt: skip
    assert contradicted([bottom, left, phantom], sensors, points, cell=CELL) == [2]
    # without the completion the paths pass between the walls and the phantom stays
    none = (np.zeros(0, np.intp), np.zeros((0, 2)), np.zeros((0, 2)))
    monkeypatch.setattr(occlusion, "corner_extensions", lambda polylines, straight=None: none)
    assert contradicted([bottom, left, phantom], sensors, points, cell=CELL) == []


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


def test_a_plane_through_a_corners_echoes_does_not_drop_the_corners_wall() -> None:
    # room corner (8, 6): east wall x = 8 heard head on by 12 readings and found 0.4 m
    # short of the corner, the north wall found only far from it; a plane fitted through
    # the corner's retro-echoes from one northbound pass stands tilted behind the east
    # wall and has more echoes (15); their ranges are the distance to one point on the
    # east wall's line, so their paths crossing it are that corner's echoes
    east = _line((8.0, 2.0), (8.0, 5.6))
    north = _line((2.0, 6.0), (4.0, 6.0))
    tilted = _line((8.45, 5.89), (7.76, 6.06))
    ye = np.linspace(2.3, 5.3, 12)
    east_s = np.c_[np.full_like(ye, 6.5), ye]
    xn = np.linspace(2.3, 7.3, 20)
    north_s = np.c_[xn, np.full_like(xn, 4.5)]
    north_s[:, 0] = np.linspace(2.1, 3.9, 20)
    yp = np.linspace(1.5, 3.0, 15)
    tilt_s = np.c_[np.full_like(yp, 7.4), yp]
    tilt_r = np.hypot(*(np.array([8.0, 6.0]) - tilt_s).T)
    polys = [east, north, tilted]
    sensors = [east_s, north_s, tilt_s]
    ranges = [np.full(12, 1.5), np.full(20, 1.5), tilt_r]
    points = occlusion.path_ends(polys, [False] * 3, sensors, ranges)
    assert np.all(points[2][:, 0] > 8.0)  # the tilted plane's echo points are behind x = 8
    assert contradicted(polys, sensors, points, cell=CELL) == []
    # one range from the whole pass is no point's on the wall's line: through the wall
    points = occlusion.path_ends(polys, [False] * 3, sensors, [*ranges[:2], np.full(15, 4.0)])
    assert contradicted(polys, sensors, points, cell=CELL) == [0]

"""The echo screen: straight pieces no reading echoes from go before the echo rounds."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces.echoes import dirbins
from sonarproc.surfaces.echoes.refine import refine_fits
from sonarproc.surfaces.echoes.screen import echo_counts, screen_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.feet import feet_on_segments
from sonarproc.surfaces.planar.polylines import resample

CELL = 0.01
BEAM = math.radians(12.5)


def _brute_counts(polys: list[np.ndarray], g: EchoGeometry, tol: float) -> np.ndarray:
    """Every (polyline, reading) pair through the test of ``echo_points``."""
    surf = np.repeat(np.arange(len(polys)), g.size)
    read = np.tile(np.arange(g.size), len(polys))
    d, foot, _, inside = feet_on_segments(g.xy[read], polys, surf)
    v = foot - g.xy[read]
    off = np.abs((np.arctan2(v[:, 1], v[:, 0]) - g.heading[read] + math.pi) % (2 * math.pi)
                 - math.pi)  # fmt: skip
    ok = inside & (off <= g.half_beam[read]) & (np.abs(d - g.range_m[read]) <= tol)
    return np.bincount(surf[ok], minlength=len(polys))


def _scene(seed: int, walls: int, readings: int) -> tuple[list[np.ndarray], EchoGeometry]:
    """Random walls in a 10 m square and readings, half of them aimed at a wall's foot."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.0, 10.0, (walls, 2))
    ang = rng.uniform(0.0, 2 * math.pi, walls)
    b = a + rng.uniform(0.2, 4.0, walls)[:, None] * np.c_[np.cos(ang), np.sin(ang)]
    polys = [resample(np.stack((p, q)), CELL) for p, q in zip(a, b, strict=True)]
    xy = rng.uniform(0.0, 10.0, (readings, 2))
    heading = rng.uniform(-math.pi, math.pi, readings)
    rng_m = rng.uniform(0.2, 8.0, readings)
    aimed = rng.random(readings) < 0.5
    k = rng.integers(0, walls, readings)
    # aimed readings: a sensor on a wall's normal through a point of it, looking about at it
    t = rng.uniform(0.0, 1.0, readings)
    on = a[k] + t[:, None] * (b[k] - a[k])
    side = np.where(rng.random(readings) < 0.5, 1.0, -1.0)
    n = np.c_[-np.sin(ang[k]), np.cos(ang[k])] * side[:, None]
    dist = rng.uniform(0.3, 6.0, readings)
    xy[aimed] = (on + n * dist[:, None])[aimed]
    heading[aimed] = (np.arctan2(-n[:, 1], -n[:, 0]) + rng.uniform(-0.3, 0.3, readings))[aimed]
    rng_m[aimed] = (dist + rng.uniform(-0.1, 0.1, readings))[aimed]
    return polys, EchoGeometry(xy, heading, np.full(readings, BEAM), rng_m)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 30), st.sampled_from([0.03, 0.08]))
def test_echo_counts_are_those_of_every_pair_tested(seed: int, walls: int, tol: float) -> None:
    polys, g = _scene(seed, walls, 400)
    np.testing.assert_array_equal(echo_counts(polys, g, tol=tol), _brute_counts(polys, g, tol))


def test_echo_counts_of_readings_facing_a_wall_and_beside_it() -> None:
    wall = resample(np.array([[-1.0, 2.0], [1.0, 2.0]]), CELL)
    xs = np.array([-0.5, 0.0, 0.5, 1.5, 0.0, 0.0])
    # the fourth is beyond the wall's end, the fifth 20 cm long, the sixth looks sideways
    heading = np.array([0.5 * math.pi] * 5 + [0.0])
    rng_m = np.array([2.0, 2.02, 1.98, 2.0, 2.2, 2.0])
    g = EchoGeometry(np.c_[xs, 0 * xs], heading, np.full(6, BEAM), rng_m)
    assert echo_counts([wall], g, tol=0.05).tolist() == [3]
    assert echo_counts([wall], g, tol=0.25).tolist() == [4]
    assert echo_counts([], g, tol=0.05).tolist() == []


def _cells(x0: float, x1: float, y: float) -> SurfaceCells:
    u = np.arange(0.0, x1 - x0, CELL)
    return SurfaceCells(x0 + u, np.full_like(u, y), u, np.ones_like(u), False)


def _fits(pieces: list[SurfaceCells]) -> list[SurfaceFit]:
    out = [fit_surface(p, cell=CELL) for p in pieces]
    assert all(isinstance(f, SurfaceFit) for f in out)
    return out  # type: ignore[return-value]


def _facing(xs: np.ndarray, wall_y: float) -> EchoGeometry:
    """Sensors on y = 0 looking up at a wall along y = wall_y."""
    n = xs.size
    return EchoGeometry(np.c_[xs, np.zeros(n)], np.full(n, 0.5 * math.pi), np.full(n, BEAM),
                        np.full(n, wall_y))  # fmt: skip


def test_a_chance_piece_goes_and_a_wall_and_a_curve_stay() -> None:
    wall = _cells(0.0, 2.0, 2.0)
    chance = _cells(3.0, 3.5, 1.0)  # no sensor faces it
    phi = np.linspace(0.2, 2.9, 200)
    pillar = SurfaceCells(6 + 0.3 * np.cos(phi), 1 + 0.3 * np.sin(phi), 0.3 * (phi - 0.2),
                          np.ones_like(phi), False)  # fmt: skip
    fits = _fits([wall, chance, pillar])
    assert [f.model for f in fits] == ["line", "line", "arc"]
    kept, cells = screen_fits(fits, [wall, chance, pillar], _facing(np.linspace(0.2, 1.8, 9), 2.0),
                              tol=0.08)  # fmt: skip
    assert [f.model for f in kept] == ["line", "arc"]
    assert cells[0] is wall and cells[1] is pillar


def test_a_wall_with_a_gap_is_kept_whole() -> None:
    # one wall cut in two by a 20 cm gap: with readings facing its left half only, the
    # right piece (nothing echoes from it) goes; with readings facing both, both stay
    # and the refit joins them into one wall across the gap
    left, right = _cells(0.0, 1.0, 2.0), _cells(1.2, 2.0, 2.0)
    g = _facing(np.linspace(0.1, 0.9, 30), 2.0)
    kept, _ = screen_fits(_fits([left, right]), [left, right], g, tol=0.08)
    assert len(kept) == 1
    g = _facing(np.r_[np.linspace(0.1, 0.9, 30), np.linspace(1.3, 1.9, 20)], 2.0)
    kept, _ = screen_fits(_fits([left, right]), [left, right], g, tol=0.08)
    assert len(kept) == 2
    fits, pts = refine_fits(_fits([left, right]), [left, right], g, cell=CELL)
    assert len(fits) == 1 and fits[0].model == "line"
    ends = fits[0].polyline[[0, -1]]
    np.testing.assert_allclose(np.sort(ends[:, 0]), [0.0, 1.99], atol=0.12)
    np.testing.assert_allclose(ends[:, 1], 2.0, atol=0.005)
    assert pts[0].size == 50


def _brute_normal_pairs(
    ends: np.ndarray, reach: np.ndarray, g: EchoGeometry
) -> set[tuple[int, int]]:
    """The pairs normal_bin_pairs promises: a normal in the beam, its point near the segment."""
    out = set()
    for i, (a, b) in enumerate(ends):
        t = (b - a) / np.hypot(*(b - a))
        for u in (np.array([-t[1], t[0]]), np.array([t[1], -t[0]])):
            off = np.abs((math.atan2(u[1], u[0]) - g.heading + math.pi) % (2 * math.pi) - math.pi)
            p = g.xy + g.range_m[:, None] * u
            s = np.clip((p - a) @ (b - a) / ((b - a) @ (b - a)), 0.0, 1.0)
            gap = np.hypot(*(a + s[:, None] * (b - a) - p).T)
            out |= {(i, int(j)) for j in np.flatnonzero((off <= g.half_beam) & (gap <= reach[i]))}
    return out


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 12), st.booleans())
def test_normal_bin_pairs_hold_every_promised_pair(seed: int, walls: int, table: bool) -> None:
    polys, g = _scene(seed, walls, 300)
    ends = np.stack([p[[0, -1]] for p in polys])
    reach = np.random.default_rng(seed).uniform(0.0, 1.0, walls)
    old = dirbins.DENSE_KEYS
    dirbins.DENSE_KEYS = old if table else 0  # the sorted search instead of the table
    try:
        seg, read = dirbins.normal_bin_pairs(ends, reach, g.xy, g.heading, g.half_beam, g.range_m)
    finally:
        dirbins.DENSE_KEYS = old
    got = set(zip(seg.tolist(), read.tolist(), strict=True))
    assert len(got) == seg.size  # distinct
    assert _brute_normal_pairs(ends, reach, g) <= got

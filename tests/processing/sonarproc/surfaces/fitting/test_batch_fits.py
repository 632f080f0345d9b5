"""Fits of many groups at once and echo tests of many surfaces at once equal the one-by-one ones."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces.echoes import specular
from sonarproc.surfaces.echoes.specular import EchoGeometry, count_seen_through, echo_points
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.arcs import fit_arc, fit_circles
from sonarproc.surfaces.fitting.batch import fit_surface, fit_surfaces
from sonarproc.surfaces.fitting.grouped import floor_rms
from sonarproc.surfaces.fitting.lines import fit_line, fit_lines
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit
from sonarproc.surfaces.planar.polylines import resample, resample_segments

CELL = 0.01


def _group(rng: np.random.Generator, kind: str) -> SurfaceCells:
    """Noisy cells of a random line, arc, wiggle or degenerate group, in order."""
    n = int(rng.integers(2, 160))
    u = np.sort(rng.uniform(0.0, rng.uniform(0.05, 3.0), n))
    a = rng.uniform(-math.pi, math.pi)
    x0, y0 = rng.uniform(-5, 5, 2)
    if kind == "line":
        x, y = x0 + u * math.cos(a), y0 + u * math.sin(a)
    elif kind == "arc":
        r = rng.uniform(0.2, 2.0)
        phi = a + u / r
        x, y = x0 + r * np.cos(phi), y0 + r * np.sin(phi)
    elif kind == "wiggle":
        x = x0 + u
        y = y0 + 0.2 * np.sin(u * rng.uniform(3, 12))
    else:  # all at one point
        x, y = np.full(n, x0), np.full(n, y0)
    x = np.round((x + rng.normal(0, 0.004, n)) / CELL) * CELL
    y = np.round((y + rng.normal(0, 0.004, n)) / CELL) * CELL
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    return SurfaceCells(x, y, s, rng.uniform(1, 9, n).round(), False)


def _same(a: SurfaceFit | SurfaceFailure, b: SurfaceFit | SurfaceFailure) -> None:
    assert type(a) is type(b)
    if isinstance(a, SurfaceFailure):
        assert isinstance(b, SurfaceFailure)
        assert (a.reason, a.support) == (b.reason, b.support)
        return
    assert isinstance(b, SurfaceFit)
    assert (a.model, a.support, a.arcs, a.closed) == (b.model, b.support, b.arcs, b.closed)
    assert math.isclose(a.rms_m, b.rms_m, rel_tol=1e-7, abs_tol=1e-10)
    assert a.polyline.shape == b.polyline.shape
    np.testing.assert_allclose(a.polyline, b.polyline, atol=1e-7)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.lists(st.sampled_from(["line", "arc", "wiggle", "point"]),
                                            min_size=1, max_size=12))  # fmt: skip
def test_fit_surfaces_equals_fit_surface_one_by_one(seed: int, kinds: list[str]) -> None:
    rng = np.random.default_rng(seed)
    groups = [_group(rng, k) for k in kinds]
    want = [fit_surface(g, cell=CELL) for g in groups]
    for got, one in zip(fit_surfaces(groups, cell=CELL), want, strict=True):
        _same(got, one)


ends = st.floats(-20.0, 20.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.tuples(ends, ends, ends, ends), min_size=0, max_size=8),
    st.sampled_from([0.01, 0.02, 0.05, 0.3]),
)
def test_resample_segments_is_resample_of_each(segs: list[tuple[float, ...]], step: float) -> None:
    # every segment at once, as the fits of a thousand straight groups need it
    a = np.array([s[:2] for s in segs]).reshape(-1, 2)
    b = np.array([s[2:] for s in segs]).reshape(-1, 2)
    b[::3] = a[::3]  # a point among them
    got = resample_segments(a, b, step)
    assert len(got) == len(segs)
    for p, q, g in zip(a, b, got, strict=True):
        want = resample(np.stack((p, q)), step)
        assert g.shape == want.shape
        np.testing.assert_allclose(g, want, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(g[0], want[0])


def test_fit_lines_of_two_walls() -> None:
    x = np.r_[np.arange(0.0, 2.0, CELL), np.full(100, 3.0)]
    y = np.r_[np.full(200, 1.0), np.arange(1.0, 0.0, -CELL)]
    s = np.r_[np.arange(200) * CELL, np.arange(100) * CELL]
    sizes = np.array([200, 100])
    lines = fit_lines(x, y, sizes, cell=CELL)
    np.testing.assert_allclose(lines.direction, [[1.0, 0.0], [0.0, -1.0]], atol=1e-12)
    np.testing.assert_allclose(lines.point, [[0.995, 1.0], [3.0, 0.505]], atol=1e-9)
    np.testing.assert_allclose(lines.hi - lines.lo, [1.99, 0.99], atol=1e-9)
    np.testing.assert_allclose(lines.rms, 0.0, atol=1e-12)
    # five cells a bin, spread along the wall: sqrt(mean(0, 1, 4, 1, 4 cells^2)) = sqrt(2) cells
    np.testing.assert_allclose(floor_rms(x, y, s, sizes, cell=CELL), np.sqrt(2) * CELL, atol=5e-4)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_grouped_lines_and_circles_match_direct_fits(seed: int) -> None:
    """Against independent fits: the SVD's principal axis, and a circle through 3 points."""
    rng = np.random.default_rng(seed)
    g = int(rng.integers(1, 8))
    sizes = rng.integers(3, 60, g)
    xs, ys, centres, radii = [], [], [], []
    for n in sizes:
        c, r = rng.uniform(-5, 5, 2), rng.uniform(0.3, 3.0)
        phi = np.sort(rng.uniform(0.0, rng.uniform(0.5, 5.0), n))
        xs.append(c[0] + r * np.cos(phi))
        ys.append(c[1] + r * np.sin(phi))
        centres.append(c)
        radii.append(r)
    x, y = np.concatenate(xs), np.concatenate(ys)
    circles = fit_circles(x, y, sizes, cell=CELL)
    assert circles.ok.all()
    np.testing.assert_allclose(circles.centre, centres, atol=1e-6)
    np.testing.assert_allclose(circles.radius, radii, atol=1e-6)
    lines = fit_lines(x, y, sizes, cell=1.0)  # a trim floor of 1 m keeps every point
    for k, (gx, gy) in enumerate(zip(xs, ys, strict=True)):
        d = np.c_[gx - gx.mean(), gy - gy.mean()]
        axis = np.linalg.svd(d, full_matrices=False)[2][0]
        assert abs(abs(float(axis @ lines.direction[k])) - 1.0) < 1e-9
        resid = d @ np.array([-axis[1], axis[0]])
        assert lines.rms[k] == pytest.approx(np.sqrt(np.mean(resid**2)), abs=1e-9)


def test_fit_surface_is_fit_surfaces_of_one() -> None:
    phi = np.linspace(0.0, 2.0, 80)
    arc = SurfaceCells(np.cos(phi), np.sin(phi), phi, np.ones_like(phi), False)
    _same(fit_surface(arc, cell=CELL), fit_surfaces([arc], cell=CELL)[0])
    got = fit_surface(arc, cell=CELL)
    assert isinstance(got, SurfaceFit) and got.model == "arc"
    assert got.params["radius"] == pytest.approx(1.0, abs=1e-9)


def _echo_points_one_by_one(
    polylines: list[np.ndarray], closed: list[bool], g: EchoGeometry, tol: float
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The reference: every reading tested against every surface (no pruning)."""
    best: dict[int, tuple[float, int, np.ndarray, float]] = {}
    for i, (p, cl) in enumerate(zip(polylines, closed, strict=True)):
        for j in range(g.size):
            q = g.xy[j]
            d, v, s, facing = _foot_one_by_one(p, cl, q, g.heading[j], g.half_beam[j])
            r = abs(d - g.range_m[j])
            if facing and r <= tol and (j not in best or r < best[j][0]):
                best[j] = (r, i, q + v / np.hypot(*v) * g.range_m[j], s)
    out = []
    for i in range(len(polylines)):
        rows = sorted((s, j, pt) for j, (_, k, pt, s) in best.items() if k == i)
        out.append((np.array([j for _, j, _ in rows], dtype=np.intp),
                    np.array([pt for _, _, pt in rows]).reshape(-1, 2),
                    np.array([s for s, _, _ in rows])))  # fmt: skip
    return out


@pytest.mark.slow
@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_echo_points_equal_the_exhaustive_test(seed: int) -> None:
    rng = np.random.default_rng(seed)
    polylines: list[np.ndarray] = []
    closed: list[bool] = []
    for _ in range(int(rng.integers(1, 6))):
        a, (x0, y0), length = (
            rng.uniform(-math.pi, math.pi),
            rng.uniform(-3, 3, 2),
            rng.uniform(0.2, 4),
        )
        if rng.random() < 0.6:
            ends = np.array([[x0, y0], [x0 + length * math.cos(a), y0 + length * math.sin(a)]])
            polylines.append(resample(ends, CELL))
            closed.append(False)
        else:
            r = rng.uniform(0.2, 1.5)
            phi = np.linspace(a, a + length / r, max(3, int(length / CELL)))
            polylines.append(np.c_[x0 + r * np.cos(phi), y0 + r * np.sin(phi)])
            closed.append(False)
    n = 300
    xy = rng.uniform(-5, 5, (n, 2))
    heading = rng.uniform(-math.pi, math.pi, n)
    g = EchoGeometry(xy, heading, np.full(n, 0.22), rng.uniform(0.1, 6.0, n))
    got = echo_points(polylines, closed, g, tol=0.5)
    want = _echo_points_one_by_one(polylines, closed, g, tol=0.5)
    through = count_seen_through(polylines, closed, g, tol=0.5)
    assert through.tolist() == _seen_through_one_by_one(polylines, closed, g, tol=0.5)
    for (gi, gp, gs, near), (wi, wp, ws), every in zip(got, want, through, strict=True):
        assert gi.tolist() == wi.tolist()
        np.testing.assert_allclose(gp, wp, atol=1e-9)
        np.testing.assert_allclose(gs, ws, atol=1e-9)
        assert 0 <= near <= every  # the search's count is a lower bound


def _seen_through_one_by_one(
    polylines: list[np.ndarray], closed: list[bool], g: EchoGeometry, tol: float
) -> list[int]:
    """The reference: every reading's foot on every surface, seen through or not."""
    out = []
    for p, cl in zip(polylines, closed, strict=True):
        count = 0
        for j in range(g.size):
            d, _, _, facing = _foot_one_by_one(p, cl, g.xy[j], g.heading[j], g.half_beam[j])
            count += bool(facing and g.range_m[j] > d / math.cos(g.half_beam[j]) + tol)
        out.append(count)
    return out


def _foot_one_by_one(
    p: np.ndarray, closed: bool, q: np.ndarray, heading: float, half_beam: float
) -> tuple[float, np.ndarray, float, bool]:
    """Distance to the foot of ``q`` on ``p``, the vector to it, its arc length, and
    whether it is inside the polyline and inside the beam (every segment tested)."""
    seg = np.hypot(*np.diff(p, axis=0).T)
    sv = np.concatenate(([0.0], np.cumsum(seg)))
    ab = np.diff(p, axis=0)
    t = np.clip(np.einsum("ij,ij->i", q - p[:-1], ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
    feet = p[:-1] + ab * t[:, None]
    d = np.hypot(*(q - feet).T)
    k = int(np.argmin(d))
    s = sv[k] + t[k] * seg[k]
    inside = closed or (0.5 * np.median(seg) < s < sv[-1] - 0.5 * np.median(seg))
    v = feet[k] - q
    off = abs((math.atan2(v[1], v[0]) - heading + math.pi) % (2 * math.pi) - math.pi)
    return float(d[k]), v, float(s), bool(inside and off <= half_beam)


@pytest.mark.parametrize("n", [0, 1, 2, 3, 4])
def test_degenerate_groups_fail_with_a_reason(n: int) -> None:
    same = np.full(n, 1.5)
    cells = SurfaceCells(same, same, np.arange(n) * CELL, np.ones(n), False)
    fits = (fit_line(cells, cell=CELL), fit_arc(cells, cell=CELL), fit_surface(cells, cell=CELL))
    for got in fits:
        assert isinstance(got, SurfaceFailure) and got.reason and got.support == n


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_echo_points_straight_pairs_equal_the_radius_search(seed: int) -> None:
    """Few straight surfaces are tested pair by pair; many go through the radius search.

    Both must give the same echoes and the same seen-through counts (the search's count is
    a lower bound, and the pair test applies the search's ball and bearing tests too).
    """
    rng = np.random.default_rng(seed)
    polylines: list[np.ndarray] = []
    for _ in range(int(rng.integers(1, 7))):
        a, (x0, y0), length = (
            rng.uniform(-math.pi, math.pi),
            rng.uniform(-3, 3, 2),
            rng.uniform(0.2, 5),
        )
        ends = np.array([[x0, y0], [x0 + length * math.cos(a), y0 + length * math.sin(a)]])
        polylines.append(resample(ends, CELL))
    r = rng.uniform(0.2, 1.5)
    phi = np.linspace(0.0, rng.uniform(1.0, 6.0), 200)
    polylines.append(np.c_[r * np.cos(phi), r * np.sin(phi)])  # one curved surface too
    closed = [False] * len(polylines)
    n = 400
    xy = rng.uniform(-5, 5, (n, 2))
    g = EchoGeometry(xy, rng.uniform(-math.pi, math.pi, n), np.full(n, 0.22),
                     rng.uniform(0.1, 6.0, n))  # fmt: skip
    # half the readings at the range of a wall, within a few centimetres
    p = polylines[0]
    u = (p[-1] - p[0]) / np.hypot(*(p[-1] - p[0]))
    d = np.abs((xy - p[0]) @ np.array([-u[1], u[0]]))
    near = rng.random(n) < 0.5
    g.range_m[near] = d[near] + rng.normal(0.0, 0.02, int(near.sum()))
    dense = echo_points(polylines, closed, g, tol=0.05)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(specular, "DENSE_PAIRS", 0)
        searched = echo_points(polylines, closed, g, tol=0.05)
    for a, b in zip(dense, searched, strict=True):
        assert a.readings.tolist() == b.readings.tolist()
        np.testing.assert_array_equal(a.points, b.points)
        np.testing.assert_array_equal(a.along, b.along)
        assert a.seen_through == b.seen_through

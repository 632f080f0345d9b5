"""Arc rasterisation: geometry, connectivity, no repeats, joint region, count-map semantics."""

from __future__ import annotations

import numpy as np
import pytest
from arcs_api import arc_bounds, arc_cells, rasterize_arcs
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray
from scipy import ndimage

from sonarproc.arcs import _fill as arcs_fill
from sonarproc.arcs import _plan as arcs_plan
from sonarproc.arcs import _raster as arcs_raster
from sonarproc.arcs import arc_geometry
from sonarproc.grid import Grid

Reading = dict[str, NDArray[np.float64]]


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return (a + np.pi) % (2 * np.pi) - np.pi


def reading(
    tx: tuple[float, float],
    th: float,
    rx: tuple[float, float],
    rh: float,
    path: float,
    tw: float,
    rw: float,
) -> Reading:
    return {
        "tx_xy": np.array([tx], dtype=float),
        "tx_heading": np.array([th]),
        "rx_xy": np.array([rx], dtype=float),
        "rx_heading": np.array([rh]),
        "path": np.array([path]),
        "tx_half_beamwidth": np.array([tw]),
        "rx_half_beamwidth": np.array([rw]),
    }


def stack(rs: list[Reading]) -> Reading:
    return {k: np.concatenate([r[k] for r in rs]) for k in rs[0]}


def kwargs(r: Reading) -> dict[str, NDArray[np.float64]]:
    return {
        k: v
        for k, v in r.items()
        if k not in ("tx_xy", "tx_heading", "rx_xy", "rx_heading", "path")
    }


def cells(r: Reading, grid: Grid) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    return arc_cells(
        r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"], grid=grid, **kwargs(r)
    )


def counts(r: Reading, grid: Grid) -> NDArray[np.uint32]:
    return rasterize_arcs(
        r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"], grid=grid, **kwargs(r)
    )


def bounds(r: Reading) -> tuple[float, float, float, float]:
    return arc_bounds(
        r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"], **kwargs(r)
    )


def true_arc(
    r: Reading, i: int = 0, n: int = 200_000
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Dense points of the true arc, by brute force in polar form about the transmitter."""
    t = r["tx_xy"][i]
    q = r["rx_xy"][i]
    a = r["path"][i] / 2
    c = np.hypot(*(q - t)) / 2
    alpha = np.arctan2(q[1] - t[1], q[0] - t[0]) if c > 0 else 0.0
    tw = r["tx_half_beamwidth"][i]
    theta = r["tx_heading"][i] + np.linspace(-min(tw, np.pi), min(tw, np.pi), n)
    rho = (a * a - c * c) / (a - c * np.cos(theta - alpha))
    x = t[0] + rho * np.cos(theta)
    y = t[1] + rho * np.sin(theta)
    ang_r = np.arctan2(y - q[1], x - q[0])
    inside = np.abs(_wrap(ang_r - r["rx_heading"][i])) <= r["rx_half_beamwidth"][i]
    return x[inside], y[inside]


# --- strategies -------------------------------------------------------------------------

coords = st.floats(-0.5, 0.5)
angles = st.floats(-np.pi, np.pi)


@st.composite
def monostatic(draw: st.DrawFn) -> Reading:
    p = (draw(coords), draw(coords))
    h = draw(angles)
    w = draw(st.floats(0.02, 1.6))
    return reading(p, h, p, h, draw(st.floats(0.05, 1.6)), w, w)


@st.composite
def bistatic(draw: st.DrawFn) -> Reading:
    t = (draw(coords), draw(coords))
    d = draw(st.floats(0.01, 0.4))
    phi = draw(angles)
    rx = (t[0] + d * np.cos(phi), t[1] + d * np.sin(phi))
    path = d * draw(st.floats(1.02, 6.0))
    # Aim both beams roughly at a common point so that most arcs exist.
    aim = draw(angles)
    return reading(
        t,
        aim + draw(st.floats(-0.3, 0.3)),
        rx,
        aim + draw(st.floats(-0.3, 0.3)),
        path,
        draw(st.floats(0.05, 1.6)),
        draw(st.floats(0.05, 1.6)),
    )


any_reading = st.one_of(monostatic(), bistatic())


def grid_for(r: Reading, cell: float) -> Grid:
    x0, x1, y0, y1 = bounds(r)
    return Grid.covering(x0 - 3 * cell, x1 + 3 * cell, y0 - 3 * cell, y1 + 3 * cell, cell=cell)


def check_arc(r: Reading, cell: float) -> None:
    """All single-arc properties against the brute-force arc."""
    xt, yt = true_arc(r)
    if xt.size == 0:
        grid = Grid.covering(-3, 3, -3, 3, cell=0.05)
        assert cells(r, grid)[0].size == 0
        return
    grid = grid_for(r, cell)
    arc, iy, ix = cells(r, grid)
    assert arc.size > 0
    assert (arc == 0).all()
    # No cell twice.
    key = iy * grid.nx + ix
    assert np.unique(key).size == key.size
    # Each cell lies within a half cell diagonal of the true ellipse (|PT| + |PR| = path).
    px = grid.x0 + ix * cell
    py = grid.y0 + iy * cell
    t = r["tx_xy"][0]
    q = r["rx_xy"][0]
    s = np.hypot(px - t[0], py - t[1]) + np.hypot(px - q[0], py - q[1])
    assert np.abs(s - r["path"][0]).max() <= np.sqrt(2) * cell * (1 + 1e-6)
    # The chain covers the true arc and strays from it by at most one cell.
    tiy, tix = grid.to_index(xt, yt)
    true_map = np.zeros(grid.shape, dtype=bool)
    true_map[tiy, tix] = True
    got = np.zeros(grid.shape, dtype=bool)
    got[iy, ix] = True
    near_true = ndimage.binary_dilation(true_map, structure=np.ones((3, 3)))
    near_got = ndimage.binary_dilation(got, structure=np.ones((3, 3)))
    assert near_true[got].all()
    assert near_got[true_map].all()
    # 8-connected: one component per connected piece of the joint region.
    ang_t = np.arctan2(yt - t[1], xt - t[0])
    gaps = np.count_nonzero(np.abs(np.diff(_wrap(ang_t))) > 1e-3) + 1
    _, ncomp = ndimage.label(got, structure=np.ones((3, 3)))
    assert ncomp <= gaps
    # Joint region: every cell centre within a cell's angular size of both beams.
    for centre, head, half in (
        (t, r["tx_heading"][0], r["tx_half_beamwidth"][0]),
        (q, r["rx_heading"][0], r["rx_half_beamwidth"][0]),
    ):
        dist = np.hypot(px - centre[0], py - centre[1])
        far = dist > 2 * cell
        off = np.abs(_wrap(np.arctan2(py - centre[1], px - centre[0]) - head))
        slack = np.arcsin(np.minimum(1.0, np.sqrt(2) * cell / np.maximum(dist, 1e-12)))
        assert (off[far] <= half + slack[far] + 1e-9).all()


@settings(max_examples=60, deadline=None)
@given(r=monostatic(), cell=st.sampled_from([0.004, 0.01, 0.03]))
def test_monostatic_arc_properties(r: Reading, cell: float) -> None:
    check_arc(r, cell)


@settings(max_examples=60, deadline=None)
@given(r=bistatic(), cell=st.sampled_from([0.004, 0.01, 0.03]))
def test_bistatic_arc_properties(r: Reading, cell: float) -> None:
    check_arc(r, cell)


@pytest.mark.parametrize(
    "r",
    [
        # Full circles: closed chains.
        reading((0, 0), 0.0, (0, 0), 0.0, 1.0, np.pi, np.pi),
        reading((0.013, -0.2), 1.0, (0.013, -0.2), 1.0, 0.3, 4.0, 4.0),
        # A thin ellipse seen whole, and seen around the far end of a focus.
        reading((0, 0), 0.0, (0.3, 0), 0.0, 0.31, np.pi, np.pi),
        reading((0, 0), np.pi, (0.3, 0), 0.0, 0.305, 0.3, np.pi),
        # Tiny circles a few cells across.
        reading((0, 0), 0.3, (0, 0), 0.3, 0.05, 1.5, 1.5),
        reading((0, 0), 0.3, (0, 0), 0.3, 0.011, 1.5, 1.5),
        # Beams that overlap in two separate pieces.
        reading((0, 0), 0.0, (0, 0), np.pi, 1.0, 2.5, 2.5),
        # Polaroid geometry, neighbouring transducers on a ring.
        reading((0.2, 0.0), 0.0, (0.185, 0.077), 0.39, 3.0, 0.218, 0.218),
    ],
)
def test_special_arcs(r: Reading) -> None:
    check_arc(r, 0.01)


def test_full_circle_cell_count_matches_arc_length() -> None:
    # A minimal 8-connected circle has 4 * sqrt(2) * r / cell cells (length * 2 sqrt 2 / pi).
    for radius in (0.1, 0.5, 2.0):
        r = reading((0, 0), 0.0, (0, 0), 0.0, 2 * radius, np.pi, np.pi)
        grid = grid_for(r, 0.01)
        arc, _, _ = cells(r, grid)
        expected = 2 * np.pi * radius / 0.01 * 2 * np.sqrt(2) / np.pi
        assert abs(arc.size - expected) <= 0.01 * expected + 4


@settings(max_examples=40, deadline=None)
@given(r=monostatic())
def test_arc_cell_count_is_arc_length_over_cell(r: Reading) -> None:
    # One cell per column (or row): between length / (sqrt(2) cell) and length / cell,
    # give or take the end and joint cells (beam limits and 45-degree points).
    cell = 0.01
    xt, yt = true_arc(r)
    if xt.size < 2:
        return
    seg = np.hypot(np.diff(xt), np.diff(yt))
    length = seg[seg < 0.1].sum()
    arc, _, _ = cells(r, grid_for(r, cell))
    assert length / cell / np.sqrt(2) - 2 <= arc.size <= length / cell + 6


def test_counts_are_distinct_arcs_per_cell() -> None:
    # Two arcs crossing at (0.4, +-0.3): 2 exactly where both are.
    a = reading((0, 0), 0.0, (0, 0), 0.0, 1.0, 0.8, 0.8)
    b = reading((0.8, 0), np.pi, (0.8, 0), np.pi, 1.0, 0.8, 0.8)
    grid = Grid.covering(-1, 1, -1, 1, cell=0.01)
    ca = counts(a, grid)
    cb = counts(b, grid)
    both = counts(stack([a, b]), grid)
    assert both.dtype == np.uint32
    assert ca.max() == 1 and cb.max() == 1
    np.testing.assert_array_equal(both, ca.astype(int) + cb)
    iy, ix = np.nonzero(both == 2)
    assert iy.size >= 2
    xs = grid.x0 + ix * grid.cell
    ys = grid.y0 + iy * grid.cell
    assert np.all(np.abs(xs - 0.4) < 0.05) and np.all(np.abs(np.abs(ys) - 0.3) < 0.05)
    assert ((both == 2) == ((ca == 1) & (cb == 1))).all()
    # The same echo twice makes two arcs.
    twice = counts(stack([a, a]), grid)
    np.testing.assert_array_equal(twice, 2 * ca)


def test_count_map_equals_cells_scattered() -> None:
    rng = np.random.default_rng(3)
    n = 300
    t = rng.uniform(-0.3, 0.3, (n, 2))
    rx = t + rng.uniform(-0.05, 0.05, (n, 2)) * (rng.random((n, 1)) < 0.5)
    h = rng.uniform(-np.pi, np.pi, n)
    r = {
        "tx_xy": t,
        "tx_heading": h,
        "rx_xy": rx,
        "rx_heading": h + rng.uniform(-0.2, 0.2, n),
        "path": rng.uniform(0.0, 3.0, n),
        "tx_half_beamwidth": np.full(n, np.deg2rad(12.5)),
        "rx_half_beamwidth": np.full(n, np.deg2rad(12.5)),
    }
    grid = Grid.covering(-1, 1, -1.2, 1, cell=0.01)  # clips some arcs
    arc, iy, ix = cells(r, grid)
    expect = np.zeros(grid.shape, dtype=np.int64)
    np.add.at(expect, (iy, ix), 1)
    got = counts(r, grid)
    np.testing.assert_array_equal(got, expect)
    assert grid.contains_index(iy, ix).all()
    # Each arc's cells are distinct.
    key = arc * grid.nx * grid.ny + iy * grid.nx + ix
    assert np.unique(key).size == key.size


def test_chunking_and_exact_path_do_not_change_the_map(monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(5)
    n = 200
    t = rng.uniform(-0.5, 0.5, (n, 2))
    h = rng.uniform(-np.pi, np.pi, n)
    r = {
        "tx_xy": t,
        "tx_heading": h,
        "rx_xy": t + 0.05 * (rng.random((n, 1)) < 0.3),
        "rx_heading": h,
        "path": rng.uniform(0.2, 2.0, n),
        "tx_half_beamwidth": rng.uniform(0.1, 3.2, n),
        "rx_half_beamwidth": rng.uniform(0.1, 3.2, n),
    }
    grid = Grid.covering(-1.5, 1.5, -1.5, 1.5, cell=0.01)
    ref = counts(r, grid)
    ref_cells = cells(r, grid)
    monkeypatch.setattr(arcs_fill, "_CHUNK", 50)
    monkeypatch.setattr(arcs_raster, "_BATCH", 3000)
    monkeypatch.setattr(arcs_plan, "_PLAN_CHUNK", 37)
    np.testing.assert_array_equal(counts(r, grid), ref)
    monkeypatch.setattr(arcs_plan, "_SIMPLE_TURNING", -1.0)  # every arc takes the exact check
    np.testing.assert_array_equal(counts(r, grid), ref)
    for got, want in zip(cells(r, grid), ref_cells, strict=True):
        np.testing.assert_array_equal(got, want)


def test_clipping_matches_a_larger_grid() -> None:
    r = reading((0, 0), 0.3, (0, 0), 0.3, 1.6, 1.0, 1.0)
    big = Grid.covering(-1, 1, -1, 1, cell=0.01)
    small = Grid(x0=big.x0 + 50 * big.cell, y0=big.y0 + 120 * big.cell, cell=big.cell, nx=90, ny=70)
    full = counts(r, big)
    part = counts(r, small)
    np.testing.assert_array_equal(part, full[120 : 120 + 70, 50 : 50 + 90])


def test_readings_that_make_no_arc_are_skipped() -> None:
    good = reading((0, 0), 0.0, (0, 0), 0.0, 1.0, 0.2, 0.2)
    rs = [
        good,
        reading((0, 0), 0.0, (0.2, 0), 0.0, 0.1, 0.2, 0.2),  # path < |TR|
        reading((0, 0), 0.0, (0.2, 0), 0.0, 0.2, 0.2, 0.2),  # path == |TR|
        reading((0, 0), 0.0, (0, 0), 0.0, float("nan"), 0.2, 0.2),
        reading((0, 0), 0.0, (0, 0), 0.0, 0.0, 0.2, 0.2),
        reading((0, 0), 0.0, (0.1, 0), np.pi, 1.0, 0.2, 0.2),  # beams apart: no joint region
        reading((0, 0), 0.0, (0, 0), 1.0, 1.0, 0.2, 0.2),  # same spot, beams apart
    ]
    grid = Grid.covering(-1, 1, -1, 1, cell=0.01)
    arc, _, _ = cells(stack(rs), grid)
    assert set(arc.tolist()) == {0}
    np.testing.assert_array_equal(counts(stack(rs), grid), counts(good, grid))
    empty = stack(rs[1:])
    assert counts(empty, grid).sum() == 0
    with pytest.raises(ValueError, match="no reading makes an arc"):
        bounds(empty)


def test_scalar_beamwidths_and_shape_errors() -> None:
    r = reading((0, 0), 0.0, (0, 0), 0.0, 1.0, 0.2, 0.2)
    grid = Grid.covering(-1, 1, -1, 1, cell=0.01)
    m = rasterize_arcs(
        r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"],
        tx_half_beamwidth=0.2, rx_half_beamwidth=0.2, grid=grid,
    )  # fmt: skip
    np.testing.assert_array_equal(m, counts(r, grid))
    with pytest.raises(ValueError, match="tx_xy"):
        rasterize_arcs(
            np.zeros((2, 3)), [0, 0], np.zeros((2, 2)), [0, 0], [1, 1],
            tx_half_beamwidth=0.2, rx_half_beamwidth=0.2, grid=grid,
        )  # fmt: skip
    with pytest.raises(ValueError, match="expected 3 rows"):
        rasterize_arcs(
            np.zeros((2, 2)), [0, 0], np.zeros((2, 2)), [0, 0], [1, 1, 1],
            tx_half_beamwidth=0.2, rx_half_beamwidth=0.2, grid=grid,
        )  # fmt: skip


def test_empty_input_gives_empty_map() -> None:
    grid = Grid.covering(0, 1, 0, 1, cell=0.1)
    z = np.zeros((0, 2))
    m = rasterize_arcs(z, [], z, [], [], tx_half_beamwidth=0.2, rx_half_beamwidth=0.2, grid=grid)
    assert m.shape == grid.shape and m.sum() == 0
    arc, iy, ix = arc_cells(
        z, [], z, [], [], tx_half_beamwidth=0.2, rx_half_beamwidth=0.2, grid=grid
    )
    assert arc.size == iy.size == ix.size == 0


@settings(max_examples=40, deadline=None)
@given(r=any_reading)
def test_bounds_hold_the_arc(r: Reading) -> None:
    xt, yt = true_arc(r)
    if xt.size == 0:
        return
    x0, x1, y0, y1 = bounds(r)
    tol = 1e-6
    assert x0 - tol <= xt.min() and xt.max() <= x1 + tol
    assert y0 - tol <= yt.min() and yt.max() <= y1 + tol
    # And are tight (the dense reference gets within its sampling step).
    assert xt.min() - x0 < 1e-3 and x1 - xt.max() < 1e-3
    assert yt.min() - y0 < 1e-3 and y1 - yt.max() < 1e-3


def test_large_radius_polaroid_arcs() -> None:
    # 10 m circles at 1 cm: the count of a 25 degree arc is about its length per cell.
    r = reading((0, 0), 0.4, (0, 0), 0.4, 20.0, np.deg2rad(12.5), np.deg2rad(12.5))
    check_arc(r, 0.01)


def _mixed_readings(seed: int, n: int, *, spread: float, max_path: float) -> Reading:
    """Monostatic and bistatic readings of all sizes and beam widths (seeded)."""
    rng = np.random.default_rng(seed)
    t = rng.uniform(-spread, spread, (n, 2))
    h = rng.uniform(-np.pi, np.pi, n)
    bistatic = rng.random((n, 1)) < 0.4
    rx = t + bistatic * rng.uniform(-0.1, 0.1, (n, 2))
    return {
        "tx_xy": t,
        "tx_heading": h,
        "rx_xy": rx,
        "rx_heading": h + rng.uniform(-0.2, 0.2, n),
        "path": rng.uniform(0.05, max_path, n),
        "tx_half_beamwidth": rng.uniform(0.05, 1.7, n),
        "rx_half_beamwidth": rng.uniform(0.05, 1.7, n),
    }


@pytest.mark.parametrize(
    ("spread", "max_path", "cell", "clip"),
    [(0.5, 3.0, 0.01, False), (0.5, 3.0, 0.01, True), (5.0, 30.0, 0.01, True)],
)
def test_float32_path_matches_float64(
    monkeypatch: pytest.MonkeyPatch, spread: float, max_path: float, cell: float, clip: bool
) -> None:
    # The float32 arithmetic with its float64 repair gives exactly the float64 cells; so
    # does the int64 key path that grids of 2**24 cells or more take, and so do clipped
    # pieces without the rounds that skip samples outside the grid.
    r = _mixed_readings(11, 400, spread=spread, max_path=max_path)
    x0, x1, y0, y1 = bounds(r)
    if clip:  # cut the grid well inside the arcs, so that many pieces need clipping
        x0, x1, y0, y1 = 0.6 * x0, 0.7 * x1, 0.8 * y0, 0.5 * y1
    grid = Grid.covering(x0, x1, y0, y1, cell=cell)
    ref = counts(r, grid)
    ref_cells = cells(r, grid)
    assert ref.sum() > 0
    knobs = (
        (arcs_plan, "_F32_MAX_ERROR", -1.0),
        (arcs_fill, "_F32_KEY_LIMIT", 0),
        (arcs_plan, "_TRIM_ROUNDS", 0),
    )
    for module, name, value in knobs:
        with monkeypatch.context() as m:
            m.setattr(module, name, value)
            np.testing.assert_array_equal(counts(r, grid), ref)
            for got, want in zip(cells(r, grid), ref_cells, strict=True):
                np.testing.assert_array_equal(got, want)


def _f32_values(
    plan: arcs_plan.RasterPlan, i: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Piece i's computed coordinate plus its eps, as the float32 engine makes it and exact."""
    n = int(plan.n[i])
    kind = int(plan.kind[i])
    out = []
    eps = np.float32(plan.eps[i])
    for dt in (np.float32, np.float64):
        k = np.arange(n, dtype=dt)
        u = dt(plan.u0[i]) + k if kind & arcs_plan.UP else dt(plan.u0[i]) - k
        q = u * u
        if kind & arcs_plan.ELLIPSE:
            q = q * dt(plan.beta[i]) + dt(plan.gamma[i])
        else:
            q = dt(plan.gamma[i]) - q
        s = np.sqrt(q)
        if kind & arcs_plan.ELLIPSE:
            au = u * dt(plan.c_alpha[i])
            s = s + au if kind & arcs_plan.PLUS else s - au
        f = dt(plan.c_frac[i]) + dt(eps)
        out.append((f + s if kind & arcs_plan.PLUS else f - s).astype(np.float64))
    return out[0], out[1]


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    max_path=st.sampled_from([0.5, 3.0, 30.0]),
    cell=st.sampled_from([0.002, 0.01, 0.05]),
)
def test_float32_error_bound_holds(seed: int, max_path: float, cell: float) -> None:
    r = _mixed_readings(seed, 40, spread=1.0, max_path=max_path)
    try:
        grid = Grid.covering(*bounds(r), cell=cell)
    except ValueError:  # no arc at all
        return
    arcs = arc_geometry(
        r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"],
        tx_half_beamwidth=r["tx_half_beamwidth"], rx_half_beamwidth=r["rx_half_beamwidth"],
    )  # fmt: skip
    plan = arcs_plan.plan_pieces(arcs, grid)
    for i in np.flatnonzero(plan.n > 0):
        v32, v64 = _f32_values(plan, int(i))
        assert np.abs(v32 - v64).max() <= plan.eps[i]


def test_counts_beyond_uint16() -> None:
    # 70 000 echoes of one small arc: every cell of it counts 70 000 (the uint32 path).
    n = 70_000
    one = reading((0, 0), 0.3, (0, 0), 0.3, 0.1, 0.6, 0.6)
    many = {k: np.repeat(v, n, axis=0) for k, v in one.items()}
    grid = Grid.covering(-0.1, 0.1, -0.1, 0.1, cell=0.01)
    single = counts(one, grid)
    np.testing.assert_array_equal(counts(many, grid), n * single.astype(np.int64))


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31), cell=st.sampled_from([0.005, 0.02]))
def test_overlap_bound_holds(seed: int, cell: float) -> None:
    r = _mixed_readings(seed, 300, spread=0.3, max_path=1.0)
    grid = Grid.covering(-0.8, 0.8, -0.8, 0.8, cell=cell)  # clips some arcs
    arcs = arc_geometry(
        r["tx_xy"], r["tx_heading"], r["rx_xy"], r["rx_heading"], r["path"],
        tx_half_beamwidth=r["tx_half_beamwidth"], rx_half_beamwidth=r["rx_half_beamwidth"],
    )  # fmt: skip
    plan = arcs_plan.plan_pieces(arcs, grid)
    assert plan.overlap >= counts(r, grid).max()


@pytest.mark.parametrize("seed", [1, 2])
def test_clipping_many_arcs_matches_a_larger_grid(seed: int) -> None:
    # Sub-grids cutting through many arcs (samples surely outside are skipped, the rest
    # masked) give exactly the window of the full map.
    r = _mixed_readings(seed, 300, spread=0.5, max_path=2.0)
    big = Grid.covering(*bounds(r), cell=0.01)
    full = counts(r, big)
    rng = np.random.default_rng(seed)
    for _ in range(4):
        iy0, ix0 = rng.integers(0, big.ny // 2), rng.integers(0, big.nx // 2)
        ny, nx = rng.integers(1, big.ny - iy0), rng.integers(1, big.nx - ix0)
        small = Grid(
            x0=big.x0 + ix0 * big.cell, y0=big.y0 + iy0 * big.cell, cell=big.cell, nx=nx, ny=ny
        )
        np.testing.assert_array_equal(counts(r, small), full[iy0 : iy0 + ny, ix0 : ix0 + nx])

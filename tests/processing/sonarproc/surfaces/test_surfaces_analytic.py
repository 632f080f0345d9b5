"""Analytic checks of extraction and fits on synthetic cell maps (written before tuning)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarproc.grid import Grid
from sonarproc.morphology import ridge as column_ridge
from sonarproc.surfaces import (
    EchoGeometry,
    SurfaceCells,
    SurfaceFailure,
    SurfaceParams,
    decide,
    extract_surfaces,
    find_surfaces,
    fit_surface,
    refine_fits,
    ridge_nms,
    write_surfaces_csv,
    write_surfaces_geojson,
)

CELL = 0.01


def _map(points: np.ndarray, grid: Grid) -> np.ndarray:
    m = np.zeros(grid.shape, dtype=bool)
    iy, ix = grid.to_index(points[:, 0], points[:, 1])
    ok = grid.contains_index(iy, ix)
    m[iy[ok], ix[ok]] = True
    return m


def _segment(a: tuple[float, float], b: tuple[float, float], step: float = 0.002) -> np.ndarray:
    n = int(np.hypot(b[0] - a[0], b[1] - a[1]) / step) + 1
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.asarray(a) + (np.asarray(b) - np.asarray(a)) * t


def _noisy(points: np.ndarray, rng: np.random.Generator, sigma: float) -> np.ndarray:
    return points + rng.normal(0.0, sigma, points.shape)


def _line_of(fit: object) -> tuple[np.ndarray, np.ndarray]:
    assert not isinstance(fit, SurfaceFailure)
    p = np.asarray(fit.params["point"])  # type: ignore[attr-defined]
    d = np.asarray(fit.params["direction"])  # type: ignore[attr-defined]
    return p, d


@pytest.mark.parametrize("angle_deg", [0.0, 90.0, 30.0])
def test_two_parallel_walls_give_two_lines_at_the_right_separation(angle_deg: float) -> None:
    rng = np.random.default_rng(1)
    th = np.deg2rad(angle_deg)
    rot = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    a = _noisy(_segment((0.0, 0.0), (2.0, 0.0)), rng, 0.003) @ rot.T
    b = _noisy(_segment((0.0, 0.8), (2.0, 0.8)), rng, 0.003) @ rot.T
    pts = np.vstack((a, b))
    grid = Grid.covering(*pts[:, 0].min(axis=0, keepdims=True).tolist(), pts[:, 0].max(),
                         pts[:, 1].min(), pts[:, 1].max(), cell=CELL)  # fmt: skip
    found = find_surfaces(_map(pts, grid), grid)
    assert [s.model for s in found.surfaces] == ["line", "line"]
    (p0, d0), (p1, _) = (_line_of(s) for s in found.surfaces)
    normal = np.array([-d0[1], d0[0]])
    assert abs(abs(float((p1 - p0) @ normal)) - 0.8) <= 0.01
    assert all(abs(s.length_m - 2.0) <= 0.03 for s in found.surfaces)
    assert not decide(found).single_function


def test_corner_gives_two_lines_meeting_at_the_corner() -> None:
    rng = np.random.default_rng(2)
    corner = np.array([1.5, 0.4])
    pts = np.vstack(
        (
            _noisy(_segment((0.0, 0.4), tuple(corner)), rng, 0.003),
            _noisy(_segment(tuple(corner), (1.5, 2.0)), rng, 0.003),
        )
    )
    grid = Grid.covering(-0.1, 1.6, 0.3, 2.1, cell=CELL)
    found = find_surfaces(_map(pts, grid), grid)
    assert [s.model for s in found.surfaces] == ["line", "line"]
    (p0, d0), (p1, d1) = (_line_of(s) for s in found.surfaces)
    # intersection of the two fitted lines
    t = np.linalg.solve(np.column_stack((d0, -d1)), p1 - p0)
    meet = p0 + t[0] * d0
    assert np.hypot(*(meet - corner)) <= 0.02
    ends = [s.polyline[[0, -1]] for s in found.surfaces]
    near = [float(np.min(np.hypot(*(e - corner).T))) for e in ends]
    assert max(near) <= 0.05


@pytest.mark.parametrize("radius", [0.3, 0.6])
def test_cylinder_gives_a_closed_arc_of_the_right_radius(radius: float) -> None:
    rng = np.random.default_rng(3)
    phi = np.linspace(0.0, 2 * np.pi, 4000, endpoint=False)
    pts = _noisy(np.column_stack((1.0 + radius * np.cos(phi), 2.0 + radius * np.sin(phi))), rng,
                 0.003)  # fmt: skip
    grid = Grid.covering(0.0, 2.0, 1.0, 3.0, cell=CELL)
    found = find_surfaces(_map(pts, grid), grid)
    assert len(found.surfaces) == 1
    s = found.surfaces[0]
    assert s.model == "arc" and s.closed
    assert abs(s.params["radius"] - radius) <= 0.02
    assert np.hypot(s.params["centre"][0] - 1.0, s.params["centre"][1] - 2.0) <= 0.02
    assert np.allclose(s.polyline[0], s.polyline[-1])


def test_half_cylinder_and_a_fold_need_no_function_of_x() -> None:
    # a U (folds back in x) and a vertical wall
    phi = np.linspace(np.pi, 2 * np.pi, 2000)
    u = np.column_stack((1.0 + 0.5 * np.cos(phi), 1.0 + 0.5 * np.sin(phi)))
    v = _segment((2.5, 0.0), (2.5, 2.0))
    grid = Grid.covering(0.0, 3.0, 0.0, 2.1, cell=CELL)
    found = find_surfaces(_map(np.vstack((u, v)), grid), grid)
    models = sorted(s.model for s in found.surfaces)
    assert models == ["arc", "line"]
    arc = next(s for s in found.surfaces if s.model == "arc")
    assert abs(arc.params["radius"] - 0.5) <= 0.01
    assert abs(abs(arc.params["sweep_rad"]) - np.pi) <= 0.1


def test_gap_bridging_follows_the_parameter() -> None:
    pts = np.vstack((_segment((0.0, 0.0), (1.0, 0.0)), _segment((1.08, 0.0), (2.0, 0.0))))
    grid = Grid.covering(0.0, 2.0, -0.1, 0.1, cell=CELL)
    m = _map(pts, grid)
    assert len(find_surfaces(m, grid, params=SurfaceParams(bridge_m=0.10)).surfaces) == 1
    assert len(find_surfaces(m, grid, params=SurfaceParams(bridge_m=0.05)).surfaces) == 2


def test_nothing_kept_gives_zero_surfaces_and_a_reason() -> None:
    grid = Grid(x0=0.0, y0=0.0, cell=CELL, nx=50, ny=50)
    empty = find_surfaces(np.zeros(grid.shape, bool), grid)
    assert empty.surfaces == [] and empty.reason == "no cells kept after the morphological stage"
    specks = np.zeros(grid.shape, bool)
    specks[10, 10] = specks[30, 40] = True
    few = find_surfaces(specks, grid)
    assert few.surfaces == [] and few.reason is not None and "0.2 m long" in few.reason
    assert decide(few).single_function is False


def test_degenerate_fits_fail_explicitly() -> None:
    one = SurfaceCells(np.zeros(8), np.zeros(8), np.zeros(8), np.ones(8), False)
    got = fit_surface(one, cell=CELL)
    assert isinstance(got, SurfaceFailure) and "one point" in got.reason
    few = SurfaceCells(np.arange(3.0), np.zeros(3), np.arange(3.0), np.ones(3), False)
    assert isinstance(fit_surface(few, cell=CELL), SurfaceFailure)


def test_ridge_keeps_both_corridor_walls_where_the_column_ridge_keeps_one() -> None:
    grid = Grid(x0=0.0, y0=0.0, cell=CELL, nx=200, ny=120)
    yy = grid.centres_y()[:, None]
    profile = lambda y0, h: h * np.exp(-0.5 * ((yy - y0) / 0.02) ** 2)  # noqa: E731
    counts = np.rint(profile(0.3, 20.0) + profile(0.9, 8.0) + np.zeros(grid.shape)).astype(
        np.uint16
    )
    kept = counts >= 2
    both = ridge_nms(kept, counts)
    rows = np.flatnonzero(both.any(axis=1))
    assert rows.tolist() == [30, 90]
    assert both[30].all() and both[90].all()
    assert np.flatnonzero(column_ridge(kept, counts).any(axis=1)).max() < 60


def test_ridge_thins_a_wall_in_any_direction() -> None:
    grid = Grid(x0=0.0, y0=0.0, cell=CELL, nx=150, ny=150)
    xx, yy = np.meshgrid(grid.centres_x(), grid.centres_y())
    d = (xx - 0.75) * np.cos(0.6) + (yy - 0.75) * np.sin(0.6)  # distance to a tilted wall
    counts = np.rint(10 * np.exp(-0.5 * (d / 0.02) ** 2)).astype(np.uint16)
    thin = ridge_nms(counts >= 2, counts)
    thin[:3], thin[-3:], thin[:, :3], thin[:, -3:] = False, False, False, False  # map edge
    x, y = xx[thin], yy[thin]
    dist = (x - 0.75) * np.cos(0.6) + (y - 0.75) * np.sin(0.6)
    assert np.abs(dist).max() <= 0.01
    assert thin.sum() <= 1.6 * (counts >= 2).sum() / 7  # one or two cells thick, not seven


def test_extraction_orders_cells_along_the_surface() -> None:
    phi = np.linspace(0.2, 2.8, 500)
    x, y = np.cos(phi), np.sin(phi)
    (c,) = extract_surfaces(np.round(x, 2), np.round(y, 2), cell=CELL)
    ang = np.unwrap(np.arctan2(c.y, c.x))
    assert np.all(np.diff(c.s) >= 0)
    assert abs(np.corrcoef(ang, c.s)[0, 1]) > 0.99


def test_writers_write_the_contract(tmp_path: Path) -> None:
    grid = Grid(x0=0.0, y0=0.0, cell=CELL, nx=100, ny=60)
    m = np.zeros(grid.shape, bool)
    m[10, 5:95] = True
    m[20:55, 50] = True
    found = find_surfaces(m, grid)
    csv = write_surfaces_csv(found.surfaces, tmp_path / "surfaces.csv").read_text().splitlines()
    assert csv[0] == "surface,kind,x,y"
    ids = np.array([int(r.split(",")[0]) for r in csv[1:]])
    assert sorted(set(ids.tolist())) == [0, 1] and np.all(np.diff(ids) >= 0)
    first = np.array([[float(v) for v in r.split(",")[2:]] for r in csv[1:] if r.startswith("0,")])
    steps = np.hypot(*np.diff(first, axis=0).T)
    assert np.all(steps <= CELL + 1e-9) and steps[:-1].min() >= CELL - 1e-9
    doc = json.loads(write_surfaces_geojson(found.surfaces, tmp_path / "s.geojson").read_text())
    assert doc["type"] == "FeatureCollection" and len(doc["features"]) == 2
    props = doc["features"][0]["properties"]
    assert set(props) >= {"surface", "model", "length_m", "rms_m", "support"}
    assert doc["features"][0]["geometry"]["type"] == "LineString"
    rep = found.to_json()
    assert [r["surface"] for r in rep] == [0, 1] and rep[0]["model"] == "line"
    json.dumps(rep)


def test_echo_refit_moves_a_biased_wall_onto_the_echoes() -> None:
    # sensors along y = 0 looking up at a wall y = 1 (ranges 1 m, 5 mm noise); the ridge's
    # line sits 3 cm short of the wall, on the sensors' side
    rng = np.random.default_rng(4)
    xs = np.linspace(0.0, 2.0, 41)
    echoes = EchoGeometry(
        np.column_stack((xs, np.zeros_like(xs))), np.full(xs.size, np.pi / 2),
        np.full(xs.size, 0.22), 1.0 + rng.normal(0.0, 0.005, xs.size),
    )  # fmt: skip
    x = np.arange(0.0, 2.0, CELL)
    ridge = SurfaceCells(x, 0.97 + 0 * x, x, 1 + 0 * x, False)
    first = fit_surface(ridge, cell=CELL)
    assert not isinstance(first, SurfaceFailure)
    fits, cells = refine_fits([first], [ridge], echoes, cell=CELL)
    assert [f.model for f in fits] == ["line"] and cells[0].size >= 35
    assert abs(float(np.mean(fits[0].polyline[:, 1])) - 1.0) <= 0.005
    # nothing echoes from a line 0.5 m off: dropped
    far = SurfaceCells(x, 0.5 + 0 * x, x, 1 + 0 * x, False)
    other = fit_surface(far, cell=CELL)
    assert not isinstance(other, SurfaceFailure)
    assert refine_fits([other], [far], echoes, cell=CELL)[0] == []

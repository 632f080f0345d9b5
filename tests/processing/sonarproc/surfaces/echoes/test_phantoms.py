"""Phantom surfaces: chance crossings of arcs that the sound went through are dropped.

A room whose walls reflect diffusely (every reading returns the range along its beam's
axis, as a rough wall or a cluttered shelf does) makes arc crossings near the walls that
look like short surfaces with a few readings echoing from them. The readings that face
such a phantom see through it (their range ends beyond it), so it goes; the walls and the
box stay. None of this scene was used to choose the rule's threshold.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from logbuilders import ring_sensors, ring_walk_readings

from sonarlog import LogWriter, read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.pipeline import surfacefit as surfacefit_module
from sonarproc.surfaces import EchoGeometry, count_seen_through, echo_points, refine_fits
from sonarproc.surfaces.echoes import refine as echoes_module
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample

pytestmark = pytest.mark.slow

C = 343.3
CELL = 0.01
ROOM_W, ROOM_H = 8.0, 6.0
BOX = np.array([[4.5, 2.0], [5.5, 2.0], [5.5, 2.6], [4.5, 2.6], [4.5, 2.0]])
WALLS = np.array([[0, 0], [ROOM_W, 0], [ROOM_W, ROOM_H], [0, ROOM_H], [0, 0]], dtype=float)


def _axial_range(px: np.ndarray, py: np.ndarray, h: np.ndarray) -> np.ndarray:
    """Distance along each ray to the nearest wall or box edge (inf where none)."""
    segs = np.concatenate([np.stack((p[:-1], p[1:]), axis=1) for p in (WALLS, BOX)])  # (S, 2, 2)
    a, b = segs[:, 0], segs[:, 1]
    d = np.stack((np.cos(h), np.sin(h)), axis=1)  # (N, 2)
    e = b - a  # (S, 2)
    den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
    wx, wy = a[None, :, 0] - px[:, None], a[None, :, 1] - py[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wx * e[None, :, 1] - wy * e[None, :, 0]) / den
        u = (wx * d[:, None, 1] - wy * d[:, None, 0]) / den
    hit = (t > 1e-9) & (u >= 0) & (u <= 1) & (np.abs(den) > 1e-12)
    return np.where(hit, t, np.inf).min(axis=1)


def _diffuse_room_log(path: Path, n: int = 12_000, seed: int = 7) -> None:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 25.0
    x = 2.6 + 1.6 * np.sin(2 * np.pi * t / 173.0)
    y = 3.0 + 2.0 * np.sin(2 * np.pi * t / 97.0 + 0.4)
    x = np.where((y > 1.6) & (y < 3.0), np.minimum(x, 3.9), x)  # keep clear of the box
    turret = np.deg2rad(7.0) * t
    sens = ring_sensors()
    r = ring_walk_readings(t, x, y, turret, _axial_range, rng, sensors=sens, speed_of_sound=C)
    truth = np.concatenate((WALLS, [[np.nan, np.nan]], BOX))
    with LogWriter(path, sens, speed_of_sound=C, robot="test", truth=truth) as w:
        w.append(r)


def _distance_to_truth(p: np.ndarray) -> np.ndarray:
    segs = np.concatenate([np.stack((q[:-1], q[1:]), axis=1) for q in (WALLS, BOX)])
    a, b = segs[:, 0], segs[:, 1]
    ab = b - a
    t = np.clip(
        np.einsum("nsk,sk->ns", p[:, None, :] - a[None], ab) / np.einsum("sk,sk->s", ab, ab),
        0.0,
        1.0,
    )
    foot = a[None] + t[..., None] * ab[None]
    return np.asarray(np.hypot(*(p[:, None, :] - foot).transpose(2, 0, 1)).min(axis=1))


@pytest.fixture(scope="module")
def diffuse_room(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("diffuse") / "room.h5"
    _diffuse_room_log(path)
    return path


def _run(path: Path) -> list[SurfaceFit]:
    log_ = read_log(path)
    bbox = (-0.5, ROOM_W + 0.5, -0.5, ROOM_H + 0.5)
    result = process(log_, RunParams(cell=CELL, bbox=bbox, fit="auto"))
    assert result.surfaces is not None and result.surface_metrics is not None
    assert result.surface_metrics["precision_m"] <= 0.02
    return result.surfaces.surfaces


def _assert_walls_and_no_phantoms(fits: list[SurfaceFit]) -> None:
    off = [float(np.median(_distance_to_truth(f.polyline))) for f in fits]
    assert sum(d > 0.05 for d in off) == 0, off
    # each wall is found where the robot passed in front of it (x 1-4.2 m, y 1-5 m)
    for axis, value, lo, hi in ((1, 0.0, 1.2, 4.0), (1, ROOM_H, 1.2, 4.0),
                                (0, 0.0, 1.2, 4.8), (0, ROOM_W, 1.2, 4.8)):  # fmt: skip
        along = 1 - axis
        assert any(
            f.model == "line"
            and np.all(np.abs(f.polyline[:, axis] - value) < 0.03)
            and f.polyline[:, along].min() <= lo
            and f.polyline[:, along].max() >= hi
            for f in fits
        ), (axis, value)


def test_a_diffuse_room_gives_its_walls_and_no_phantoms(diffuse_room: Path) -> None:
    # without the seen-through rule this log gives 17 surfaces more than 5 cm from the
    # truth and a precision of 11 cm
    _assert_walls_and_no_phantoms(_run(diffuse_room))


@pytest.mark.parametrize("seed", [12, 15])
def test_no_phantom_behind_the_corners(tmp_path: Path, seed: int) -> None:
    # the walls are found short of the corners; without completing them to their
    # corners for the occlusion test, these seeds (kept aside while that was written)
    # leave one and two phantoms just behind the corners
    path = tmp_path / "room.h5"
    _diffuse_room_log(path, seed=seed)
    _assert_walls_and_no_phantoms(_run(path))


def test_a_long_log_scores_the_first_echo_round_on_a_subset(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 36 000 readings (another seed, not looked at before the subset was written): the
    # first round scores a fifth of them, and finds what scoring all of them finds
    # (the map's path: a log this long would find its walls from the tangent votes first)
    monkeypatch.setattr(surfacefit_module, "LINES_FIRST_READINGS", 10**9)
    path = tmp_path / "long.h5"
    _diffuse_room_log(path, n=36_000, seed=11)
    assert echoes_module.FIRST_ROUND_READINGS < 36_000
    subset = _run(path)
    _assert_walls_and_no_phantoms(subset)
    monkeypatch.setattr(echoes_module, "FIRST_ROUND_READINGS", 10**9)
    full = _run(path)
    assert len(subset) == len(full)
    for a, b in zip(subset, full, strict=True):
        assert a.model == b.model
        assert abs(a.length_m - b.length_m) < 0.05
        assert float(np.median(_distance_to_truth(a.polyline))) < 0.01 + float(
            np.median(_distance_to_truth(b.polyline))
        )


def test_a_phantom_the_readings_see_through_is_dropped() -> None:
    # a wall along y = 2 seen from below at normal incidence, and a phantom line at
    # y = 1.4 that five readings echo from but twenty face and see through
    xs = np.linspace(-1.0, 1.0, 40)
    wall_xy = np.c_[xs, np.zeros_like(xs)]
    wall_rng = np.full(xs.size, 2.0)
    px = np.linspace(-0.3, 0.3, 5)
    ph_xy = np.c_[px, np.full(5, 0.8)]
    ph_rng = np.full(5, 0.6)
    through_xy = np.c_[np.linspace(-0.35, 0.35, 20), np.full(20, 0.9)]
    through_rng = np.full(20, 1.1)  # reaching the wall, 0.6 m beyond the phantom
    g = EchoGeometry(
        np.concatenate((wall_xy, ph_xy, through_xy)),
        np.full(65, math.pi / 2),
        np.full(65, 0.22),
        np.concatenate((wall_rng, ph_rng, through_rng)),
    )
    wall = resample(np.array([[-1.2, 2.0], [1.2, 2.0]]), CELL)
    phantom = resample(np.array([[-0.4, 1.4], [0.4, 1.4]]), CELL)
    got = echo_points([wall, phantom], [False, False], g, tol=0.03)
    assert got[0].readings.size == 60 and got[0].seen_through == 0
    # the search finds arcs ending near a surface: these end 0.7 m behind the phantom
    assert got[1].readings.size == 5 and got[1].seen_through == 0
    through = count_seen_through([wall, phantom], [False, False], g, tol=0.03)
    # the twenty, and the sixteen wall readings below the phantom (|x| < 0.4 m)
    assert through.tolist() == [0, 36]
    fits = []
    cells = []
    for line in (wall, phantom):
        c = SurfaceCells(line[:, 0], line[:, 1], np.arange(len(line)) * CELL,
                         np.ones(len(line)), False)  # fmt: skip
        fit = fit_surface(c, cell=CELL)
        fits.append(fit)
        cells.append(c)
    kept, _ = refine_fits(fits, cells, g, cell=CELL)  # type: ignore[arg-type]
    assert len(kept) == 1
    np.testing.assert_allclose(kept[0].polyline[:, 1], 2.0, atol=1e-6)


def test_sound_passing_the_end_of_a_box_does_not_see_through_it() -> None:
    # a box face confirmed by echo points from x = -0.3 to 0.3, its fit stretched to
    # +-0.5 m; readings at x = 0.4 pass beside the box and reach a wall behind it
    face = resample(np.array([[-0.5, 1.0], [0.5, 1.0]]), CELL)
    echo_pts = np.c_[np.linspace(-0.3, 0.3, 7), np.ones(7)]
    xs = np.array([0.38, 0.40, 0.42, 0.0])
    g = EchoGeometry(np.c_[xs, np.zeros(4)], np.full(4, math.pi / 2), np.full(4, 0.22),
                     np.array([2.0, 2.0, 2.0, 2.0]))  # fmt: skip
    assert count_seen_through([face], [False], g, tol=0.03).tolist() == [4]
    got = count_seen_through([face], [False], g, tol=0.03, confirmed=[echo_pts])
    assert got.tolist() == [1]  # only the reading in front of the confirmed face

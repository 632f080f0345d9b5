"""A wall heard through a doorway is not contradicted by the doorway's jambs.

A wall along y = 0 has a 1 m doorway (x from -0.5 to 0.5 m), each side heard head on
from 1 m below. Behind the doorway a back wall, y = 2.5 m, is heard through it by
sensors 1.5 m below the first wall, straight up, between the jambs. The map's ridge of
the back wall is a shallow arc: the echo points gathered along the feet on it lean out
by up to 6 degrees, and paths drawn to them cross the wall beside the jambs (the back
wall, with fewer echoes, would lose). The sound went straight up, to the feet on the back
wall as refitted, through the doorway: those paths contradict nothing.
"""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces.echoes.occlusion import (
    END_MARGIN_M,
    contradicted,
    path_ends,
    segment_crossings,
)
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample

CELL = 0.01
HALF_BEAM = math.radians(15.0)
BACK_Y, SENSOR_Y = 2.5, -1.5
#: the ridge's arc: centre below the sensors, its top on the back wall
ARC_CENTRE, ARC_RADIUS = np.array([0.0, -5.5]), 8.0


def _cells(line: np.ndarray) -> SurfaceCells:
    return SurfaceCells(line[:, 0], line[:, 1], np.r_[0.0, np.cumsum(np.hypot(
        *np.diff(line, axis=0).T))], np.ones(len(line)), False)  # fmt: skip


def _ridge(line: np.ndarray) -> tuple[SurfaceFit, SurfaceCells]:
    cells = _cells(line)
    fit = fit_surface(cells, cell=CELL)
    assert isinstance(fit, SurfaceFit)
    return fit, cells


def _scene() -> tuple[list[SurfaceFit], list[SurfaceCells], EchoGeometry]:
    side = np.r_[np.linspace(-3.0, -0.5, 26), np.linspace(0.5, 3.0, 26)]
    through = np.r_[-0.46, -0.44, -0.42, -0.4, 0.0, 0.4, 0.42, 0.44, 0.46]
    xy = np.r_[
        np.c_[side, np.full(side.size, -1.0)], np.c_[through, np.full(through.size, SENSOR_Y)]
    ]
    rng = np.r_[np.full(side.size, 1.0), np.full(through.size, BACK_Y - SENSOR_Y)]
    g = EchoGeometry(xy, np.full(len(xy), math.pi / 2), np.full(len(xy), HALF_BEAM), rng)
    phi = np.linspace(math.pi / 2 - 0.15, math.pi / 2 + 0.15, 241)
    arc = ARC_CENTRE + ARC_RADIUS * np.c_[np.cos(phi), np.sin(phi)]
    parts = [
        _ridge(resample(np.array([[-3.0, 0.0], [-0.5, 0.0]]), CELL)),
        _ridge(resample(np.array([[0.5, 0.0], [3.0, 0.0]]), CELL)),
        (SurfaceFit("arc", arc, float(0.3 * ARC_RADIUS), 0.0, len(arc), len(arc), False,
                    {"centre": ARC_CENTRE.tolist(), "radius": ARC_RADIUS,
                     "start_rad": float(phi[0]), "sweep_rad": float(phi[-1] - phi[0])}),
         _cells(arc)),
    ]  # fmt: skip
    return [p[0] for p in parts], [p[1] for p in parts], g


def test_paths_to_the_feet_on_the_arc_would_cross_the_jambs() -> None:
    _, _, g = _scene()
    s = g.xy[-9:]
    v = ARC_CENTRE + ARC_RADIUS * (s - ARC_CENTRE) / np.hypot(*(s - ARC_CENTRE).T)[:, None] - s
    ends = s + (g.range_m[-9:] - END_MARGIN_M)[:, None] * v / np.hypot(*v.T)[:, None]
    wall = np.array([[-3.0, 0.0], [-0.5, 0.0], [0.5, 0.0], [3.0, 0.0]])
    rows, _, _ = segment_crossings(s, ends, wall[[0, 2]], wall[[1, 3]])
    assert np.unique(rows).size >= 3


def test_paths_run_to_the_feet_on_the_refitted_wall_and_pass_the_jambs() -> None:
    _, _, g = _scene()
    n = g.size - 9
    side, through = np.arange(n), np.arange(n, g.size)
    wall = [resample(np.array([[-3.0, 0.0], [-0.5, 0.0]]), CELL),
            resample(np.array([[0.5, 0.0], [3.0, 0.0]]), CELL)]  # fmt: skip
    back = resample(np.array([[-1.0, BACK_Y], [1.0, BACK_Y]]), CELL)
    fits = [SurfaceFit("line", p, 2.5, 0.0, 26, 26, False, {}) for p in wall]
    fits.append(SurfaceFit("line", back, 2.0, 0.0, 9, 9, False, {}))
    readings = [side[g.xy[side, 0] < 0], side[g.xy[side, 0] > 0], through]
    # the echo points gathered along the feet on the ridge's arc: the back wall loses
    s = g.xy[through]
    v = ARC_CENTRE + ARC_RADIUS * (s - ARC_CENTRE) / np.hypot(*(s - ARC_CENTRE).T)[:, None] - s
    leaning = s + g.range_m[through][:, None] * v / np.hypot(*v.T)[:, None]
    ends = path_ends([f.polyline for f in fits], [False] * 3, [g.xy[r] for r in readings],
                     [g.range_m[r] for r in readings])  # fmt: skip
    polys = [f.polyline for f in fits]
    sensors = [g.xy[r] for r in readings]
    assert contradicted(polys, sensors, [*ends[:2], leaning], cell=CELL) == [2]
    # the paths to the feet on the walls as refitted: straight up, through the doorway
    np.testing.assert_allclose(ends[2][:, 0], s[:, 0], atol=1e-9)
    np.testing.assert_allclose(ends[2][:, 1], BACK_Y, atol=1e-9)
    assert contradicted(polys, sensors, ends, cell=CELL) == []

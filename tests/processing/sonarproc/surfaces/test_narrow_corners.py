"""A corner heard over a narrow spread of bearings is reported as a corner.

One sensor on a straight stretch of track, looking back into a room's corner from 4-5 m,
reads its distance to the corner (1-inch range steps, 5 mm noise, seeded). A plane through
the corner, normal to the line of sight, explains those ranges as well as the point.
Handed the two walls and that diagonal plane, :func:`refine_with_points` drops the
diagonal and reports a corner where the walls' lines meet; handed the two walls only, it
finds the corner on their lines; heard 30 times, one reading a noise tail past the range
tolerance, it is still the corner. A short plane that crosses a wall's line obliquely but
whose readings do not all meet at one point, a plane meeting the wall square, and a
wall's readings at the edge of the beam, heard along its normal, make no corner; a wall
is not stretched to a corner past an edge on its line.
"""

from __future__ import annotations

import numpy as np
from cornerlogs import HALF_BEAM, quantised, wall_fit

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.complete import complete_to_corners
from sonarproc.surfaces.reflectors.corner_planes import planes_as_corners
from sonarproc.surfaces.reflectors.line_corners import corners_on_wall_lines
from sonarproc.surfaces.reflectors.points import ClaimedPoints, refine_with_points


def _cells(fit: SurfaceFit) -> SurfaceCells:
    p = fit.polyline
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(p, axis=0).T))]
    return SurfaceCells(p[:, 0].copy(), p[:, 1].copy(), s, np.ones(s.size), False)


def _room(seed: int = 11) -> tuple[EchoGeometry, list[SurfaceFit]]:
    """Walls y = 0 and x = 0 seen head on, the corner (0, 0) from one sensor far along y = 3.8."""
    rng = np.random.default_rng(seed)
    xs = np.sort(rng.uniform(2.4, 3.2, 10))  # irregular steps: the 1-inch rounding is no line
    corner_s = np.c_[xs, np.full(xs.size, 3.8)]
    corner_r = quantised(np.hypot(xs, 3.8), rng)
    wall_x = np.linspace(1.2, 3.8, 12)
    south_s, south_r = np.c_[wall_x, np.full(12, 1.5)], quantised(np.full(12, 1.5), rng)
    west_s, west_r = np.c_[np.full(12, 1.5), wall_x], quantised(np.full(12, 1.5), rng)
    xy = np.r_[corner_s, south_s, west_s]
    heading = np.r_[np.full(10, np.radians(-129.0)), np.full(12, -np.pi / 2), np.full(12, np.pi)]
    echoes = EchoGeometry(xy, heading, np.full(xy.shape[0], HALF_BEAM),
                          np.r_[corner_r, south_r, west_r])  # fmt: skip
    south, west = wall_fit((1.0, 0.0), (4.0, 0.0)), wall_fit((0.0, 1.0), (0.0, 4.0))
    # the plane through the corner, normal to the mean line of sight
    n = np.array([2.8, 3.8]) / np.hypot(2.8, 3.8)
    u = np.array([n[1], -n[0]]) * 0.35
    diagonal = wall_fit((-u[0], -u[1]), (u[0], u[1]))
    return echoes, [south, west, diagonal]


def test_diagonal_through_a_corner_becomes_the_corner() -> None:
    echoes, fits = _room()
    cells = [_cells(f) for f in fits]
    found = ClaimedPoints([], np.zeros(echoes.size, dtype=bool))
    out, out_cells = refine_with_points(lambda e: (list(fits), list(cells)), echoes, found)
    assert len(out) == len(out_cells)
    corners = [s for s in out if s.model == "corner"]
    assert len(corners) == 1
    assert np.hypot(*corners[0].polyline[0]) < 0.02
    assert corners[0].support == 10
    lines = [s for s in out if s.model == "line"]
    assert len(lines) == 2
    # both walls run on to the corner, and nothing runs across it
    for s in lines:
        assert float(np.hypot(*s.polyline.T).min()) < 0.05
        assert float(np.abs(s.polyline).min(axis=0).max()) < 0.01


def test_a_short_oblique_wall_seen_head_on_stays() -> None:
    echoes, fits = _room()
    # the diagonal is a real wall: seen head on from 1 m along a track parallel to it, its
    # ranges are all 1 m, and only the middle one meets the walls' crossing
    d = fits[2].polyline[-1] - fits[2].polyline[0]
    u = d / np.hypot(*d)
    n = np.array([-u[1], u[0]])
    n = n if n @ np.array([1.0, 1.0]) > 0 else -n  # towards the room
    t = np.linspace(-0.3, 0.3, 10)
    xy = echoes.xy.copy()
    xy[:10] = t[:, None] * u + n
    heading = echoes.heading.copy()
    heading[:10] = np.arctan2(-n[1], -n[0])
    r = echoes.range_m.copy()
    r[:10] = quantised(np.ones(10), np.random.default_rng(5))
    wall = EchoGeometry(xy, heading, echoes.half_beam, r)
    gone, points = planes_as_corners(fits, wall)
    assert (gone, points) == ([], [])


def test_a_wall_meeting_another_square_is_no_corner_echo() -> None:
    echoes, fits = _room()
    gone, points = planes_as_corners(fits[:2], echoes)
    assert (gone, points) == ([], [])


def test_a_corner_no_plane_was_fitted_to_is_found_on_the_walls_lines() -> None:
    echoes, fits = _room()
    walls = fits[:2]
    cells = [_cells(f) for f in walls]
    found = ClaimedPoints([], np.zeros(echoes.size, dtype=bool))
    out, _ = refine_with_points(lambda e: (list(walls), list(cells)), echoes, found)
    corners = [s for s in out if s.model == "corner"]
    assert len(corners) == 1
    assert np.hypot(*corners[0].polyline[0]) < 0.02
    assert corners[0].support == 10


def test_a_walls_echoes_at_the_beam_edge_along_its_normal_make_no_corner() -> None:
    # a wall x = 0 (not fitted) heard at 10 degrees off the axis by a sensor driving
    # along its normal, 2 cm beside the fitted wall y = 0's line: its arcs all pass
    # through (0, 0), but so does the plane x = 0, square to y = 0
    rng = np.random.default_rng(3)
    xs = np.linspace(0.8, 2.2, 12)
    wall_x = np.linspace(1.2, 3.8, 12)
    xy = np.r_[np.c_[xs, np.full(12, 0.02)], np.c_[wall_x, np.full(12, 1.5)]]
    heading = np.r_[np.full(12, np.radians(170.0)), np.full(12, -np.pi / 2)]
    r = np.r_[quantised(xs, rng), quantised(np.full(12, 1.5), rng)]
    echoes = EchoGeometry(xy, heading, np.full(24, np.radians(12.5)), r)
    assert corners_on_wall_lines([wall_fit((1.0, 0.0), (4.0, 0.0))], echoes, []) == []


def test_no_wall_is_stretched_past_an_edge_to_a_corner() -> None:
    wall = wall_fit((1.0, 0.0), (4.0, 0.0))
    corner = SurfaceFit("corner", np.array([[7.0, 0.0]]), 0.0, 0.0, 9, 9, False, {})
    edge = SurfaceFit("edge", np.array([[5.5, 0.0]]), 0.0, 0.0, 9, 9, False, {})
    none = EchoGeometry(np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0))
    stretched = complete_to_corners([wall, corner], none)[0]
    assert stretched.polyline[[0, -1]].round(6).tolist() == [[1.0, 0.0], [7.0, 0.0]]
    kept = complete_to_corners([wall, corner, edge], none)[0]
    assert kept.polyline[[0, -1]].round(6).tolist() == [[1.0, 0.0], [4.0, 0.0]]


def test_a_corner_heard_often_with_a_stray_reading_is_still_the_corner() -> None:
    # 30 readings of the corner; the last one, at the track's end, reads 3.3 cm short (a
    # noise tail: 1 cm noise on the 1-inch steps puts a few in a hundred past the range
    # tolerance). It lies within the tolerance of the diagonal plane (nearer than the
    # corner by the sagitta there) but not of the corner: the plane is still its echo
    echoes, fits = _room()
    rng = np.random.default_rng(2)
    xs = np.linspace(2.5, 3.1, 30)
    r = quantised(np.hypot(xs, 3.8), rng)
    r[-1] = np.hypot(xs[-1], 3.8) - 0.033
    n_walls = echoes.size - 10
    xy = np.r_[np.c_[xs, np.full(xs.size, 3.8)], echoes.xy[10:]]
    heading = np.r_[np.full(xs.size, np.radians(-129.0)), echoes.heading[10:]]
    often = EchoGeometry(xy, heading, np.full(xs.size + n_walls, HALF_BEAM),
                         np.r_[r, echoes.range_m[10:]])  # fmt: skip
    gone, points = planes_as_corners(fits, often)
    assert gone == [2]
    assert len(points) == 1
    assert float(np.hypot(*points[0].xy)) < 0.02
    # every reading of the corner, the stray among them, and no wall's
    assert points[0].readings.tolist() == list(range(xs.size))

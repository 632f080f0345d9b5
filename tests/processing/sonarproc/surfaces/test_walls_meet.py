"""A corner whose readings a head-on wall owns is placed where its two fitted walls meet.

A corridor's end wall x = 0 (0 <= y <= 1.6) is seen head on from a track along y = 0.8
and fitted 5 cm past its corner (0, 1.6), as a wall seen head on is (the corner's echo is
within the ranges' tolerance of the wall's there); the north wall y = 1.6 is seen head
on from the same track and fitted from x = 0.7. Sensors aimed up the corner range it from
six poses (1-inch range steps, 5 mm noise, seeded), and the end wall explains every one
of those readings, so no finder of points takes them: the two walls' lines place the
corner, and the end wall ends there. Lines meeting behind a wall (a convex edge), an
opening seen through at the corner, and a short wall's line extended far place nothing.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample
from sonarproc.surfaces.reflectors.points import ClaimedPoints, refine_with_points

INCH = 0.0254
HALF_BEAM = np.radians(15.0)
CORNER = np.array([0.0, 1.6])


def _wall(a: tuple[float, float], b: tuple[float, float]) -> SurfaceFit:
    poly = resample(np.array([a, b], dtype=np.float64), 0.01)
    return SurfaceFit("line", poly, float(np.hypot(*np.subtract(b, a))), 0.0, 20, 20)


def _log(corner_sensors: np.ndarray, extra: list[tuple[Any, ...]] | None = None) -> EchoGeometry:
    """The walls' head-on readings from y = 0.8, and the corner ranged from its sensors."""
    rng = np.random.default_rng(11)
    xs = np.linspace(0.3, 0.6, 6)
    north = np.c_[np.linspace(0.8, 2.8, 12), np.full(12, 0.8)]
    west = np.c_[xs, np.full(6, 0.8)]
    aim = np.arctan2(CORNER[1] - corner_sensors[:, 1], CORNER[0] - corner_sensors[:, 0])
    xy = np.r_[corner_sensors, north, west]
    heading = np.r_[aim + 0.1, np.full(12, np.pi / 2), np.full(6, np.pi)]
    r = np.r_[np.hypot(*(corner_sensors - CORNER).T), np.full(12, 0.8), xs]
    for p, h, d in extra or []:
        xy, heading, r = np.r_[xy, [p]], np.r_[heading, h], np.r_[r, d]
    r = np.round((r + rng.normal(0.0, 0.005, r.size)) / INCH) * INCH
    return EchoGeometry(xy, heading, np.full(xy.shape[0], HALF_BEAM), r)


def _refined(fits: list[SurfaceFit], echoes: EchoGeometry) -> list[SurfaceFit]:
    cells = [SurfaceCells(f.polyline[:, 0], f.polyline[:, 1], np.zeros(len(f.polyline)),
                          np.ones(len(f.polyline)), False) for f in fits]  # fmt: skip
    none = ClaimedPoints([], np.zeros(echoes.size, dtype=bool))
    out, _ = refine_with_points(lambda e: (list(fits), list(cells)), echoes, none)
    return out


def _track() -> np.ndarray:
    return np.c_[np.linspace(0.3, 0.55, 6), np.full(6, 0.8)]


def _corners(out: list[SurfaceFit]) -> list[np.ndarray]:
    return [f.polyline[0] for f in out if f.model == "corner"]


def test_the_head_on_walls_corner_is_where_the_two_walls_meet() -> None:
    end, north = _wall((0.0, 0.2), (0.0, 1.65)), _wall((0.7, 1.6), (3.0, 1.6))
    out = _refined([end, north], _log(_track()))
    corners = _corners(out)
    assert len(corners) == 1
    assert float(np.hypot(*(corners[0] - CORNER))) < 0.02
    # the end wall fitted past its corner ends there; the north wall runs into it
    assert abs(float(out[0].polyline[:, 1].max()) - 1.6) < 0.02
    assert float(out[1].polyline[:, 0].min()) < 0.02
    assert [f.model for f in out] == ["line", "line", "corner"]


def test_lines_meeting_behind_a_wall_are_no_corner() -> None:
    # the north wall seen from above: the end wall lies behind it (a convex meeting)
    end, north = _wall((0.0, 0.2), (0.0, 1.65)), _wall((0.7, 1.6), (3.0, 1.6))
    echoes = _log(_track())
    flip = echoes.xy.copy()
    flip[6:18, 1] = 2.4  # the north wall's sensors above it, looking down
    heading = echoes.heading.copy()
    heading[6:18] = -np.pi / 2
    echoes = EchoGeometry(flip, heading, echoes.half_beam, echoes.range_m)
    assert _corners(_refined([end, north], echoes)) == []


def test_an_opening_seen_through_at_the_corner_is_no_corner() -> None:
    # two viewpoints looked up through the north wall's line beside the corner: nothing till 3 m
    end, north = _wall((0.0, 0.2), (0.0, 1.65)), _wall((0.7, 1.6), (3.0, 1.6))
    through = [((0.05, 0.9), np.pi / 2, 3.0), ((0.35, 0.9), np.pi / 2, 3.0)]
    assert _corners(_refined([end, north], _log(_track(), through))) == []


def test_a_short_walls_line_extended_far_places_no_corner() -> None:
    # the north wall 0.6 m long, ending 0.7 m short of the corner
    end, north = _wall((0.0, 0.2), (0.0, 1.65)), _wall((0.7, 1.6), (1.3, 1.6))
    assert _corners(_refined([end, north], _log(_track()))) == []


def _thin_wall_log() -> EchoGeometry:
    """The corridor's readings, plus the end wall heard head on from a room behind it
    (x = -0.8, y 0.3 to 2.3) and from the corridor along y 0.3 to 1.2 (x = 0.4)."""
    room = [((-0.8, y), 0.0, 0.8) for y in np.linspace(0.3, 2.3, 12)]
    corridor = [((0.4, y), np.pi, 0.4) for y in np.linspace(0.3, 1.2, 8)]
    return _log(_track(), room + corridor)


def test_a_thin_walls_corridor_face_meets_its_corner() -> None:
    # the end wall is thin: one fit spans its corridor face (to the corner at y = 1.6)
    # and its room face, which runs on to y = 2.4; the corner is on the corridor face
    end, north = _wall((0.0, 0.2), (0.0, 2.4)), _wall((0.7, 1.6), (3.0, 1.6))
    corners = _corners(_refined([end, north], _thin_wall_log()))
    assert len(corners) == 1
    assert float(np.hypot(*(corners[0] - CORNER))) < 0.02


def test_a_wall_heard_from_one_side_past_the_corner_is_no_corner() -> None:
    # the same fit heard from the corridor only: the crossing lies inside the wall
    end, north = _wall((0.0, 0.2), (0.0, 2.4)), _wall((0.7, 1.6), (3.0, 1.6))
    corridor = [((0.4, y), np.pi, 0.4) for y in np.linspace(0.3, 1.2, 8)]
    assert _corners(_refined([end, north], _log(_track(), corridor))) == []

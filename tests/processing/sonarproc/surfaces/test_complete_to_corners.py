"""Walls completed to the corners they run into (``complete_to_corners``)."""

from __future__ import annotations

import numpy as np

from sonarproc.surfaces import EchoGeometry
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample
from sonarproc.surfaces.reflectors.complete import complete_to_corners

NONE = EchoGeometry(np.zeros((0, 2)), np.zeros(0), np.zeros(0), np.zeros(0))


def _wall(a: tuple[float, float], b: tuple[float, float]) -> SurfaceFit:
    poly = resample(np.array([a, b], dtype=np.float64), 0.01)
    d = (np.array(b) - np.array(a)) / np.hypot(*(np.array(b) - np.array(a)))
    return SurfaceFit("line", poly, float(np.hypot(*(np.array(b) - np.array(a)))), 0.0, 50,
                      50, False, {"point": list(a), "direction": d.tolist()})  # fmt: skip


def _point(kind: str, xy: tuple[float, float]) -> SurfaceFit:
    return SurfaceFit(kind, np.array([xy], dtype=np.float64), 0.0, 0.0, 9, 9, False, {})


def test_two_walls_found_short_of_their_corner_meet_in_it() -> None:
    bottom, left = _wall((0.8, 0.0), (4.0, 0.0)), _wall((0.0, 3.0), (0.0, 0.7))
    out = complete_to_corners([bottom, left, _point("corner", (0.01, -0.01))], NONE)
    np.testing.assert_allclose(out[0].polyline[[0, -1]], [[0.01, 0.0], [4.0, 0.0]], atol=1e-9)
    np.testing.assert_allclose(out[1].polyline[[0, -1]], [[0.0, 3.0], [0.0, -0.01]], atol=1e-9)
    assert round(out[0].length_m, 2) == 3.99 and round(out[1].length_m, 2) == 3.01
    assert np.allclose(np.diff(out[0].polyline[:, 0]).max(), 0.01, atol=1e-3)
    assert out[2] is not None and out[2].model == "corner"


def test_an_edge_or_a_corner_off_the_line_stretches_nothing() -> None:
    wall = _wall((0.8, 0.0), (4.0, 0.0))
    out = complete_to_corners([wall, _point("edge", (0.0, 0.0)), _point("corner", (0.0, 0.2))],
                              NONE)  # fmt: skip
    assert out[0] is wall


def test_an_opening_seen_through_is_not_bridged_to_a_corner() -> None:
    # a doorway between the wall's end (x = 0.8) and the corner: sensors below x = 0.2 .. 0.6
    # looked through it and ranged 3 m
    wall = _wall((0.8, 0.0), (4.0, 0.0))
    x = np.arange(0.2, 0.65, 0.1)
    seen = EchoGeometry(np.c_[x, np.full(x.size, 1.0)], np.full(x.size, -np.pi / 2),
                        np.full(x.size, 0.2), np.full(x.size, 3.0))  # fmt: skip
    assert complete_to_corners([wall, _point("corner", (0.0, 0.0))], seen)[0] is wall


def test_a_corner_beyond_another_wall_is_not_reached() -> None:
    # the corner of the next room: a partition x = 0.4 stands between the wall and it
    wall = _wall((0.8, 0.0), (4.0, 0.0))
    partition = _wall((0.4, -1.0), (0.4, 1.0))
    out = complete_to_corners([wall, partition, _point("corner", (-1.0, 0.0))], NONE)
    assert out[0] is wall


def test_a_stretch_hidden_behind_another_wall_is_not_completed() -> None:
    # two door recesses' back walls on y = -0.25 behind a corridor wall y = 0: the first
    # recess's back wall ends at x = 0.9, the second's corner is at (4.0, -0.25); sensors in
    # the corridor facing the stretch squarely all ranged the corridor wall (0.75 m short)
    # (the back wall is longer than the stretch: a shorter one would not reach that far)
    wall = _wall((-2.3, -0.25), (0.9, -0.25))
    x = np.repeat(np.arange(1.0, 3.95, 0.05), 2)
    hidden = EchoGeometry(np.c_[x, np.full(x.size, 1.0)], np.full(x.size, -np.pi / 2),
                          np.full(x.size, 0.2), np.full(x.size, 1.0))  # fmt: skip
    assert complete_to_corners([wall, _point("corner", (4.0, -0.25))], hidden)[0] is wall
    # with the corridor wall gone (ranges reach the line) the wall is completed
    reached = EchoGeometry(hidden.xy, hidden.heading, hidden.half_beam, np.full(x.size, 1.25))
    out = complete_to_corners([wall, _point("corner", (4.0, -0.25))], reached)
    np.testing.assert_allclose(out[0].polyline[-1], [4.0, -0.25], atol=1e-9)


def test_a_short_plane_is_not_stretched_far_past_its_end() -> None:
    # a 0.5 m plane (a box's side, or a plane fitted on a pillar's echoes) whose line passes
    # a pillar's point 1.5 m past its end: the line is known too poorly there for the point
    # to be its corner (nothing else stops the stretch: no reading saw through it)
    short = _wall((0.0, 0.0), (0.5, 0.0))
    assert complete_to_corners([short, _point("corner", (2.0, 0.01))], NONE)[0] is short
    # a corner as far past its end as the plane is long is still reached
    out = complete_to_corners([short, _point("corner", (1.0, 0.01))], NONE)
    np.testing.assert_allclose(out[0].polyline[[0, -1]], [[0.0, 0.0], [1.0, 0.0]], atol=1e-9)
    # and so is the far one when a second wall's line runs into it: two walls meet there
    side = _wall((2.0, 3.0), (2.0, 0.8))
    out = complete_to_corners([short, side, _point("corner", (2.0, 0.01))], NONE)
    np.testing.assert_allclose(out[0].polyline[[0, -1]], [[0.0, 0.0], [2.0, 0.0]], atol=1e-9)


def test_a_wall_fitted_past_a_point_on_its_line_ends_there() -> None:
    from sonarproc.surfaces.fitting.models import SurfaceFit as Fit
    from sonarproc.surfaces.planar.polylines import resample
    from sonarproc.surfaces.reflectors.complete import trim_to_points

    def wall(a: list[float], b: list[float]) -> Fit:
        poly = resample(np.array([a, b]), 0.01)
        return Fit("line", poly, float(np.hypot(*np.subtract(b, a))), 0.0, 50, 50, False,
                   {"point": a, "direction": [1.0, 0.0]})  # fmt: skip

    w = wall([0.0, 0.0], [3.13, 0.0])
    # a jamb 13 cm inside the end, 2 cm off the line: the wall ends there
    (t,) = trim_to_points([w], [[3.0, 0.02]])
    assert np.allclose(t.polyline[[0, -1]], [[0.0, 0.0], [3.0, 0.0]]) and t.length_m == 3.0
    # at both ends at once
    (t,) = trim_to_points([w], [[0.1, 0.0], [3.0, 0.0]])
    assert np.allclose(t.polyline[[0, -1]], [[0.1, 0.0], [3.0, 0.0]])
    # inside the wall beyond the end reach, off its line, or past its end: no change
    for q in ([1.5, 0.0], [3.0, 0.2], [3.3, 0.0]):
        (t,) = trim_to_points([w], [q])
        assert t is w
    # a point reflector and a short wall are left alone
    c = Fit("corner", np.array([[3.0, 0.0]]), 0.0, 0.0, 9, 9)
    short = wall([2.7, 0.0], [3.1, 0.0])
    assert trim_to_points([c, short], [[3.0, 0.0]]) == [c, short]


def test_a_piece_is_not_stretched_along_another_piece_of_its_line() -> None:
    # two pieces of the wall y = 0, a gap between them left open: only the nearer one
    # reaches each corner, and no stretch runs along the other piece
    near, far = _wall((0.3, 0.0), (2.0, 0.0)), _wall((2.6, 0.0), (3.5, 0.0))
    corners = [_point("corner", (0.0, 0.0)), _point("corner", (4.3, 0.0))]
    out = complete_to_corners([near, far, *corners], NONE)
    np.testing.assert_allclose(out[0].polyline[[0, -1]], [[0.0, 0.0], [2.0, 0.0]], atol=1e-9)
    np.testing.assert_allclose(out[1].polyline[[0, -1]], [[2.6, 0.0], [4.3, 0.0]], atol=1e-9)

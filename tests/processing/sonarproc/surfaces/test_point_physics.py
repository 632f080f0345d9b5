"""Corner or edge from the echo physics: span, far reach, passed-by beams, occlusion, arcs."""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.classify import (
    EDGE_REACH_M,
    echo_kind,
    heard_as_corner,
    on_circles,
)
from sonarproc.surfaces.reflectors.rcd import PointFeature


def _heard(sensors: np.ndarray, p: np.ndarray, extra: np.ndarray | None = None) -> EchoGeometry:
    """Sensors aimed at ``p`` hearing it; ``extra`` rows: (x, y, heading, range)."""
    rel = p - sensors
    xy, heading, rng = sensors, np.arctan2(rel[:, 1], rel[:, 0]), np.hypot(*rel.T)
    if extra is not None:
        xy = np.vstack((xy, extra[:, :2]))
        heading, rng = np.r_[heading, extra[:, 2]], np.r_[rng, extra[:, 3]]
    return EchoGeometry(xy, heading, np.full(rng.size, math.radians(12.5)), rng)


def _point(p: np.ndarray, sensors: np.ndarray, n: int) -> PointFeature:
    b = np.sort(np.arctan2(sensors[:, 1] - p[1], sensors[:, 0] - p[0]))
    gaps = np.diff(np.r_[b, b[0] + 2 * np.pi])
    return PointFeature(p, np.arange(n), n, 0.005, 0.05, float(2 * np.pi - gaps.max()))


def _arc_sensors(p: np.ndarray, r: np.ndarray, a0: float, a1: float) -> np.ndarray:
    a = np.linspace(a0, a1, r.size)
    return p + np.column_stack((r * np.cos(a), r * np.sin(a)))


def test_a_corner_heard_from_afar_inside_its_right_angle() -> None:
    p = np.zeros(2)
    s = _arc_sensors(p, np.linspace(1.0, 4.0, 12), 0.1, 1.4)  # inside the first quadrant
    e = _heard(s, p)
    f = _point(p, s, 12)
    assert f.span_rad < math.pi / 2
    assert echo_kind(f, e) == "corner"
    assert heard_as_corner(f, e, [])


def test_sensors_all_round_make_an_edge() -> None:
    p = np.zeros(2)
    s = _arc_sensors(p, np.full(12, 1.0), -1.5, 1.5)  # 172 degrees round it
    assert echo_kind(_point(p, s, 12), _heard(s, p)) == "edge"
    assert not heard_as_corner(_point(p, s, 12), _heard(s, p), [])


def test_an_edge_heard_close_by_and_passed_by_from_afar() -> None:
    p = np.zeros(2)
    s = _arc_sensors(p, np.linspace(0.6, 1.2, 10), 0.2, 1.3)
    # three beams from 3 m inside the same sector, aimed at the point, echoed from 4 m
    far = _arc_sensors(p, np.full(3, 3.0), 0.4, 1.0)
    aim = np.arctan2(-far[:, 1], -far[:, 0])
    extra = np.column_stack((far, aim, np.full(3, 4.0)))
    e = _heard(s, p, extra)
    f = _point(p, s, 10)
    assert echo_kind(f, _heard(s, p)) is None  # close by only: the echoes do not tell
    assert echo_kind(f, e) == "edge"


def test_a_far_heard_point_behind_a_fitted_wall_or_just_before_it_is_no_corner() -> None:
    p = np.array([1.0, -0.2])  # behind the wall y = 0 from sensors above it
    s = _arc_sensors(p, np.linspace(2.5, 4.0, 10), 0.9, 2.2)
    wall = [(np.array([-2.0, 0.0]), np.array([4.0, 0.0]))]
    f, e = _point(p, s, 10), _heard(s, p)
    assert heard_as_corner(f, e, [])
    assert not heard_as_corner(f, e, wall)
    q = np.array([1.0, 0.2])  # 20 cm in front of the wall's face, inside its extent
    s2 = _arc_sensors(q, np.linspace(2.5, 4.0, 10), 0.9, 2.2)
    assert not heard_as_corner(_point(q, s2, 10), _heard(s2, q), wall)
    assert EDGE_REACH_M < 2.5


def test_points_on_a_fitted_arc_s_circle_are_the_cylinder_s() -> None:
    arc = SurfaceFit("arc", np.array([[1.25, 1.0], [1.0, 1.25]]), 0.39, 0.0, 9, 9, False,
                     {"centre": [1.0, 1.0], "radius": 0.25})  # fmt: skip
    assert on_circles([1.0 - 0.25, 1.0], [arc])
    assert not on_circles([1.0, 1.6], [arc])
    # heard as the cylinder's facing point: ranges to the circle
    s = np.array([[-1.0, 1.0], [-1.0, 1.2], [-1.0, 0.8]])
    to_circle = np.hypot(*(s - 1.0).T) - 0.25
    assert on_circles([0.75, 1.0], [arc], (s, to_circle))


def test_a_wall_fitted_as_a_wide_arc_does_not_take_its_corner() -> None:
    # a recess's back wall y ~ 2.6 fitted as an arc of radius 6.9 m runs through its corner
    # (2.4, 2.6); the corner's readings range the corner, not the circle (sensors inside it)
    c, radius = np.array([3.0, 2.6 - 6.9]), 6.9
    arc = SurfaceFit("arc", np.array([[3.45, 2.585], [2.55, 2.585]]), 0.9, 0.0, 11, 11, False,
                     {"centre": c.tolist(), "radius": radius})  # fmt: skip
    tilt = math.asin(0.6 / radius)  # the corner 0.6 m west of the circle's top
    corner = c + radius * np.array([-math.sin(tilt), math.cos(tilt)])
    assert abs(np.hypot(*(corner - c)) - radius) < 0.03
    s = corner + np.column_stack((np.linspace(-1.0, 1.0, 9), np.linspace(-2.5, -1.5, 9)))
    assert on_circles(corner, [arc])
    assert not on_circles(corner, [arc], (s, np.hypot(*(s - corner).T)))


def test_a_corner_seen_from_a_narrow_span_is_no_cylinder() -> None:
    # ranges of a circle of radius 8 cm seen over 60 degrees: its sag there, 1.1 cm, is
    # within the time walk, so the point is kept (a corner's beam-edge echoes read long)
    from sonarproc.surfaces.reflectors.rcd import TIME_WALK_M, _radius_says_cylinder

    c, radius = np.zeros(2), 0.08
    a = np.linspace(math.radians(15), math.radians(75), 40)
    dist = np.linspace(1.5, 4.5, 40)
    s = c + np.column_stack((dist * np.cos(a), dist * np.sin(a)))
    rng = dist - radius
    assert radius * (1 - math.cos(math.radians(30))) <= TIME_WALK_M
    assert not _radius_says_cylinder(s, rng, c + radius * np.array([0.707, 0.707]))
    # a 15 cm pillar seen over 150 degrees is one
    a = np.linspace(math.radians(-30), math.radians(120), 40)
    s = c + np.column_stack((dist * np.cos(a), dist * np.sin(a)))
    assert _radius_says_cylinder(s, dist - 0.15, c + 0.15 * np.array([0.5, 0.866]))


def test_a_corner_no_fitted_wall_leads_to_is_kept_when_heard_as_one() -> None:
    # the far corner of a corridor whose end wall was never fitted: no plane at all, heard
    # from 1.5 to 4 m inside its right angle
    from sonarproc.surfaces.reflectors.classify import confirm_points
    from sonarproc.surfaces.reflectors.rcd import point_feature

    p = np.array([5.0, 5.0])
    s = _arc_sensors(p, np.linspace(1.5, 4.0, 30), math.radians(200), math.radians(250))
    e = _heard(s, p)
    # anywhere in the beams, not all on their axes: a beam aimed exactly at the point
    # reads the distance to any diffusely scattering line through it as well
    aim = np.random.default_rng(5).uniform(-0.18, 0.18, 30)
    e = EchoGeometry(e.xy, e.heading + aim, e.half_beam, e.range_m)
    f = point_feature(e, np.arange(30), p + 0.01)
    assert f is not None
    kept = confirm_points([f], e, [])
    assert len(kept) == 1 and np.hypot(*(kept[0][1].xy - p)) < 0.01


def test_a_chance_crossing_behind_a_wall_does_not_answer_its_beams() -> None:
    from sonarproc.surfaces.reflectors.classify import answers_its_beams

    p = np.zeros(2)
    s = _arc_sensors(p, np.linspace(1.5, 4.0, 20), 0.2, 1.3)
    f = _point(p, s, 20)
    assert answers_its_beams(f, _heard(s, p))  # every beam aimed at it ranged it
    # 30 more beams aimed at it ranged a wall 0.2 m in front of it: the point is a
    # crossing of arcs behind that wall, which no sound reached
    more = _arc_sensors(p, np.linspace(1.6, 3.9, 30), 0.25, 1.25)
    short = np.hypot(*more.T) - 0.2
    e = _heard(s, p, np.column_stack((more, np.arctan2(-more[:, 1], -more[:, 0]), short)))
    assert not answers_its_beams(f, e)


def _track(p: np.ndarray, xs: np.ndarray, seed: int, *, wall: bool = False) -> EchoGeometry:
    """Sensors on y = 0 at ``xs`` hearing ``p`` (or the wall y = p[1] square on): 5 mm noise,
    1-inch range steps, each beam's axis up to 8 degrees off the reflector."""
    rng = np.random.default_rng(seed)
    s = np.column_stack((xs, np.zeros(xs.size)))
    rel = p - s
    aim = rng.uniform(-0.14, 0.14, xs.size)
    if wall:
        heading, r = np.full(xs.size, math.pi / 2) + aim, np.full(xs.size, p[1])
    else:
        heading, r = np.arctan2(rel[:, 1], rel[:, 0]) + aim, np.hypot(*rel.T)
    r = np.round((r + rng.normal(0.0, 0.005, xs.size)) / 0.0254) * 0.0254
    return EchoGeometry(s, heading, np.full(xs.size, math.radians(12.5)), r)


def test_a_corner_seen_from_one_straight_track_is_told_from_a_plane() -> None:
    # 41 poses 1 m along a straight track, 3 m from the corner: 13 degrees of bearings,
    # over which the best plane fits the ranges within 1.5 cm (a fixed floor kept them a
    # plane's); the likelihood-ratio test tells the point on most seeds, never a wall
    from sonarproc.surfaces.reflectors.rcd import plane_rms, point_feature

    p = np.array([0.0, 3.0])
    found = 0
    for seed in range(5):
        e = _track(p, np.linspace(1.5, 2.5, 41), seed)
        assert plane_rms(e.xy, e.range_m) < 0.015
        f = point_feature(e, np.arange(41), p + 0.02)
        if f is not None:
            found += 1
            assert np.hypot(*(f.xy - p)) < 0.03  # the range tolerance
        w = _track(p, np.linspace(-0.4, 0.4, 33), seed, wall=True)
        assert point_feature(w, np.arange(33), p) is None
    assert found >= 4

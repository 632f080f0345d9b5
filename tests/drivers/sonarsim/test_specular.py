"""Analytic cases of the specular echo model."""

from __future__ import annotations

import numpy as np
import pytest

from sonarsim import (
    Circle,
    Polyline,
    World,
    echoes,
    first_echo_path,
    polynomial,
    room,
    sinusoid,
    wall,
)

UP = np.pi / 2


def _aim(frm: np.ndarray, to: np.ndarray) -> float:
    d = np.asarray(to, dtype=float) - np.asarray(frm, dtype=float)
    return float(np.arctan2(d[1], d[0]))


def flat_world(y: float = 2.0, half: float = 3.0) -> World:
    return World([wall((-half, y), (half, y))])


@pytest.mark.parametrize("d", [0.2, 1.0, 2.5, 7.0])
def test_normal_incidence_flat_wall_gives_exact_range(d: float) -> None:
    p = first_echo_path(flat_world(d, 10.0), [0.3, 0.0], UP, [0.3, 0.0], UP)
    assert p[0] == pytest.approx(2 * d, abs=1e-12)


@pytest.mark.parametrize("heading_deg", [90 - 12.4, 90 + 12.4, 90 - 5.0])
def test_tilted_sensor_still_sees_wall_inside_beam(heading_deg: float) -> None:
    h = np.deg2rad(heading_deg)
    p = first_echo_path(flat_world(), [0.0, 0.0], h, [0.0, 0.0], h)
    assert p[0] == pytest.approx(4.0, abs=1e-12)


@pytest.mark.parametrize("heading_deg", [90 - 12.6, 90 + 13.0, 0.0, -90.0, 180.0])
def test_wall_outside_beam_gives_no_echo(heading_deg: float) -> None:
    h = np.deg2rad(heading_deg)
    p = first_echo_path(flat_world(), [0.0, 0.0], h, [0.0, 0.0], h)
    assert np.isnan(p[0])


def test_wall_too_short_to_hold_the_normal_foot_gives_no_echo() -> None:
    w = World([wall((0.5, 2.0), (2.0, 2.0))])  # foot of the normal (0, 2) is off the wall
    assert np.isnan(first_echo_path(w, [0.0, 0.0], UP, [0.0, 0.0], UP)[0])


def test_range_limits() -> None:
    w = flat_world(0.1)
    assert np.isnan(first_echo_path(w, [0, 0], UP, [0, 0], UP)[0])  # below 0.15 m
    assert first_echo_path(w, [0, 0], UP, [0, 0], UP, min_range=0.05)[0] == pytest.approx(0.2)
    far = flat_world(11.0, 20.0)
    assert np.isnan(first_echo_path(far, [0, 0], UP, [0, 0], UP)[0])
    assert first_echo_path(far, [0, 0], UP, [0, 0], UP, max_range=12)[0] == pytest.approx(22)


@pytest.mark.parametrize(
    ("tx", "rx"),
    [((-0.5, 0.0), (0.5, 0.0)), ((-0.3, 0.2), (0.4, -0.1)), ((0.0, 0.0), (0.6, 0.5))],
)
def test_bistatic_flat_wall_is_mirror_image_path(
    tx: tuple[float, float], rx: tuple[float, float]
) -> None:
    y = 2.0
    t, r = np.asarray(tx), np.asarray(rx)
    mirror = np.array([r[0], 2 * y - r[1]])
    expected = float(np.hypot(*(mirror - t)))
    foot = t + (mirror - t) * (y - t[1]) / (mirror[1] - t[1])
    ht, hr = _aim(t, foot), _aim(r, foot)
    ev = echoes(flat_world(y), tx, ht, rx, hr)
    assert len(ev) == 1
    assert ev.path[0] == pytest.approx(expected, abs=1e-12)
    # The reflection point satisfies the law of reflection.
    p = ev.point[0]
    a_in = np.arctan2(p[1] - tx[1], p[0] - tx[0])
    a_out = np.arctan2(p[1] - rx[1], p[0] - rx[0])
    assert a_in + a_out == pytest.approx(np.pi, abs=1e-12)


@pytest.mark.parametrize("tx", [(0.0, 0.0), (0.3, -0.2), (-0.25, 0.4)])
def test_circle_reflection_lies_on_line_through_centre(tx: tuple[float, float]) -> None:
    c = np.array([0.1, 3.0])
    r = 0.8
    w = World([Circle((float(c[0]), float(c[1])), r)])
    to_c = c - np.asarray(tx)
    h = float(np.arctan2(to_c[1], to_c[0])) + np.deg2rad(4.0)
    ev = echoes(w, tx, h, tx, h)
    assert len(ev) == 1
    p = ev.point[0]
    u, v = p - c, np.asarray(tx) - c
    assert abs(u[0] * v[1] - u[1] * v[0]) / np.hypot(*v) < 2e-4
    assert ev.path[0] == pytest.approx(2 * (np.hypot(*v) - r), abs=1e-4)


def test_circle_bistatic_normal_bisects() -> None:
    c = np.array([0.0, 2.5])
    w = World([Circle((0.0, 2.5), 0.5)])
    tx, rx = np.array([-0.4, 0.0]), np.array([0.5, 0.1])
    ev = echoes(w, tx, np.arctan2(2.0, 0.4), rx, np.arctan2(2.0, -0.5))
    assert len(ev) == 1
    p = ev.point[0]
    n = (p - c) / np.hypot(*(p - c))
    ut = (tx - p) / np.hypot(*(tx - p))
    ur = (rx - p) / np.hypot(*(rx - p))
    bis = (ut + ur) / np.hypot(*(ut + ur))
    assert float(n @ bis) == pytest.approx(1.0, abs=1e-6)
    assert np.hypot(*(p - c)) == pytest.approx(0.5, abs=1e-4)


def test_curve_monostatic_reflection_is_normal_foot() -> None:
    w = World([polynomial([2.0, 0.1, 0.15], (-2.0, 2.0))])
    tx = np.array([0.2, 0.0])
    ev = echoes(w, tx, UP, tx, UP)
    assert len(ev) == 1
    p = ev.point[0]
    slope = 0.1 + 0.3 * p[0]
    assert p[1] == pytest.approx(2.0 + 0.1 * p[0] + 0.15 * p[0] ** 2, abs=1e-4)
    d = p - tx
    assert float(d @ np.array([1.0, slope])) == pytest.approx(0.0, abs=1e-4)
    assert ev.path[0] == pytest.approx(2 * np.hypot(*d), abs=1e-9)


def test_occlusion_near_wall_hides_far_wall() -> None:
    near = wall((-0.5, 1.0), (0.5, 1.0))
    far = wall((-5.0, 3.0), (5.0, 3.0))
    both = World([near, far])
    ev = echoes(both, [0, 0], UP, [0, 0], UP)
    np.testing.assert_allclose(ev.path, [2.0])
    # Off to the side the near wall is not in the way: the far wall answers.
    ev = echoes(both, [2.0, 0.0], UP, [2.0, 0.0], UP)
    np.testing.assert_allclose(ev.path, [6.0])


def test_occlusion_of_the_return_leg_only() -> None:
    tx, rx = (-0.5, 0.0), (0.5, 0.0)
    ht, hr = _aim(np.array(tx), np.array([0.0, 2.0])), _aim(np.array(rx), np.array([0.0, 2.0]))
    blocker = wall((0.2, 1.0), (0.3, 1.0))  # on the leg from (0, 2) to R only
    w = World([flat_world().surfaces[0], blocker])
    assert len(echoes(World(w.surfaces[:1]), tx, ht, rx, hr)) == 1
    assert len(echoes(w, tx, ht, rx, hr)) == 0
    # The same blocker mirrored onto the outgoing leg blocks too.
    w2 = World([flat_world().surfaces[0], wall((-0.3, 1.0), (-0.2, 1.0))])
    assert len(echoes(w2, tx, ht, rx, hr)) == 0


def test_all_echoes_in_time_order_and_first_echo_mode() -> None:
    # Three short walls facing the origin at 1, 2 and 3 m, at bearings 82, 100 and 90 deg,
    # none in the way of another.
    def facing(bearing_deg: float, dist: float) -> Polyline:
        b = np.deg2rad(bearing_deg)
        c = dist * np.array([np.cos(b), np.sin(b)])
        t = 0.1 * np.array([-np.sin(b), np.cos(b)])
        return wall(c - t, c + t)

    w = World([facing(90.0, 3.0), facing(82.0, 1.0), facing(100.0, 2.0)])
    ev = echoes(w, [[0, 0], [0, 0]], [UP, -UP], [[0, 0], [0, 0]], [UP, -UP])
    np.testing.assert_allclose(ev.path, [2.0, 4.0, 6.0])
    np.testing.assert_array_equal(ev.firing, [0, 0, 0])
    first = first_echo_path(w, [[0, 0], [0, 0]], [UP, -UP], [[0, 0], [0, 0]], [UP, -UP])
    np.testing.assert_allclose(first, [2.0, np.nan])
    np.testing.assert_allclose(ev.first().path, [2.0])


def test_right_angle_corner_double_bounce() -> None:
    w = World([Polyline(np.array([[3.0, -2.0], [3.0, 2.0], [-2.0, 2.0]]))])
    tx = np.array([1.0, 0.5])
    corner = np.array([3.0, 2.0])
    h = float(np.arctan2(*(corner - tx)[::-1])) + 0.05
    single = echoes(w, tx, h, tx, h, max_order=1)
    assert len(single) == 0  # neither wall is seen at normal incidence
    ev = echoes(w, tx, h, tx, h, max_order=2)
    assert len(ev) == 1 and ev.order[0] == 2
    assert ev.path[0] == pytest.approx(2 * np.hypot(*(corner - tx)), abs=1e-12)
    np.testing.assert_allclose(ev.point[0], corner, atol=1e-12)
    # first_echo_path gives corners their double bounce by default.
    assert first_echo_path(w, tx, h, tx, h)[0] == pytest.approx(ev.path[0])


def test_corner_double_bounce_bistatic_is_image_distance() -> None:
    w = World([Polyline(np.array([[3.0, -2.0], [3.0, 2.0], [-2.0, 2.0]]))])
    tx, rx = np.array([1.0, 0.5]), np.array([1.4, 0.6])
    corner = np.array([3.0, 2.0])
    image = 2 * corner - tx  # mirrored across both walls = point reflection in the corner
    ht = float(np.arctan2(*(corner - tx)[::-1]))
    hr = float(np.arctan2(*(corner - rx)[::-1]))
    ev = echoes(w, tx, ht, rx, hr, max_order=2)
    assert len(ev) == 1 and ev.order[0] == 2
    assert ev.path[0] == pytest.approx(np.hypot(*(image - rx)), abs=1e-12)


def test_third_order_between_parallel_walls() -> None:
    w = World([wall((-5, 2.0), (5, 2.0)), wall((-5, -1.0), (5, -1.0))])
    ev = echoes(w, [0, 0], UP, [0, 0], UP, max_order=3)
    np.testing.assert_allclose(ev.path, [4.0, 10.0])
    np.testing.assert_array_equal(ev.order, [1, 3])


def test_room_from_inside_every_wall() -> None:
    w = World([room(-2.0, 3.0, -1.0, 4.0)])
    h = np.deg2rad([0.0, 90.0, 180.0, 270.0])
    xy = np.zeros((4, 2))
    np.testing.assert_allclose(first_echo_path(w, xy, h, xy, h), [6.0, 8.0, 4.0, 2.0])


def test_sinusoid_vertex_gaps_do_not_lose_echoes() -> None:
    # Convex crests of a sampled curve must still reflect (tangent interpolation).
    w = World([sinusoid(0.15, 1.25, (-1.0, 3.0), offset=2.0)])
    x = np.linspace(-0.5, 2.5, 301)
    xy = np.c_[x, np.zeros_like(x)]
    p = first_echo_path(w, xy, UP, xy, UP)
    assert np.isfinite(p).mean() > 0.95
    # Below the far crest (sin = 1 at x = 1.25/4) the range is offset + amplitude.
    crest = first_echo_path(w, [0.3125, 0.0], UP, [0.3125, 0.0], UP)
    assert crest[0] == pytest.approx(2 * 2.15, abs=1e-4)


def test_input_validation() -> None:
    w = flat_world()
    with pytest.raises(ValueError, match="max_order"):
        echoes(w, [0, 0], UP, [0, 0], UP, max_order=0)
    with pytest.raises(ValueError, match=r"\(N, 2\)"):
        echoes(w, [0, 0, 0], UP, [0, 0], UP)


def test_chunked_search_matches_single_pass(monkeypatch: pytest.MonkeyPatch) -> None:
    from sonarsim import search

    w = World([sinusoid(0.15, 1.25, (-1.0, 3.0), offset=2.0), room(-2, 4, -1, 3)])
    rng = np.random.default_rng(3)
    n = 60
    xy = np.c_[rng.uniform(-0.5, 2.5, n), rng.uniform(0, 1.5, n)]
    h = rng.uniform(0.5, 2.6, n)
    ti, ri = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(n), indexing="ij"))
    args = (w, xy[ti], h[ti], xy[ri], h[ri])
    whole = echoes(*args, max_order=2)
    monkeypatch.setattr(search, "_TABLE_ELEMENTS", 10)
    monkeypatch.setattr(search, "_CHUNK_ELEMENTS", 50_000)
    parts = echoes(*args, max_order=2)
    assert len(whole) > 50
    np.testing.assert_array_equal(parts.firing, whole.firing)
    np.testing.assert_allclose(parts.path, whole.path, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(parts.order, whole.order)

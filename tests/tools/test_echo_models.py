"""tools/real_logs/echo_models.py: each echo model's range on analytic geometries.

A wall at a known distance, a sensor at a known angle to it: the specular, axis ray-cast,
diffuse and wide-beam models' ranges follow from trigonometry and are asserted to 1e-9;
the corner reflector, the side-wall map and the scoring on constructed readings.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools" / "real_logs"))  # the tools import each other

import echo_geometry as geo  # noqa: E402
import echo_models  # noqa: E402
import echo_readings as rds  # noqa: E402

DEG = math.pi / 180.0
#: A wall along y = 1 from x = -5 to 5 (one segment).
WALL = [np.array([[-5.0, 1.0], [5.0, 1.0]])]


def _range(cone: float | None, incidence: float, heading_deg: float,
           lines: list[np.ndarray] = WALL, half_deg: float = 15.0,
           xy: tuple[float, float] = (0.0, 0.0)) -> float:  # fmt: skip
    model = geo.EchoModel("m", cone, incidence)
    got = geo.predict(model, np.array([xy], dtype=float), np.array([heading_deg * DEG]),
                     np.array([half_deg * DEG]), lines)  # fmt: skip
    return float(got[0])


def test_every_model_gives_the_perpendicular_distance_head_on() -> None:
    for cone, inc in ((None, 0.0), (0.0, 89.9 * DEG), (15 * DEG, 30 * DEG), (40 * DEG, 0.0)):
        assert _range(cone, inc, 90.0) == pytest.approx(1.0, abs=1e-9)


def test_a_sensor_turned_off_the_normal() -> None:
    # the axis 20 degrees off the wall's normal
    assert _range(None, 0.0, 110.0) == math.inf  # the specular point is outside 15 degrees
    assert _range(25 * DEG, 0.0, 110.0) == pytest.approx(1.0, abs=1e-9)  # a wider beam holds it
    assert _range(0.0, 89.9 * DEG, 110.0) == pytest.approx(1 / math.cos(20 * DEG), abs=1e-9)
    # nearest point in a 15-degree cone: 5 degrees off the normal
    near = 1 / math.cos(5 * DEG)
    assert _range(15 * DEG, 89.9 * DEG, 110.0) == pytest.approx(near, abs=1e-9)
    assert _range(15 * DEG, 10 * DEG, 110.0) == pytest.approx(near, abs=1e-9)
    assert _range(15 * DEG, 3 * DEG, 110.0) == math.inf  # no point at incidence <= 3 degrees
    # turned the other way: the same by symmetry
    assert _range(15 * DEG, 89.9 * DEG, 70.0) == pytest.approx(near, abs=1e-9)


def test_a_segment_end_bounds_the_nearest_point() -> None:
    short = [np.array([[0.5, 1.0], [2.0, 1.0]])]
    # head on: the foot of the perpendicular misses the segment; its near end is 26.6
    # degrees off the normal, inside a 30-degree cone
    assert _range(None, 0.0, 90.0, short, half_deg=30.0) == math.inf
    assert _range(30 * DEG, 89.9 * DEG, 90.0, short) == pytest.approx(
        math.hypot(0.5, 1.0), abs=1e-9
    )
    assert _range(20 * DEG, 89.9 * DEG, 90.0, short) == math.inf  # the cone stops at 20 degrees
    # the axis 45 degrees off meets it at x = 1
    assert _range(0.0, 89.9 * DEG, 45.0, short) == pytest.approx(math.sqrt(2.0), abs=1e-9)


def test_the_axis_ray_cast_takes_the_first_wall_and_walls_have_two_sides() -> None:
    two = [*WALL, np.array([[-5.0, 2.0], [5.0, 2.0]]), np.array([[-5.0, -3.0], [5.0, -3.0]])]
    assert _range(0.0, 89.9 * DEG, 90.0, two) == pytest.approx(1.0, abs=1e-9)
    assert _range(0.0, 89.9 * DEG, -90.0, two) == pytest.approx(3.0, abs=1e-9)
    assert _range(None, 0.0, 90.0, two, xy=(0.0, 1.5)) == pytest.approx(0.5, abs=1e-9)
    assert _range(None, 0.0, -90.0, two, xy=(0.0, 1.5)) == pytest.approx(0.5, abs=1e-9)
    assert _range(0.0, 89.9 * DEG, 0.0, two) == math.inf  # parallel to every wall


def test_a_smooth_bend_is_specular_and_a_sharp_corner_is_not() -> None:
    bend = [np.array([[-1.0, 1.1], [0.0, 1.0], [1.0, 1.1]])]  # turns by 11.4 degrees
    assert _range(None, 0.0, 90.0, bend) == pytest.approx(1.0, abs=1e-9)
    edge = [np.array([[-1.0, 2.0], [0.0, 1.0], [1.0, 2.0]])]  # a convex 90-degree edge
    assert _range(None, 0.0, 90.0, edge) == math.inf


def test_a_concave_right_angle_corner_answers_from_inside_only() -> None:
    room = [np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0]])]
    corners = geo.polyline_corners(room)
    assert corners.xy.tolist() == [[2.0, 0.0]]
    xy = np.array([[1.0, 1.0], [3.0, -1.0]])
    heading = np.array([-45.0 * DEG, 135.0 * DEG])  # both look at the corner
    got = geo.corner_ranges(xy, heading, np.full(2, 15 * DEG), corners)
    assert got[0] == pytest.approx(math.sqrt(2.0), abs=1e-9)
    assert got[1] == math.inf  # seen from outside it is a convex edge
    reported = geo.polyline_corners([], np.array([[2.0, 0.0]]))
    got = geo.corner_ranges(xy, heading, np.full(2, 15 * DEG), reported)
    np.testing.assert_allclose(got, [math.sqrt(2.0), math.sqrt(2.0)], atol=1e-9)
    model = geo.EchoModel("c", None, 0.0, corners=True)
    got = geo.predict(model, xy[:1], heading[:1], np.full(1, 15 * DEG), room)
    assert got[0] == pytest.approx(math.sqrt(2.0), abs=1e-9)


def test_the_specular_model_agrees_with_the_quality_prediction() -> None:
    from sonarproc.methods.testing import flat_wall_beams
    from sonarproc.quality.predict import MapCurves, predict_paths, resample

    beams, _ = flat_wall_beams(10)
    wall = np.array([[-1.0, 1.0], [3.0, 1.0]])
    path, _ = predict_paths(MapCurves([resample(wall, 0.01)], [0], single=False), beams,
                            np.arange(beams.path.size))  # fmt: skip
    p = beams.poses
    assert np.all(p.tx_xy == p.rx_xy)
    got = geo.predict(geo.models()[0], p.tx_xy, p.tx_heading, p.tx_half_beamwidth, [wall])
    np.testing.assert_allclose(2.0 * got, path, atol=1e-3)
    np.testing.assert_allclose(2.0 * got, beams.path, atol=1e-3)


def _readings(xy: np.ndarray, heading: np.ndarray, rng: np.ndarray, t: np.ndarray,
              sensor: np.ndarray, mount: float = 90.0) -> object:  # fmt: skip
    n = rng.size
    return rds.Readings(xy, heading, np.full(n, 15 * DEG), rng, np.full(n, 5.0),
                       rds.group_of(np.full(n, mount)), t, sensor, np.full(n, mount))  # fmt: skip


def test_score_counts_explained_and_false_echoes() -> None:
    rd = _readings(np.zeros((4, 2)), np.zeros(4), np.array([1.0, 2.0, np.nan, np.nan]),
                   np.zeros(4), np.zeros(4, np.intp))  # fmt: skip
    s = rds.score(rd, np.array([1.04, 2.06, 4.0, 6.0]))  # 6 m is beyond the 5 m range
    assert s["side"] == {"explained": 0.5, "echoes": 2.0, "false_echo": 0.5, "silent": 2.0}
    assert s["oblique"]["echoes"] == 0.0 and s["all"]["explained"] == 0.5


def test_the_side_wall_map_finds_two_walls_round_a_corner() -> None:
    # the robot drives along x, then turns up y; its left sonar sees y = 1, then x = -1
    xs = np.arange(0.0, 2.0, 0.05)
    ys = np.arange(0.1, 2.0, 0.05)
    xy = np.vstack(
        (np.column_stack((xs, np.zeros_like(xs))), np.column_stack((np.zeros_like(ys), ys)))
    )
    heading = np.r_[np.full(xs.size, 90.0 * DEG), np.full(ys.size, 180.0 * DEG)]
    rd = _readings(xy, heading, np.ones(xy.shape[0]), np.arange(xy.shape[0], dtype=float),
                   np.zeros(xy.shape[0], np.intp))  # fmt: skip
    walls = rds.side_wall_map(rd)
    assert len(walls) == 2
    np.testing.assert_allclose(walls[0], [[0.0, 1.0], [1.95, 1.0]], atol=1e-9)
    np.testing.assert_allclose(walls[1], [[-1.0, 0.1], [-1.0, 1.95]], atol=1e-9)


def test_the_implied_incidence_of_ranges_along_the_axis_is_the_axis_incidence() -> None:
    n = 8
    xy = np.column_stack((np.linspace(0.0, 1.0, n), np.zeros(n)))
    heading = np.full(n, 60.0 * DEG)  # 30 degrees off the normal of the wall y = 1
    rd = _readings(xy, heading, np.full(n, 1 / math.cos(30 * DEG)), np.arange(n, dtype=float),
                   np.zeros(n, np.intp), mount=45.0)  # fmt: skip
    out = rds.implied_incidence(rd, WALL)
    axis, q = out[0]
    assert axis == pytest.approx(30.0, abs=1e-9)
    np.testing.assert_allclose(q, 30.0, atol=1e-6)
    turned = rds.remount(rd, {0: 15.0})
    np.testing.assert_allclose(turned.heading, 30.0 * DEG, atol=1e-12)
    assert set(turned.group.tolist()) == {"front"}


def test_the_command_line_refuses_missing_inputs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as no_args:
        echo_models.main([])
    assert no_args.value.code == 2
    with pytest.raises(SystemExit) as missing:
        echo_models.main([str(tmp_path / "none.csv"), "--surfaces", str(tmp_path / "s.csv")])
    assert missing.value.code == 2
    assert "LOG: no such file" in capsys.readouterr().err


def test_a_wall_in_front_hides_a_corner() -> None:
    corners = geo.polyline_corners([], np.array([[0.0, 2.0]]))
    xy, heading, cone = np.zeros((2, 2)), np.full(2, 90.0 * DEG), np.full(2, 15 * DEG)
    xy[1] = [0.0, 1.5]
    got = geo.corner_ranges(xy, heading, cone, corners, WALL)  # the wall y = 1 between
    assert got[0] == math.inf
    assert got[1] == pytest.approx(0.5, abs=1e-9)
    # the corner's own walls meet it: they do not hide it
    own = [np.array([[-1.0, 2.0], [0.0, 2.0], [0.0, 3.0]])]
    got = geo.corner_ranges(xy, heading, cone, corners, own)
    np.testing.assert_allclose(got, [2.0, 0.5], atol=1e-9)


def test_the_docstring_examples_hold() -> None:
    import doctest

    for module, examples in ((geo, 8), (rds, 3), (echo_models, 0)):
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
        assert result.failed == 0 and result.attempted >= examples, module.__name__

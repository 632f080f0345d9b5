"""A wall's head-on echoes gathered by a point are the wall's, not the point's."""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.head_on import head_on_echoes, head_on_split, hold_length_m
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M
from sonarproc.surfaces.reflectors.rcd import point_feature

STEP_M = 0.0254  # the ranging board's 1-inch steps
HALF_BEAM = math.radians(15.0)


def _quantised(r: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return np.round((r + rng.normal(0.0, 0.003, r.size)) / STEP_M) * STEP_M


def _gathered(g: EchoGeometry, p: np.ndarray) -> np.ndarray:
    """The readings within the range tolerance of ``p`` that hold it in their beams."""
    rel = p - g.xy
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - g.heading))))
    return np.flatnonzero((np.abs(np.hypot(rel[:, 0], rel[:, 1]) - g.range_m) < RANGE_TOL_M)
                          & (off <= g.half_beam))  # fmt: skip


def _wall_and_strays(n_strays: int) -> tuple[EchoGeometry, int]:
    """The wall y = 0 (x 0 .. 6) heard head on from three passes, and stray echoes at (3, 0).

    The passes' ranges read about 1 cm short after the 1-inch steps, so a point on the
    wall gathers the readings of a stretch shorter than it holds one range over.
    """
    rng = np.random.default_rng(3)
    x = np.tile(np.arange(0.5, 5.51, 0.05), 3)
    y = np.repeat([1.028, 1.79, 2.552], x.size // 3)
    a = np.radians(np.linspace(50.0, 130.0, n_strays))
    d = np.linspace(1.1, 2.0, n_strays)
    s_xy = np.c_[3.0 + d * np.cos(a), d * np.sin(a)]
    s_heading = np.arctan2(-s_xy[:, 1], 3.0 - s_xy[:, 0]) + np.radians(
        np.resize([-8.0, 8.0], n_strays)
    )
    xy = np.vstack((np.c_[x, y], s_xy))
    heading = np.r_[np.full(x.size, -math.pi / 2), s_heading]
    r = np.r_[_quantised(y, rng), _quantised(d, rng)]
    return EchoGeometry(xy, heading, np.full(heading.size, HALF_BEAM), r), x.size


def test_a_point_on_a_walls_middle_made_of_its_head_on_echoes_is_no_point() -> None:
    g, n_wall = _wall_and_strays(7)
    p = np.array([3.0, 0.0])
    idx = _gathered(g, p)
    wall = idx < n_wall
    assert wall.sum() == 32 and (~wall).sum() == 7
    # the stretch each pass gave is shorter than a point at its range holds one range over
    for y in np.unique(g.xy[idx[wall], 1]):
        xs = g.xy[idx[wall]][g.xy[idx[wall], 1] == y, 0]
        assert np.ptp(xs) < 2 * hold_length_m(y)
    # every one is the wall's: the passes run on at its range through the point's foot
    assert head_on_echoes(g, idx, p).tolist() == wall.tolist()
    # and the seven stray echoes left are no point
    assert point_feature(g, idx, p) is None


def test_a_corner_at_a_walls_end_keeps_its_echoes_and_those_near_its_foot() -> None:
    """Corner (4, -1) at the west end of the wall y = -1, heard by sensors 40-50 degrees off."""
    rng = np.random.default_rng(5)
    p = np.array([4.0, -1.0])
    x = np.tile(np.arange(4.0, 7.01, 0.05), 2)
    y = np.repeat([0.4, 1.1], x.size // 2)
    own = [(xx, yy, math.radians(h)) for yy in (0.4, 1.1) for h in (-130.0, -140.0)
           for xx in np.arange(4.0, 7.0, 0.05)
           if abs(math.remainder(math.atan2(p[1] - yy, p[0] - xx) - math.radians(h),
                                 2 * math.pi)) <= HALF_BEAM]  # fmt: skip
    c = np.array(own)
    xy = np.vstack((np.c_[x, y], c[:, :2]))
    heading = np.r_[np.full(x.size, -math.pi / 2), c[:, 2]]
    r = np.r_[_quantised(y + 1.0, rng), _quantised(np.hypot(*(c[:, :2] - p).T), rng)]
    g = EchoGeometry(xy, heading, np.full(heading.size, HALF_BEAM), r)
    start = p + np.array([-0.05, 0.03])  # pulled off its place, it gathers more of the wall's
    idx = _gathered(g, start)
    f = point_feature(g, idx, start)
    assert f is not None
    assert math.dist(f.xy, p) < 0.02
    # its own echoes all stay; of the wall's, those farther along the wall from its foot
    # than it holds one range over are left to the wall, the rest stay
    assert set(np.flatnonzero(heading != -math.pi / 2)) & set(idx) <= set(f.readings)
    left = np.asarray(f.left)
    assert left.size and (heading[left] == -math.pi / 2).all()
    assert (xy[left, 0] - p[0] > np.array([hold_length_m(v) for v in r[left]]) - 0.05).all()
    assert not set(left) & set(f.readings)


def test_a_far_walls_head_on_pass_and_three_strays_make_no_point() -> None:
    """The wall x = 8 heard head on from one pass 3.35 m off (y 4.5 .. 5.3), and three
    echoes of something else from the south whose ranges happen to equal their distance
    to (8, 4.95): over the pass a point there holds the wall's range within the range
    tolerance, so only the three strays could tell it from the wall, and three are not a
    point."""
    rng = np.random.default_rng(7)
    y = np.arange(4.5, 5.31, 0.07)
    wall_xy = np.c_[np.full(y.size, 4.65), y]
    p = np.array([8.0, 4.95])
    s_xy = np.c_[[6.37, 6.44, 6.51], [1.12, 1.12, 1.12]]
    xy = np.vstack((wall_xy, s_xy))
    heading = np.r_[np.zeros(y.size), np.full(3, math.radians(55.0))]
    r = np.r_[
        _quantised(8.0 - wall_xy[:, 0], rng),
        _quantised(np.hypot(p[0] - s_xy[:, 0], p[1] - s_xy[:, 1]), rng),
    ]
    g = EchoGeometry(xy, heading, np.full(heading.size, HALF_BEAM), r)
    wall, level = head_on_split(g, np.arange(r.size), p)
    # the pass's ranges do not change as a point's would by more than the tolerance: not
    # the plane's alone, but no evidence for the point either
    assert not wall.any()
    assert level.tolist() == [True] * y.size + [False] * 3
    assert point_feature(g, np.arange(r.size), p) is None

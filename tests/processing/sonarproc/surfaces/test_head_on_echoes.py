"""A short wall's head-on echoes near its corner are the wall's, not the corner's."""

from __future__ import annotations

import math

import numpy as np

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.rcd import point_feature

STEP_M = 0.0254  # the ranging board's 1-inch steps


def _corner_and_back_wall() -> tuple[EchoGeometry, np.ndarray]:
    """A corner at (4.5, -1) heard over an arc; the wall y = -1 heard head on from 3 passes."""
    rng = np.random.default_rng(7)
    p = np.array([4.5, -1.0])
    a = np.linspace(math.radians(110), math.radians(160), 30)
    d = np.linspace(1.5, 4.0, a.size)
    corner_xy = p + np.column_stack((d * np.cos(a), d * np.sin(a)))
    rel = p - corner_xy
    # heard anywhere in the beam, not only on its axis (as a diffuse wall would be)
    corner_heading = np.arctan2(rel[:, 1], rel[:, 0]) + np.radians(
        np.resize([-10.0, 0.0, 10.0], a.size)
    )
    corner_r = np.hypot(rel[:, 0], rel[:, 1])
    # three passes along y = const, the sensors pointing straight at the wall (-90 deg)
    x = np.tile(np.linspace(3.9, 4.4, 6), 3)
    y = np.repeat([1.06, 1.86, 2.66], 6)
    wall_xy = np.column_stack((x, y))
    wall_r = y + 1.0
    xy = np.vstack((corner_xy, wall_xy))
    heading = np.r_[corner_heading, np.full(x.size, -math.pi / 2)]
    r = np.r_[corner_r, wall_r] + rng.normal(0.0, 0.003, heading.size)
    r = np.round(r / STEP_M) * STEP_M
    wall = np.r_[np.zeros(a.size, dtype=bool), np.ones(x.size, dtype=bool)]
    return EchoGeometry(xy, heading, np.full(r.size, math.radians(15.0)), r), wall


def test_a_corner_leaves_the_head_on_echoes_of_its_wall_to_the_wall() -> None:
    echoes, wall = _corner_and_back_wall()
    f = point_feature(echoes, np.arange(echoes.size), [4.5, -1.0])
    assert f is not None
    assert not wall[f.readings].any()
    assert f.support == int((~wall).sum())
    assert math.dist(f.xy, (4.5, -1.0)) < 0.01

"""A plane fitted through a corner's arcs is that corner, placed on the wall whose end it is.

One sensor driving along y = 3.8 and looking back at 231 degrees reads its distance to the
corner (0, 0) of a wall along y = 0 (from x = 1, seen from above). A short wall near the
line x = 0, 3.6 m up and tilted by 1.7 degrees, has a line that passes 15 cm from the
corner, across the line of sight, where the ranges meet as well. The plane fitted through
the corner's arcs crosses the first wall's line 6 cm off the corner (the ranges fall
3.6 cm short of it there) and the short wall's line at that 15 cm place: the corner is placed on
the line of the wall whose end it is nearest, where the ranges meet on it. Heard seven
times from 4-5 m (fewer readings than a free point needs, enough for a point on a wall's
line, where only a corner's retro-reflection returns), the plane is still the corner;
heard seven times from within 2 m (where an edge's weak echo is heard too), it is not.
"""

from __future__ import annotations

import numpy as np
from cornerlogs import HALF_BEAM, wall_fit

from sonarproc.surfaces.echoes.specular import EchoGeometry, SurfaceEchoes
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.corner_planes import planes_as_corners


def _echoes_of(readings: list[np.ndarray]) -> list[SurfaceEchoes]:
    """Which readings echo from each fit (only ``readings`` is asked)."""
    return [SurfaceEchoes(r, np.zeros((r.size, 2)), np.zeros(r.size), 0) for r in readings]


def _log(corner_s: np.ndarray) -> tuple[EchoGeometry, list[np.ndarray]]:
    """The corner (0, 0) heard from ``corner_s``, and the two walls' own readings."""
    n = corner_s.shape[0]
    wall_x = np.linspace(1.2, 3.8, 10)
    south_s = np.c_[wall_x, np.ones(10)]
    short_y = np.linspace(3.6, 4.1, 10)
    short_s = np.c_[np.ones(10), short_y]
    xy = np.r_[corner_s, south_s, short_s]
    aim = np.arctan2(-corner_s[:, 1], -corner_s[:, 0])
    heading = np.r_[aim, np.full(10, -np.pi / 2), np.full(10, np.pi)]
    rng = np.r_[np.hypot(*corner_s.T), np.ones(10), np.ones(10)]
    echoes = EchoGeometry(xy, heading, np.full(xy.shape[0], HALF_BEAM), rng)
    own = [np.arange(10) + n, np.arange(10) + n + 10, np.arange(n)]
    return echoes, own


def _fits() -> list[SurfaceFit]:
    """The wall y = 0, the short tilted wall, and the plane through the corner's arcs."""
    south = wall_fit((1.0, 0.0), (4.0, 0.0))
    c = np.array([0.12, -0.09])  # 15 cm from the corner, across the line of sight
    top = np.array([0.0, 3.85])
    v = (top - c) / np.hypot(*(top - c))
    a, b = c + 3.65 * v, c + 4.25 * v
    short = wall_fit((a[0], a[1]), (b[0], b[1]))
    d = np.array([-0.06, 0.0])  # where it crosses y = 0
    u = (c - d) / np.hypot(*(c - d))
    p, q = d - 0.25 * u, c + 0.25 * u
    return [south, short, wall_fit((p[0], p[1]), (q[0], q[1]))]


def test_corner_on_the_wall_whose_end_is_nearest() -> None:
    xs = np.linspace(2.5, 3.2, 8)
    echoes, own = _log(np.c_[xs, np.full(8, 3.8)])
    gone, points = planes_as_corners(_fits(), echoes, got=_echoes_of(own))
    assert gone == [2]
    assert len(points) == 1
    assert np.hypot(*points[0].xy) < 0.02


def test_seven_readings_from_far_make_the_corner_near_do_not() -> None:
    xs = np.linspace(2.5, 3.1, 7)
    echoes, own = _log(np.c_[xs, np.full(7, 3.8)])
    gone, points = planes_as_corners(_fits(), echoes, got=_echoes_of(own))
    assert gone == [2]
    assert np.hypot(*points[0].xy) < 0.02
    xs = np.linspace(0.9, 1.2, 7)
    echoes, own = _log(np.c_[xs, np.full(7, 1.0)])
    assert planes_as_corners(_fits(), echoes, got=_echoes_of(own)) == ([], [])

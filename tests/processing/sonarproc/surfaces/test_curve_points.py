"""An arc fitted through one point's arcs is that point; a curved wall stays a curve.

One sensor on a straight stretch of track hears a room's corner from about 4 m (1-inch
range steps, 5 mm noise, seeded): over 3 degrees of bearing a point, a plane and a wide
arc across the line of sight explain its ranges alike. Handed that arc and the wall
that ends at the corner, :func:`refine_with_points` reports the corner in the arc's
place (at the corner's distance; sideways only as well as 3 degrees of bearing tell);
without the wall, or with the arc along the wall's line (a stretch of that wall heard
head on), the arc stays. A concave curved wall seen from inside, and a pillar heard
from all round, keep their arcs: their readings range to different points of them.
"""

from __future__ import annotations

import numpy as np
from cornerlogs import HALF_BEAM, quantised, wall_fit

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.curve_points import curves_as_points
from sonarproc.surfaces.reflectors.points import ClaimedPoints, refine_with_points


def _arc(centre: np.ndarray, radius: float, a0: float, a1: float) -> SurfaceFit:
    phi = np.linspace(a0, a1, 1 + round(100 * radius * abs(a1 - a0)))
    poly = centre + radius * np.c_[np.cos(phi), np.sin(phi)]
    params = {"centre": centre.tolist(), "radius": radius}
    return SurfaceFit("arc", poly, radius * abs(a1 - a0), 0.0, 10, 10, params=params)


def _cells(fit: SurfaceFit) -> SurfaceCells:
    p = fit.polyline
    s = np.r_[0.0, np.cumsum(np.hypot(*np.diff(p, axis=0).T))]
    return SurfaceCells(p[:, 0].copy(), p[:, 1].copy(), s, np.ones(s.size), False)


def _refined(fits: list[SurfaceFit], echoes: EchoGeometry) -> list[SurfaceFit]:
    cells = [_cells(f) for f in fits]
    found = ClaimedPoints([], np.zeros(echoes.size, dtype=bool))
    out, out_cells = refine_with_points(lambda e: (list(fits), list(cells)), echoes, found)
    assert len(out) == len(out_cells)
    return out


def _corner_far_away(seed: int = 3) -> tuple[EchoGeometry, SurfaceFit]:
    """Corner (0, 3) heard from x = 4, y in 0 .. 0.3; a wide arc through it across the view."""
    rng = np.random.default_rng(seed)
    ys = np.sort(rng.uniform(0.0, 0.3, 10))
    s = np.c_[np.full(ys.size, 4.0), ys]
    r = quantised(np.hypot(4.0, ys - 3.0), rng)
    echoes = EchoGeometry(s, np.full(ys.size, np.radians(140.0)), np.full(ys.size, HALF_BEAM), r)
    u0 = np.array([-4.0, 2.85]) / np.hypot(4.0, 2.85)  # the mean line of sight
    centre = np.array([0.0, 3.0]) + 7.0 * u0
    mid = float(np.arctan2(-u0[1], -u0[0]))
    return echoes, _arc(centre, 7.0, mid - 0.07, mid + 0.07)


def test_arc_through_a_corners_arcs_becomes_the_corner() -> None:
    echoes, arc = _corner_far_away()
    wall = wall_fit((0.0, 0.5), (0.0, 2.8))  # x = 0, fitted short of the corner
    out = _refined([wall, arc], echoes)
    assert sorted(s.model for s in out) == ["corner", "line"]
    corner = next(s for s in out if s.model == "corner")
    p = corner.polyline[0]
    # the range pins its distance; over 3 degrees of bearing the noise moves it sideways
    mid = echoes.xy.mean(axis=0)
    assert abs(np.hypot(*(p - mid)) - np.hypot(*(np.array([0.0, 3.0]) - mid))) < 0.02
    assert np.hypot(p[0], p[1] - 3.0) < 0.2
    assert corner.support == 10


def test_arc_without_a_wall_end_or_along_a_wall_stays() -> None:
    echoes, arc = _corner_far_away()
    assert curves_as_points([arc], echoes) == ([], [])
    # the arc continues a wall through the meeting point: a stretch of it heard head on
    end, chord = arc.polyline[-1], arc.polyline[-1] - arc.polyline[0]
    far = end + chord / np.hypot(*chord)
    along = wall_fit((float(end[0]), float(end[1])), (float(far[0]), float(far[1])))
    assert curves_as_points([along, arc], echoes) == ([], [])


def test_concave_curved_wall_stays_an_arc() -> None:
    rng = np.random.default_rng(5)
    xs = np.linspace(-1.0, 1.0, 15)
    s = np.c_[xs, np.full(xs.size, -1.0)]
    d = np.hypot(xs, 1.0)
    heading = np.arctan2(-1.0, xs)  # each sensor faces the wall along its normal
    echoes = EchoGeometry(s, heading, np.full(xs.size, HALF_BEAM), quantised(3.0 - d, rng))
    wall = _arc(np.zeros(2), 3.0, np.arctan2(-1.0, 1.0), np.arctan2(-1.0, -1.0) - 2 * np.pi)
    assert curves_as_points([wall], echoes) == ([], [])
    assert [f.model for f in _refined([wall], echoes)] == ["arc"]


def test_pillar_heard_from_round_it_stays_an_arc() -> None:
    rng = np.random.default_rng(7)
    a = np.linspace(0.0, 2 * np.pi, 24, endpoint=False)
    s = 2.0 * np.c_[np.cos(a), np.sin(a)]
    echoes = EchoGeometry(
        s, a + np.pi, np.full(a.size, HALF_BEAM), quantised(np.full(24, 1.7), rng)
    )
    pillar = _arc(np.zeros(2), 0.3, 0.0, 2 * np.pi)
    pillar = SurfaceFit("arc", pillar.polyline, pillar.length_m, 0.0, 24, 24, True, pillar.params)
    assert curves_as_points([pillar], echoes) == ([], [])

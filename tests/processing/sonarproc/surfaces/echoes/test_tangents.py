"""Walls from the readings' tangent votes (surfaces.echoes.tangents) and the long-log path."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.surfaces import EchoGeometry
from sonarproc.surfaces.echoes.tangents import tangent_lines

HALF_BEAM = math.radians(12.5)


def _facing_wall(
    x: np.ndarray, y_sensor: float, y_wall: float, rng: np.random.Generator, noise: float = 0.005
) -> EchoGeometry:
    """Sensors at (x, y_sensor) looking straight at the wall y = y_wall (up or down)."""
    up = y_wall > y_sensor
    heading = np.full(x.size, math.pi / 2 if up else -math.pi / 2)
    heading += rng.uniform(-0.15, 0.15, x.size)  # the wall's normal stays inside the beam
    r = abs(y_wall - y_sensor) + rng.normal(0.0, noise, x.size)
    xy = np.column_stack((x, np.full(x.size, y_sensor)))
    return EchoGeometry(xy, heading, np.full(x.size, HALF_BEAM), r)


def _join(*gs: EchoGeometry) -> EchoGeometry:
    return EchoGeometry(
        np.concatenate([g.xy for g in gs]),
        np.concatenate([g.heading for g in gs]),
        np.concatenate([g.half_beam for g in gs]),
        np.concatenate([g.range_m for g in gs]),
    )


def _lines(g: EchoGeometry):  # type: ignore[no-untyped-def]
    return tangent_lines(g, tol=0.05, min_votes=20, bridge_m=0.3, min_spread_m=0.1)


def test_two_parallel_walls_give_two_lines_at_their_distances() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(0.0, 6.0, 400)
    g = _join(_facing_wall(x, 1.0, 2.5, rng), _facing_wall(x, 1.0, -0.2, rng))
    segs, claimed = _lines(g)
    assert len(segs) == 2
    rhos = sorted(round(float(s.rho * s.normal[1]), 2) for s in segs)  # y of each wall
    assert abs(rhos[0] - (-0.2)) <= 0.01 and abs(rhos[1] - 2.5) <= 0.01
    assert claimed.all()
    for s in segs:
        assert abs(abs(s.normal[1]) - 1.0) < 1e-3
        assert s.readings.size == 400
        assert np.all(np.diff(s.along) >= 0.0)


def test_a_doorway_cuts_the_wall_in_two() -> None:
    rng = np.random.default_rng(2)
    x = np.concatenate((rng.uniform(0.0, 2.0, 200), rng.uniform(3.0, 5.0, 200)))
    segs, _ = _lines(_facing_wall(x, 0.0, 1.5, rng))
    assert len(segs) == 2
    spans = sorted((float(s.points[:, 0].min()), float(s.points[:, 0].max())) for s in segs)
    assert spans[0][1] < 2.05 and spans[1][0] > 2.95  # the gap stays open
    assert spans[0][1] - spans[0][0] > 1.8 and spans[1][1] - spans[1][0] > 1.8


def test_a_pillar_is_not_taken_for_walls() -> None:
    # sensors all round a pillar of radius 0.4, looking at it from 1-2 m
    rng = np.random.default_rng(3)
    n = 3000
    bearing = rng.uniform(0.0, 2 * math.pi, n)
    dist = rng.uniform(1.0, 2.0, n)
    xy = np.column_stack((dist * np.cos(bearing), dist * np.sin(bearing)))
    heading = bearing + math.pi + rng.uniform(-0.15, 0.15, n)
    r = dist - 0.4 + rng.normal(0.0, 0.005, n)
    segs, claimed = _lines(EchoGeometry(xy, heading, np.full(n, HALF_BEAM), r))
    assert segs == []
    assert not claimed.any()  # the map gets every reading


def test_diffuse_echoes_off_a_found_wall_are_claimed() -> None:
    # most readings look straight at the wall y = 2; a few hit it at 10 deg off their axis
    # and return the range along it (a diffuse echo): they vote for no other line
    rng = np.random.default_rng(4)
    straight = _facing_wall(rng.uniform(0.0, 4.0, 300), 0.0, 2.0, rng)
    x = rng.uniform(1.0, 3.0, 40)
    slant = EchoGeometry(
        np.column_stack((x, np.zeros(40))),
        np.full(40, math.pi / 2 + math.radians(10.0)),
        np.full(40, HALF_BEAM),
        np.full(40, 2.0 / math.cos(math.radians(10.0))),
    )
    segs, claimed = _lines(_join(straight, slant))
    assert len(segs) == 1
    assert claimed.all()
    assert segs[0].readings.size >= 300


@settings(max_examples=25, deadline=None)
@given(
    phi=st.floats(0.0, 2 * math.pi, exclude_max=True),
    dist=st.floats(0.5, 4.0),
    shift=st.floats(-5.0, 5.0),
    seed=st.integers(0, 2**16),
)
def test_any_wall_is_found_where_it_is(phi: float, dist: float, shift: float, seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 200
    u = np.array([math.cos(phi), math.sin(phi)])
    t = np.array([-u[1], u[0]])
    along = rng.uniform(-2.0, 2.0, n) + shift
    back = rng.uniform(0.0, 0.5, n)
    # the wall: points p with p . u = rho; sensors at distance dist + back in front of it
    rho = 3.0
    xy = (rho - dist - back)[:, None] * u + along[:, None] * t
    heading = phi + rng.uniform(-0.15, 0.15, n)
    g = EchoGeometry(xy, heading, np.full(n, HALF_BEAM), dist + back + rng.normal(0, 0.003, n))
    segs, claimed = _lines(g)
    assert len(segs) == 1
    (s,) = segs
    assert float(s.normal @ u) > math.cos(math.radians(1.0))
    # every echo point lies on the wall
    assert np.abs(s.points @ u - rho).max() <= 0.05
    assert claimed.all()


def _room_with_pillar_log(path, n: int):  # type: ignore[no-untyped-def]
    """A ring wandering ``n`` firings in a 10 m x 8 m room round a pillar (r 0.5 m at 5, 4)."""
    from logbuilders import ring_sensors, ring_walk_readings

    from sonarlog import LogWriter

    w, h, cx, cy, rad = 10.0, 8.0, 5.0, 4.0, 0.5
    rng = np.random.default_rng(7)
    t = np.arange(n) / 25.0
    # a loop round the pillar, 2-3 m from it, with the turret turning
    ang = 2 * np.pi * t / 97.0
    rad_walk = 2.5 + 0.5 * np.sin(2 * np.pi * t / 41.0)
    x, y = cx + 1.3 * rad_walk * np.cos(ang), cy + rad_walk * np.sin(ang)

    def axial(px: np.ndarray, py: np.ndarray, hd: np.ndarray) -> np.ndarray:
        c, s = np.cos(hd), np.sin(hd)
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(c > 0, (w - px) / c, np.where(c < 0, -px / c, np.inf))
            ty = np.where(s > 0, (h - py) / s, np.where(s < 0, -py / s, np.inf))
        # the ray against the pillar: |p + d (c, s) - centre| = rad
        ox, oy = px - cx, py - cy
        b = ox * c + oy * s
        disc = b * b - (ox * ox + oy * oy - rad * rad)
        hit = np.where((disc >= 0) & (-b - np.sqrt(np.maximum(disc, 0)) > 0),
                       -b - np.sqrt(np.maximum(disc, 0)), np.inf)  # fmt: skip
        return np.asarray(np.minimum(np.minimum(tx, ty), hit))

    sens = ring_sensors()
    r = ring_walk_readings(t, x, y, np.deg2rad(10.0) * t, axial, rng, sensors=sens,
                           speed_of_sound=343.3)  # fmt: skip
    phi = np.linspace(0.0, 2 * np.pi, 200)
    walls = np.array([[0, 0], [w, 0], [w, h], [0, h], [0, 0]], dtype=float)
    pillar = np.column_stack((cx + rad * np.cos(phi), cy + rad * np.sin(phi)))
    truth = np.vstack((walls, [[np.nan, np.nan]], pillar))
    with LogWriter(path, sens, speed_of_sound=343.3, robot="test", truth=truth) as wr:
        wr.append(r)


def test_a_long_log_finds_its_walls_from_the_votes(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from sonarlog import read_log
    from sonarproc.params import RunParams
    from sonarproc.pipeline import process
    from sonarproc.pipeline.surfacefit import LINES_FIRST_READINGS

    path = tmp_path / "pillar.h5"
    _room_with_pillar_log(path, 2 * LINES_FIRST_READINGS)
    res = process(read_log(path), RunParams(cell=0.02, fit="auto"))
    assert res.auto is not None and res.auto["choice"] == "surfaces"
    assert res.auto["tangent_lines"] >= 4
    assert res.auto["readings_left_to_the_map"] > 0
    walls = [f for f in res.surfaces.surfaces if f.model == "line" and f.length_m > 5.0]  # type: ignore[union-attr]
    assert len(walls) == 4
    # each on its wall: x = 0, x = 10, y = 0 or y = 8, within 2 cm
    for f in walls:
        mid = f.polyline.mean(axis=0)
        off = (
            min(abs(mid[0]), abs(mid[0] - 10.0))
            if abs(f.params["direction"][1]) > 0.99
            else min(abs(mid[1]), abs(mid[1] - 8.0))
        )
        assert off <= 0.02, (mid, f.params)
    m = res.surface_metrics
    assert m is not None and m["precision_m"] <= 0.03

"""The cheap screens before the exact tests keep the exact tests' answers, bit for bit.

:meth:`~sonarproc.surfaces.reflectors.point_echoes.BeamIndex.aiming` screens the sensors
by squared lengths and :func:`~sonarproc.surfaces.echoes.unseen.facing_views` the
readings and the point-reading pairs by dot products; each is held here to the exact
tests applied to every reading, on seeded random readings with beams from none to more
than a half turn wide, points on sensors and readings without a range.
"""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.echoes.unseen import facing_views
from sonarproc.surfaces.freespace import FREE_BEAM_FRACTION, FreeCones
from sonarproc.surfaces.reflectors import point_echoes
from sonarproc.surfaces.reflectors.point_echoes import AXIS_SHARE, BeamIndex

HALF_BEAMS = [0.0, 0.1, 0.22, 1.0, 2.5, 3.5, 7.0]


def _aiming_everywhere(
    echoes: EchoGeometry, p: np.ndarray, reach: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The exact tests of :meth:`BeamIndex.aiming` on every reading."""
    aim = np.minimum(AXIS_SHARE * echoes.half_beam + point_echoes._AIM_MARGIN_RAD, np.pi)
    rx, ry = echoes.xy[:, 0] - float(p[0]), echoes.xy[:, 1] - float(p[1])
    dist = np.hypot(rx, ry)
    toward = -(rx * np.cos(echoes.heading) + ry * np.sin(echoes.heading))
    keep = np.flatnonzero((dist <= reach) & (toward >= dist * np.cos(aim)))
    return keep, np.column_stack((rx[keep], ry[keep])), dist[keep]


@pytest.mark.parametrize("seed", range(4))
def test_beam_index_keeps_what_the_exact_tests_keep(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 4000
    echoes = EchoGeometry(
        rng.uniform(0.0, 8.0, (n, 2)), rng.uniform(-7.0, 7.0, n), rng.choice(HALF_BEAMS, n),
        rng.uniform(0.1, 6.0, n),
    )  # fmt: skip
    index = BeamIndex(echoes)
    asked = [(rng.uniform(-1.0, 9.0, 2), float(rng.uniform(0.01, 6.0))) for _ in range(60)]
    asked += [(echoes.xy[i].copy(), 1.0) for i in range(10)]  # on a sensor
    kept = 0
    for p, reach in asked:
        rows, rel, dist = index.aiming(p, reach)
        order = np.argsort(rows)
        want = _aiming_everywhere(echoes, p, reach)
        assert np.array_equal(rows[order], want[0])
        assert np.array_equal(rel[order], want[1])
        assert np.array_equal(dist[order], want[2])
        kept += rows.size
    assert kept > 0


def _facing_everywhere(
    p: np.ndarray, n: np.ndarray, cones: FreeCones, margin: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`facing_views` by its exact tests on every reading and every pair."""
    cone = FREE_BEAM_FRACTION * cones.half_beam
    toward = np.arctan2(-n[1], -n[0])
    facing = (np.abs(np.angle(np.exp(1j * (cones.heading - toward)))) <= cone) & np.isfinite(
        cones.range_m
    )
    rel = p[:, None, :] - cones.xy[None, facing, :]
    dist = np.hypot(rel[..., 0], rel[..., 1])
    bearing = np.arctan2(rel[..., 1], rel[..., 0]) - cones.heading[facing]
    inside = np.abs(np.angle(np.exp(1j * bearing))) <= cone[facing]
    rng, view = cones.range_m[facing], cones.viewpoint[facing]
    out = []
    for hit in (rng >= dist - margin, rng < dist - margin):
        out.append(np.array([np.unique(view[row]).size for row in inside & hit], dtype=np.intp))
    return out[0], out[1]


@pytest.mark.parametrize("seed", range(4))
def test_facing_views_count_what_the_exact_tests_count(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 1500
    ranges = np.where(rng.random(n) < 0.1, np.inf, rng.uniform(0.2, 6.0, n))
    cones = FreeCones.of(
        rng.uniform(0.0, 5.0, (n, 2)), rng.uniform(-7.0, 7.0, n), rng.choice(HALF_BEAMS, n),
        ranges,
    )  # fmt: skip
    counted = 0
    for _ in range(8):
        angle = rng.uniform(-4.0, 4.0)
        normal = np.array([np.cos(angle), np.sin(angle)])
        points = rng.uniform(-1.0, 6.0, (int(rng.integers(0, 120)), 2))
        reached, short = facing_views(points, normal, cones, margin=0.03)
        want = _facing_everywhere(points, normal, cones, 0.03)
        assert np.array_equal(reached, want[0])
        assert np.array_equal(short, want[1])
        counted += int(reached.sum() + short.sum())
    assert counted > 0

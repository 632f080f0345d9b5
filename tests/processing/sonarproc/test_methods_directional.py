"""The methods of Barshan (2007)'s comparison on analytic cases: a wall, a corner, a cylinder."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.methods import METHODS, make_method
from sonarproc.methods.arc_selection import ordered_arc_cells
from sonarproc.methods.echo_model import first_echo_path
from sonarproc.methods.testing import corner_beams, cylinder_beams, flat_wall_beams
from sonarproc.params import RunParams

NEW = ("directional-max", "arc-median", "triangulation")


def _points(name: str, case):  # type: ignore[no-untyped-def]
    beams, grid = case()
    m = make_method(name).build(beams, grid, RunParams())
    iy, ix = np.nonzero(m.processed)
    x, y = grid.to_world(iy, ix)
    return m, x, y


@pytest.mark.parametrize("name", NEW)
def test_registered_with_a_reference(name: str) -> None:
    cls = METHODS[name]
    assert cls.name == name and cls.summary
    assert any(year in (cls.__doc__ or "") for year in ("2000", "2003", "2007"))


@pytest.mark.parametrize(("name", "tol", "least"), [
    ("directional-max", 0.011, 30), ("arc-median", 0.011, 40), ("triangulation", 0.032, 100),
])  # fmt: skip
def test_flat_wall(name: str, tol: float, least: int) -> None:
    m, x, y = _points(name, flat_wall_beams)
    assert x.size >= least
    assert np.max(np.abs(y - 1.0)) <= tol
    assert x.min() < 0.3 and x.max() > 1.7  # the whole lit part of the wall
    assert m.evidence.sum() >= x.size and m.evidence.dtype == np.uint32


@pytest.mark.parametrize("name", NEW)
def test_corner(name: str) -> None:
    _, x, y = _points(name, corner_beams)
    # every kept cell on one of the two walls x = 2 or y = 2
    assert x.size >= 20
    # (the median of crossings near the vertex may sit a few cells inside it)
    tol = 0.06 if name == "arc-median" else 0.03
    assert np.all(np.minimum(np.abs(x - 2.0), np.abs(y - 2.0)) <= tol)
    assert np.any(np.abs(x - 2.0) <= 0.015) and np.any(np.abs(y - 2.0) <= 0.015)


@pytest.mark.parametrize("name", NEW)
def test_cylinder(name: str) -> None:
    _, x, y = _points(name, cylinder_beams)
    r = np.hypot(x, y)
    assert x.size >= 30
    assert np.all(np.abs(r - 0.3) <= 0.025)
    # seen from all round: points in every quadrant
    quadrant = (x > 0).astype(int) * 2 + (y > 0).astype(int)
    assert set(quadrant.tolist()) == {0, 1, 2, 3}


def test_directional_max_votes_once_per_arc_and_min_count() -> None:
    beams, grid = flat_wall_beams()
    arc, _, _, start = ordered_arc_cells(beams, grid)
    assert np.all(np.diff(arc) >= 0) and start.size == np.unique(arc).size
    m = make_method("directional-max", min_count=1).build(beams, grid, RunParams())
    assert int(m.evidence.sum()) == start.size  # one vote per arc
    strict = make_method("directional-max", min_count=10_000).build(beams, grid, RunParams())
    assert not strict.processed.any()
    with pytest.raises(ValueError, match="min_count"):
        make_method("directional-max", min_count=0)


def test_arc_median_needs_crossings_and_triangulation_options() -> None:
    beams, grid = flat_wall_beams()
    none = make_method("arc-median", min_crossings=10**6).build(beams, grid, RunParams())
    assert not none.processed.any()
    with pytest.raises(ValueError, match="min_baseline"):
        make_method("triangulation", min_baseline=2.0, max_baseline=1.0)
    lone = make_method("triangulation", min_support=10**6).build(beams, grid, RunParams())
    assert not lone.processed.any()


@settings(max_examples=60, deadline=None)
@given(
    tx=st.floats(-1.0, 1.0),
    rx=st.floats(-1.0, 1.0),
    wall=st.floats(0.5, 3.0),
)
def test_echo_model_flat_wall_is_the_mirror_path(tx: float, rx: float, wall: float) -> None:
    xs = np.linspace(-6.0, 6.0, 24001)
    curve = np.column_stack((xs, np.full_like(xs, wall)))
    up = np.pi / 2
    got = first_echo_path([[tx, 0.0]], [up], [1.2], [[rx, 0.0]], [up], [1.2], curve)
    # the image of the receiver in the wall: |T R'| (the specular point is in both beams)
    want = np.hypot(rx - tx, 2 * wall)
    assert got[0] == pytest.approx(want, abs=1e-4)


def test_echo_model_crest_ranks_and_misses() -> None:
    xs = np.linspace(-2.0, 2.0, 4001)
    bump = np.column_stack((xs, 1.0 + 0.1 * np.cos(np.pi * xs)))  # a crest at x = 0
    t = [[0.0, 0.0]]
    # first echo: the troughs at x = +-1 are nearer than the crest, but outside a narrow beam
    narrow = first_echo_path(t, [np.pi / 2], [0.1], t, [np.pi / 2], [0.1], bump)
    assert narrow[0] == pytest.approx(2 * 1.1, abs=1e-4)
    wide = first_echo_path(t * 2, [np.pi / 2] * 2, [1.0] * 2, t * 2, [np.pi / 2] * 2, [1.0] * 2,
                           bump, rank=[0, 2])  # fmt: skip
    assert wide[0] < narrow[0] and wide[1] == pytest.approx(2 * 1.1, abs=1e-3)
    away = first_echo_path(t, [-np.pi / 2], [0.2], t, [-np.pi / 2], [0.2], bump)
    assert np.isnan(away[0])

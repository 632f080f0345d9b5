"""Grid: covering boxes, index rounding, centres and extent."""

from __future__ import annotations

import doctest

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc import arcs, grid, morphology
from sonarproc.arcs import _geometry as arcs_geometry
from sonarproc.grid import Grid


@pytest.mark.parametrize("module", [grid, arcs, arcs_geometry, morphology])
def test_docstring_examples_run(module: object) -> None:
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)  # type: ignore[arg-type]
    assert result.attempted > 0
    assert result.failed == 0


def test_fields_shape_and_extent() -> None:
    g = Grid(x0=1.0, y0=-2.0, cell=0.5, nx=4, ny=3)
    assert g.shape == (3, 4)
    assert g.extent == (0.75, 2.75, -2.25, -0.75)
    np.testing.assert_allclose(g.centres_x(), [1.0, 1.5, 2.0, 2.5])
    np.testing.assert_allclose(g.centres_y(), [-2.0, -1.5, -1.0])


@pytest.mark.parametrize("cell", [0.0, -0.01, float("nan"), float("inf")])
def test_covering_rejects_bad_cell(cell: float) -> None:
    with pytest.raises(ValueError, match="cell size must be > 0"):
        Grid.covering(0.0, 1.0, 0.0, 1.0, cell=cell)


@pytest.mark.parametrize(
    "box", [(1.0, 0.0, 0.0, 1.0), (0.0, 1.0, 1.0, 0.99), (0.0, float("nan"), 0.0, 1.0)]
)
def test_covering_rejects_empty_box(box: tuple[float, float, float, float]) -> None:
    with pytest.raises(ValueError, match="box"):
        Grid.covering(*box, cell=0.1)


def test_direct_construction_validates() -> None:
    with pytest.raises(ValueError):
        Grid(x0=0.0, y0=0.0, cell=0.0, nx=1, ny=1)
    with pytest.raises(ValueError):
        Grid(x0=0.0, y0=0.0, cell=1.0, nx=0, ny=1)


def test_zero_width_box_is_one_column() -> None:
    g = Grid.covering(0.3, 0.3, 0.0, 1.0, cell=0.1)
    assert g.nx == 1
    assert g.ny == 11


@settings(max_examples=80, deadline=None)
@given(
    x=st.floats(-50, 50),
    y=st.floats(-50, 50),
    w=st.floats(0, 20),
    h=st.floats(0, 20),
    cell=st.floats(0.001, 1.0),
)
def test_covering_holds_every_point_of_the_box(
    x: float, y: float, w: float, h: float, cell: float
) -> None:
    g = Grid.covering(x, x + w, y, y + h, cell=cell)
    px = np.array([x, x + w, x, x + w, x + 0.5 * w])
    py = np.array([y, y, y + h, y + h, y + 0.5 * h])
    iy, ix = g.to_index(px, py)
    assert g.contains_index(iy, ix).all()
    # Smallest: at most one spare cell per axis.
    assert g.nx <= w / cell + 2
    assert g.ny <= h / cell + 2
    # Aligned to multiples of cell.
    assert abs(g.x0 / cell - round(g.x0 / cell)) < 1e-6


def test_to_index_rounds_to_nearest_centre() -> None:
    g = Grid(x0=0.0, y0=0.0, cell=1.0, nx=5, ny=5)
    iy, ix = g.to_index([0.49, 0.5, 1.51, -0.51, -0.49], [0.0, 0.0, 2.4, 0.0, 0.0])
    assert ix.tolist() == [0, 1, 2, -1, 0]
    assert iy.tolist() == [0, 0, 2, 0, 0]
    assert ix.dtype == np.intp
    # Centres map back onto their own cells.
    cx, cy = np.meshgrid(g.centres_x(), g.centres_y())
    iy2, ix2 = g.to_index(cx, cy)
    assert (ix2 == np.arange(5)[None, :]).all()
    assert (iy2 == np.arange(5)[:, None]).all()


def test_contains_index() -> None:
    g = Grid(x0=0.0, y0=0.0, cell=1.0, nx=3, ny=2)
    got = g.contains_index([0, 1, 2, -1, 0], [0, 2, 0, 0, 3])
    assert got.tolist() == [True, True, False, False, False]

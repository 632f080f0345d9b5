"""A regular square grid over the world plane, the frame of every arc map.

Cell ``(iy, ix)`` has its centre at ``(x0 + ix * cell, y0 + iy * cell)`` and covers the
square of side ``cell`` around it. Map arrays are indexed ``[iy, ix]``: rows are y, columns
are x, and row 0 is the lowest y (show maps with ``origin="lower"`` and :attr:`Grid.extent`).
A point belongs to the cell whose centre is nearest (halves round up).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Grid"]


def _round_index(v: float) -> int:
    """Round half up to an int (the rule :meth:`Grid.to_index` uses)."""
    return math.floor(v + 0.5)


def _aligned_origin(vmin: float, cell: float) -> float:
    """A multiple of cell whose cell holds vmin under the rounding of to_index."""
    k = _round_index(vmin / cell)
    if _round_index((vmin - k * cell) / cell) < 0:
        k -= 1
    return k * cell


@dataclass(frozen=True)
class Grid:
    """A grid of ``ny`` rows by ``nx`` columns of square cells of side ``cell`` (m).

    Parameters
    ----------
    x0, y0 : float
        World coordinates (m) of the centre of cell ``(0, 0)``.
    cell : float
        Cell side (m), > 0.
    nx, ny : int
        Number of columns (x) and rows (y), >= 1.

    Examples
    --------
    >>> g = Grid.covering(0.0, 1.0, 0.0, 0.5, cell=0.25)
    >>> g.shape
    (3, 5)
    >>> iy, ix = g.to_index([0.26, 0.9], [0.0, 0.49])
    >>> iy.tolist(), ix.tolist()
    ([0, 2], [1, 4])
    """

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int

    def __post_init__(self) -> None:
        if not (math.isfinite(self.cell) and self.cell > 0):
            raise ValueError(f"cell size must be > 0, got {self.cell!r}")
        if not (math.isfinite(self.x0) and math.isfinite(self.y0)):
            raise ValueError(f"grid origin must be finite, got ({self.x0!r}, {self.y0!r})")
        if self.nx < 1 or self.ny < 1:
            raise ValueError(f"grid must have at least one cell, got nx={self.nx}, ny={self.ny}")

    @classmethod
    def covering(cls, xmin: float, xmax: float, ymin: float, ymax: float, *, cell: float) -> Grid:
        """The smallest grid, aligned to multiples of ``cell``, whose cells hold the box.

        Every point of ``[xmin, xmax] x [ymin, ymax]`` maps (by :meth:`to_index`) to a
        cell inside the grid.

        Parameters
        ----------
        xmin, xmax, ymin, ymax : float
            The box (m); a box of zero width or height is allowed.
        cell : float
            Cell side (m).

        Returns
        -------
        Grid

        Raises
        ------
        ValueError
            If ``cell <= 0`` (or not finite) or the box is empty or not finite.

        Examples
        --------
        >>> Grid.covering(-0.02, 0.02, 0.0, 0.0, cell=0.01)
        Grid(x0=-0.02, y0=0.0, cell=0.01, nx=5, ny=1)
        """
        cell = float(cell)
        if not (math.isfinite(cell) and cell > 0):
            raise ValueError(f"cell size must be > 0, got {cell!r}")
        box = [float(v) for v in (xmin, xmax, ymin, ymax)]
        if not all(math.isfinite(v) for v in box):
            raise ValueError(f"box must be finite, got {tuple(box)}")
        xmin, xmax, ymin, ymax = box
        if xmax < xmin or ymax < ymin:
            raise ValueError(f"empty box: x [{xmin}, {xmax}], y [{ymin}, {ymax}]")
        x0 = _aligned_origin(xmin, cell)
        y0 = _aligned_origin(ymin, cell)
        # The same arithmetic as to_index, so the box corners map inside.
        nx = _round_index((xmax - x0) / cell) + 1
        ny = _round_index((ymax - y0) / cell) + 1
        return cls(x0=x0, y0=y0, cell=cell, nx=max(nx, 1), ny=max(ny, 1))

    @property
    def shape(self) -> tuple[int, int]:
        """``(ny, nx)``: the shape of a map array on this grid."""
        return (self.ny, self.nx)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """``(left, right, bottom, top)`` cell edges, for ``imshow(..., origin="lower")``."""
        h = 0.5 * self.cell
        return (
            self.x0 - h,
            self.x0 + (self.nx - 0.5) * self.cell,
            self.y0 - h,
            self.y0 + (self.ny - 0.5) * self.cell,
        )

    def to_index(self, x: ArrayLike, y: ArrayLike) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """Cell indices ``(iy, ix)`` of world points (nearest centre; not clipped).

        Parameters
        ----------
        x, y : array_like
            World coordinates (m), broadcast together.

        Returns
        -------
        iy, ix : ndarray of intp
            May lie outside the grid; see :meth:`contains_index`.

        Examples
        --------
        >>> g = Grid(x0=0.0, y0=0.0, cell=0.1, nx=3, ny=3)
        >>> [a.tolist() for a in g.to_index([0.04, 0.06], [-0.2, 0.29])]
        [[-2, 3], [0, 1]]
        """
        xa, ya = np.broadcast_arrays(
            np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        )
        ix = np.floor((xa - self.x0) / self.cell + 0.5).astype(np.intp)
        iy = np.floor((ya - self.y0) / self.cell + 0.5).astype(np.intp)
        return iy, ix

    def contains_index(self, iy: ArrayLike, ix: ArrayLike) -> NDArray[np.bool_]:
        """Whether cell indices lie inside the grid.

        Examples
        --------
        >>> Grid(x0=0.0, y0=0.0, cell=1.0, nx=2, ny=1).contains_index([0, 0, 1], [1, 2, 0]).tolist()
        [True, False, False]
        """
        iya = np.asarray(iy)
        ixa = np.asarray(ix)
        return (iya >= 0) & (iya < self.ny) & (ixa >= 0) & (ixa < self.nx)

    def centres_x(self) -> NDArray[np.float64]:
        """x of the cell centres of each column, shape ``(nx,)``.

        Examples
        --------
        >>> Grid(x0=1.0, y0=0.0, cell=0.5, nx=3, ny=1).centres_x().tolist()
        [1.0, 1.5, 2.0]
        """
        return self.x0 + self.cell * np.arange(self.nx, dtype=np.float64)

    def centres_y(self) -> NDArray[np.float64]:
        """y of the cell centres of each row, shape ``(ny,)``.

        Examples
        --------
        >>> Grid(x0=0.0, y0=-1.0, cell=0.5, nx=1, ny=2).centres_y().tolist()
        [-1.0, -0.5]
        """
        return self.y0 + self.cell * np.arange(self.ny, dtype=np.float64)

    def to_world(
        self, iy: ArrayLike, ix: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World coordinates ``(x, y)`` (m) of cell centres; the inverse of :meth:`to_index`.

        Examples
        --------
        >>> x, y = Grid(x0=1.0, y0=-1.0, cell=0.5, nx=3, ny=2).to_world([1, 0], [2, 0])
        >>> x.tolist(), y.tolist()
        ([2.0, 1.0], [-0.5, -1.0])
        """
        ixa = np.asarray(ix, dtype=np.float64)
        iya = np.asarray(iy, dtype=np.float64)
        return self.x0 + self.cell * ixa, self.y0 + self.cell * iya

    @property
    def centre_extent(self) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the cell centres (m): the first and last rows/columns.

        Examples
        --------
        >>> Grid(x0=0.0, y0=0.0, cell=0.5, nx=3, ny=2).centre_extent
        (0.0, 1.0, 0.0, 0.5)
        """
        return (
            self.x0,
            self.x0 + (self.nx - 1) * self.cell,
            self.y0,
            self.y0 + (self.ny - 1) * self.cell,
        )

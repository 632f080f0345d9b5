"""From a processed map to fitted surfaces, and the auto decision one curve / surfaces.

:func:`find_surfaces` is the stage the pipeline runs after the morphological operations:
kept cells -> :func:`~sonarproc.surfaces.extraction.extract.extract_surfaces` -> one
:func:`~sonarproc.surfaces.fitting.models.fit_surface` per surface (all straight ones at once:
:mod:`sonarproc.surfaces.fitting.batch`). Nothing kept (or nothing long
enough) gives an empty :class:`SurfaceSet` with a ``reason``, never an exception.

:func:`decide` says whether the kept cells are one surface that is a function of x (the
paper's scenes: keep the paper's polynomial) or not (fit surfaces). Its criterion:

    one function of x  <=>  the largest surface holds at least 90 % of the cells of all
    surfaces, it is not closed, and along it x moves one way: on at least 95 % of its
    arc length (cells averaged over 5 cm of arc length) ``dx/ds`` has the sign of its
    overall x extent and ``|dx/ds| >= cos 80 deg`` (no vertical run, no fold).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid
from sonarproc.surfaces.extraction.extract import (
    SurfaceCells,
    SurfaceParams,
    cells_of,
    extract_surfaces,
)
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit

__all__ = ["Decision", "SurfaceSet", "decide", "find_surfaces"]

#: The auto decision's constants (see the module docstring).
MAIN_SHARE = 0.90
MONOTONE_SHARE = 0.95
MIN_DX_DS = math.cos(math.radians(80.0))
DECIDE_WINDOW_M = 0.05


@dataclass(frozen=True)
class SurfaceSet:
    """Fitted surfaces of one map (longest first) and what could not be fitted.

    Attributes
    ----------
    surfaces : list of SurfaceFit
    failures : list of SurfaceFailure
        Groups of cells long enough to be a surface that no model fitted.
    cells_kept : int
        Cells of the processed map.
    cells_assigned : int
        Cells belonging to a fitted surface.
    reason : str or None
        Why there is no surface (None when there is at least one).
    cells : list of SurfaceCells
        The extracted surfaces' cells, for :func:`decide` and the figures.
    """

    surfaces: list[SurfaceFit]
    failures: list[SurfaceFailure]
    cells_kept: int
    cells_assigned: int
    reason: str | None = None
    cells: list[SurfaceCells] = field(default_factory=list, repr=False)

    def polylines(self) -> list[npt.NDArray[np.float64]]:
        """The fitted surfaces' polylines."""
        return [s.polyline for s in self.surfaces]

    def to_json(self) -> list[dict[str, Any]]:
        """One JSON-ready dict per surface (``surface`` = index here), then the failures."""
        out = [s.to_json(i) for i, s in enumerate(self.surfaces)]
        out += [f.to_json(len(self.surfaces) + i) for i, f in enumerate(self.failures)]
        return out


def find_surfaces(
    processed: npt.ArrayLike,
    grid: Grid,
    counts: npt.ArrayLike | None = None,
    *,
    params: SurfaceParams | None = None,
) -> SurfaceSet:
    """Split the kept cells of a processed map into surfaces and fit each.

    Parameters
    ----------
    processed : array_like of bool, shape grid.shape
        The cells kept by the morphological stage (e.g. ``vote:auto`` then
        :func:`~sonarproc.surfaces.extraction.ridge.ridge_nms`).
    grid : Grid
        The map's grid.
    counts : array_like of int, optional
        Arc counts per cell: reported as each surface's ``arcs``.
    params : SurfaceParams, optional
        Bridging, corners, minimum length.

    Returns
    -------
    SurfaceSet

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=0.01, nx=100, ny=60)
    >>> m = np.zeros(g.shape, bool); m[10, 5:95] = True; m[50, 5:95] = True
    >>> found = find_surfaces(m, g)
    >>> [(s.model, round(s.length_m, 2)) for s in found.surfaces]
    [('line', 0.89), ('line', 0.89)]
    >>> find_surfaces(np.zeros(g.shape, bool), g).reason
    'no cells kept after the morphological stage'
    """
    p = params or SurfaceParams()
    x, y, w = cells_of(processed, grid, counts)
    if x.size == 0:
        return SurfaceSet([], [], 0, 0, "no cells kept after the morphological stage")
    cells = extract_surfaces(x, y, cell=grid.cell, weight=w, params=p)
    if not cells:
        return SurfaceSet(
            [], [], int(x.size), 0,
            f"no group of the {x.size} kept cells is at least {p.min_length_m:g} m long",
        )  # fmt: skip
    fits: list[SurfaceFit] = []
    failures: list[SurfaceFailure] = []
    kept_cells: list[SurfaceCells] = []
    for c, f in zip(cells, fit_surfaces(cells, cell=grid.cell), strict=True):
        if isinstance(f, SurfaceFailure):
            failures.append(f)
        else:
            fits.append(f)
            kept_cells.append(c)
    reason = (
        None if fits else "no surface could be fitted: " + "; ".join(f.reason for f in failures)
    )
    assigned = sum(f.support for f in fits)
    return SurfaceSet(fits, failures, int(x.size), assigned, reason, kept_cells)


@dataclass(frozen=True)
class Decision:
    """The auto decision: one curve y = f(x) (``single_function``) or several surfaces."""

    single_function: bool
    main_share: float
    monotone_share: float
    surfaces: int
    criterion: str = (
        f"one function of x when the largest surface holds >= {MAIN_SHARE:.0%} of the "
        f"surfaces' cells, is open, and on >= {MONOTONE_SHARE:.0%} of its length dx/ds keeps "
        f"the sign of its x extent with |dx/ds| >= cos 80 deg"
    )

    def to_json(self) -> dict[str, Any]:
        """JSON-ready mapping for ``report.json``'s ``auto`` entry."""
        return {
            "criterion": self.criterion,
            "choice": "function" if self.single_function else "surfaces",
            "main_share": self.main_share,
            "monotone_share": self.monotone_share,
            "surfaces": self.surfaces,
        }


def _monotone_share(c: SurfaceCells) -> float:
    """Share of a surface's arc length along which x moves one way, steadily enough."""
    if c.size < 2 or c.extent_m <= 0:
        return 0.0
    b = np.floor(c.s / DECIDE_WINDOW_M).astype(np.int64)
    _, inv, cnt = np.unique(b, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    xb = np.bincount(inv, weights=c.x) / cnt
    sb = np.bincount(inv, weights=c.s) / cnt
    if xb.size < 2:
        return 0.0
    dx, ds = np.diff(xb), np.maximum(np.diff(sb), 1e-12)
    sign = 1.0 if xb[-1] >= xb[0] else -1.0
    good = sign * dx / ds >= MIN_DX_DS
    return float(ds[good].sum() / ds.sum())


def decide(found: SurfaceSet | list[SurfaceCells]) -> Decision:
    """Whether the kept cells form one surface that is a function of x (criterion above).

    Parameters
    ----------
    found : SurfaceSet or list of SurfaceCells
        From :func:`find_surfaces` (or :func:`~sonarproc.surfaces.extract_surfaces`).

    Returns
    -------
    Decision

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=0.01, nx=100, ny=60)
    >>> m = np.zeros(g.shape, bool); m[10, 5:95] = True
    >>> decide(find_surfaces(m, g)).single_function
    True
    >>> m[50, 5:95] = True
    >>> decide(find_surfaces(m, g)).single_function
    False
    """
    cells = found.cells if isinstance(found, SurfaceSet) else list(found)
    if not cells:
        return Decision(False, 0.0, 0.0, 0)
    sizes = np.array([c.size for c in cells], dtype=np.float64)
    k = int(np.argmax(sizes))
    share = float(sizes[k] / sizes.sum())
    main = cells[k]
    mono = 0.0 if main.closed else _monotone_share(main)
    single = share >= MAIN_SHARE and mono >= MONOTONE_SHARE
    return Decision(single, share, mono, len(cells))

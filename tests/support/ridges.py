"""A map's ridge along a straight stretch, and the surface fitted to it (shared by tests)."""

from __future__ import annotations

import numpy as np

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surface
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.polylines import resample


def straight_ridge(
    a: tuple[float, float], b: tuple[float, float], cell: float
) -> tuple[SurfaceFit, SurfaceCells]:
    """The ridge cells from ``a`` to ``b`` (one a cell, unit counts) and their fitted surface."""
    line = resample(np.array([a, b]), cell)
    cells = SurfaceCells(line[:, 0], line[:, 1], np.arange(len(line)) * cell,
                         np.ones(len(line)), False)  # fmt: skip
    fit = fit_surface(cells, cell=cell)
    assert isinstance(fit, SurfaceFit)
    return fit, cells

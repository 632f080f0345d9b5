"""Curved surfaces: smoothing splines x(s), y(s) in arc length.

The cells are averaged in bins of arc length (one cell, or the length over
:data:`~sonarproc.surfaces.fitting.models.MAX_SPLINE_BINS` on long surfaces) and each
coordinate gets a cubic smoothing spline (:func:`sonarproc.fit.smoothing_spline`, the
criterion of :func:`scipy.interpolate.make_smoothing_spline`, smoothing chosen by
generalised cross-validation), weighted by the cells per bin.
"""

from __future__ import annotations

import numpy as np

from sonarproc.fit import smoothing_spline
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import (
    MAX_SPLINE_BINS,
    MIN_CELLS,
    Candidate,
    SurfaceFailure,
)
from sonarproc.surfaces.planar.polylines import distance_to_polylines, resample

__all__ = ["fit_spline"]


def fit_spline(cells: SurfaceCells, *, cell: float) -> Candidate | SurfaceFailure:
    """Smoothing splines x(s), y(s) in arc length over arc-length bins, GCV smoothing."""
    width = max(cell, cells.extent_m / MAX_SPLINE_BINS)
    b = np.floor(cells.s / width).astype(np.int64)
    _, inv, cnt = np.unique(b, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    if cnt.size < MIN_CELLS:
        return SurfaceFailure(f"spline: {cnt.size} arc-length bins, need {MIN_CELLS}", cells.size)
    sb = np.bincount(inv, weights=cells.s) / cnt
    xb = np.bincount(inv, weights=cells.x) / cnt
    yb = np.bincount(inv, weights=cells.y) / cnt
    w = cnt.astype(np.float64)
    try:
        spline = smoothing_spline(sb, np.stack((xb, yb), axis=1), w)
    except (ValueError, np.linalg.LinAlgError) as err:
        return SurfaceFailure(f"spline: {err}", cells.size)
    fine = np.linspace(sb[0], sb[-1], max(2, 4 * cnt.size))
    dense = spline(fine)
    if not np.all(np.isfinite(dense)):
        return SurfaceFailure("spline: not finite", cells.size)
    poly = resample(dense, cell)
    rms = float(
        np.sqrt(np.mean(distance_to_polylines(np.stack((cells.x, cells.y), 1), [dense]) ** 2))
    )
    return Candidate("spline", poly, rms, {"knots": int(cnt.size)})

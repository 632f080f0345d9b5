"""Readings and walls of the synthetic corner tests: ranges in 1-inch steps with 5 mm of
seeded noise (the Polaroid ranging board's resolution and a quiet receiver), and fitted
straight walls as :class:`~sonarproc.surfaces.fitting.models.SurfaceFit` polylines."""

from __future__ import annotations

import numpy as np

from sonarproc.surfaces.fitting.models import SurfaceFit

#: The ranging board's range step (m).
INCH = 0.0254
#: The nominal half beam width of the simulated sensors (rad).
HALF_BEAM = np.radians(15.0)


def quantised(r: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Ranges ``r`` (m) with 5 mm of Gaussian noise, read in 1-inch steps."""
    return np.round((r + rng.normal(0.0, 0.005, r.size)) / INCH) * INCH


def wall_fit(a: tuple[float, float], b: tuple[float, float]) -> SurfaceFit:
    """A fitted straight wall from ``a`` to ``b``, sampled every centimetre."""
    t = np.linspace(0.0, 1.0, 1 + round(100 * np.hypot(b[0] - a[0], b[1] - a[1])))
    poly = np.asarray(a) + t[:, None] * (np.asarray(b) - np.asarray(a))
    return SurfaceFit("line", poly, float(np.hypot(*np.subtract(b, a))), 0.0, 10, 10)

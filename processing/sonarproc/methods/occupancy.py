"""Occupancy (certainty) grid with an inverse sonar model (Elfes & Moravec, 1985-89).

Each echo of range ``r`` updates the log-odds of the cells of its beam cone (apex at the
transducer, half angle the beam's, for a bistatic pair the pair's midpoint, the bisector
of the headings and the narrower beam, range the line-of-sight distance of
:func:`~sonarproc.methods.geometry.axis_points`):

* cells nearer than ``r - band/2``: free, ``+ log(p_free / (1 - p_free))`` (< 0);
* cells within ``band/2`` of ``r``: occupied, ``+ log(p_occ / (1 - p_occ))`` (> 0);
* cells beyond: unchanged (prior 0, p = 0.5).

The updates are constant over the cone (no fall-off with the angle off axis), so the
log-odds of a cell is ``l_occ * n_occ + l_free * n_free`` with ``n_occ``, ``n_free`` the
number of readings whose occupied band or free sector covers it: the Bayesian update is
order-free and computed for every reading at once (:func:`sector_counts`).
The map keeps ``select=threshold``: cells with p > ``p_min`` (default 0.5), or
``select=ridge``: in each column, the cell of highest probability among those.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import ClassVar

import numpy as np
import numpy.typing as npt

from sonarproc.errors import ParameterError
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MapMethod, MethodMap, OptionValue
from sonarproc.methods.geometry import axis_points, sector_counts
from sonarproc.params import RunParams

__all__ = ["Occupancy", "log_odds"]


def log_odds(p: float) -> float:
    """``log(p / (1 - p))``.

    Examples
    --------
    >>> round(log_odds(0.7), 6)
    0.847298
    """
    return math.log(p / (1.0 - p))


class Occupancy(MapMethod):
    """Log-odds certainty grid over the beam cones (Elfes/Moravec inverse sensor model)."""

    name: ClassVar[str] = "occupancy"
    summary: ClassVar[str] = "log-odds occupancy grid, free cone + occupied band per echo"
    defaults: ClassVar[Mapping[str, OptionValue]] = {
        "p_occ": 0.7,
        "p_free": 0.35,
        "band": 0.0,
        "select": "threshold",
        "p_min": 0.5,
    }

    def validate(self) -> None:
        o = self.options
        if not 0.5 < float(o["p_occ"]) < 1.0:
            raise ParameterError("occupancy", "option p_occ must be in (0.5, 1)")
        if not 0.0 < float(o["p_free"]) < 0.5:
            raise ParameterError("occupancy", "option p_free must be in (0, 0.5)")
        if not (math.isfinite(float(o["band"])) and float(o["band"]) >= 0):
            raise ParameterError("occupancy", "option band must be >= 0 m (0: two cells)")
        if o["select"] not in ("threshold", "ridge"):
            raise ParameterError("occupancy", "option select must be threshold or ridge")
        if not 0.0 < float(o["p_min"]) < 1.0:
            raise ParameterError("occupancy", "option p_min must be in (0, 1)")

    def band_width(self, grid: Grid) -> float:
        """Width of the occupied band (m): the ``band`` option or two cells."""
        band = float(self.options["band"])
        return band if band > 0 else 2.0 * grid.cell

    def cover_counts(
        self, beams: Beams, grid: Grid
    ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.int64]]:
        """``(n_occ, n_free)``: readings whose occupied band / free sector covers each cell."""
        tp = beams.poses
        apex, direction, dist = axis_points(
        beams.poses.tx_xy, beams.poses.tx_heading, beams.poses.rx_xy, beams.poses.rx_heading,
        beams.path,
    )  # fmt: skip
        heading = np.arctan2(direction[:, 1], direction[:, 0])
        half = np.minimum(tp.tx_half_beamwidth, tp.rx_half_beamwidth)
        h = 0.5 * self.band_width(grid)
        outer = sector_counts(apex, heading, half, dist + h, grid)
        inner = sector_counts(apex, heading, half, dist - h, grid)
        return outer - inner, inner

    def log_odds_map(self, beams: Beams, grid: Grid) -> npt.NDArray[np.float64]:
        """Log-odds of occupancy of every cell after all readings."""
        n_occ, n_free = self.cover_counts(beams, grid)
        l_occ = log_odds(float(self.options["p_occ"]))
        l_free = log_odds(float(self.options["p_free"]))
        return l_occ * n_occ + l_free * n_free

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        n_occ, n_free = self.cover_counts(beams, grid)
        lo = (
            log_odds(float(self.options["p_occ"])) * n_occ
            + log_odds(float(self.options["p_free"])) * n_free
        )
        prob = 1.0 / (1.0 + np.exp(-np.clip(lo, -50.0, 50.0)))
        keep = lo > log_odds(float(self.options["p_min"]))
        if self.options["select"] == "ridge":
            masked = np.where(keep, lo, -np.inf)
            best = masked.max(axis=0)
            keep &= masked == best[None, :]
        return MethodMap(keep, n_occ.astype(np.uint32), prob)

"""Naive line-of-sight mapping and Borenstein & Koren's histogram grid.

Both put each echo at one point: on the transducer's axis at the measured range (for a
bistatic pair, the echo ellipse's point on the bisector of the two headings,
:func:`~sonarproc.methods.geometry.axis_points`), ignoring the beam's width, which is what
the arcs of the paper's method keep.

* ``line-of-sight`` maps every such point (a cell is set when one point falls in it).
* ``histogram`` is the histogram grid of Borenstein & Koren (VFH, 1991; HIMM): each echo
  adds ``increment`` to the certainty value (CV) of its point's cell and takes
  ``decrement`` from every cell its axis passes on the way there; CVs are clipped to
  ``[0, cv_max]`` and the cells with ``CV >= threshold`` are kept. The sums are taken over
  the whole log at once (order-free; the robot's running clip is applied once at the end).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from sonarproc.errors import ParameterError
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MapMethod, MethodMap, OptionValue
from sonarproc.methods.geometry import axis_points, ray_cells
from sonarproc.params import RunParams

__all__ = ["Histogram", "LineOfSight", "hit_counts"]


def hit_counts(beams: Beams, grid: Grid) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
    """Echo points per cell (``grid.shape``, uint32) and ``(apex, direction, dist)``."""
    apex, direction, dist = axis_points(
        beams.poses.tx_xy, beams.poses.tx_heading, beams.poses.rx_xy, beams.poses.rx_heading,
        beams.path,
    )  # fmt: skip
    pts = apex + dist[:, None] * direction
    ok = np.isfinite(dist)
    iy, ix = grid.to_index(pts[ok, 0], pts[ok, 1])
    inside = grid.contains_index(iy, ix)
    flat = np.bincount(iy[inside] * grid.nx + ix[inside], minlength=grid.ny * grid.nx)
    return flat.reshape(grid.shape).astype(np.uint32), (apex, direction, dist)


class LineOfSight(MapMethod):
    """One point per echo on the beam (bisector) axis at the measured range."""

    name: ClassVar[str] = "line-of-sight"
    summary: ClassVar[str] = "one point per echo on the beam axis (bistatic: bisector)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {}

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        hits, _ = hit_counts(beams, grid)
        return MethodMap(hits > 0, hits)


class Histogram(MapMethod):
    """Borenstein & Koren's histogram grid (certainty values on the beam axis)."""

    name: ClassVar[str] = "histogram"
    summary: ClassVar[str] = "VFH histogram grid: +increment at the echo, -decrement along the axis"
    defaults: ClassVar[Mapping[str, OptionValue]] = {
        "increment": 3,
        "decrement": 1,
        "cv_max": 15,
        "threshold": 3,
    }

    def validate(self) -> None:
        o = self.options
        if not (int(o["increment"]) >= 1 and int(o["decrement"]) >= 0 and int(o["cv_max"]) >= 1):
            raise ParameterError(
                "histogram", "option increment >= 1, decrement >= 0 and cv_max >= 1 needed"
            )
        if not 1 <= int(o["threshold"]) <= int(o["cv_max"]):
            raise ParameterError("histogram", "option threshold must be between 1 and cv_max")

    def certainty(self, beams: Beams, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
        """Clipped certainty values (int64) and echo hits (uint32) per cell."""
        hits, (apex, direction, dist) = hit_counts(beams, grid)
        cv = int(self.options["increment"]) * hits.astype(np.int64)
        dec = int(self.options["decrement"])
        if dec:
            cv -= dec * ray_cells(apex, direction, dist, grid).reshape(grid.shape)
        return np.clip(cv, 0, int(self.options["cv_max"])), hits

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        cv, hits = self.certainty(beams, grid)
        return MethodMap(cv >= int(self.options["threshold"]), hits)

"""Array-in test helpers over the arcs API: each builds the arcs, then calls the package.

The tests were written against seven-argument functions (positions, headings, paths and
half beamwidths in, maps out); these helpers keep that shape for the tests while the
package computes arc geometry once (:func:`sonarproc.arcs.arc_geometry`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs import ArcGeometry, arc_geometry, rasterize
from sonarproc.arcs import arc_cells as cells_of
from sonarproc.arcs import arc_samples as samples_of
from sonarproc.grid import Grid


def arcs(*args: Any, **beams: Any) -> ArcGeometry:
    return arc_geometry(*args, **beams)


def rasterize_arcs(*args: Any, grid: Grid, **beams: Any) -> NDArray[np.uint32]:
    return rasterize(arc_geometry(*args, **beams), grid)


def rasterize_arcs_sampled(
    *args: Any, grid: Grid, step_rad: float, **beams: Any
) -> NDArray[np.uint32]:
    return rasterize(arc_geometry(*args, **beams), grid, method="sampled", step=step_rad)


def arc_bounds(*args: Any, **beams: Any) -> tuple[float, float, float, float]:
    return arc_geometry(*args, **beams).bounds()


def arc_cells(*args: Any, grid: Grid, **beams: Any) -> tuple[Any, Any, Any]:
    return cells_of(arc_geometry(*args, **beams), grid)


def arc_samples(*args: Any, grid: Grid, step_rad: float, **beams: Any) -> tuple[Any, Any, Any]:
    return samples_of(arc_geometry(*args, **beams), grid, step=step_rad)

"""The run without reflector classes or free space, for the benchmarks of what they cost.

:func:`without_free_space` is the run as it was before free space: no silent readings
selected, no cut of walls at openings, no join of pieces, no cut of unseen stretches, the
merge's fixed gap. :func:`without_point_reflectors` is the run without the point
reflectors: no search (every reading left to the walls; on a long log, no coarse count
map made for it either), no corner fitted as a plane, no corner on the walls' lines, no
corner where two walls meet.
Each replaces the functions where the run looks them up and restores them on leaving.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np

from sonarproc.pipeline import selection
from sonarproc.pipeline import surfacefit as surfacefit_module
from sonarproc.surfaces.echoes import refine
from sonarproc.surfaces.reflectors import points as points_module
from sonarproc.surfaces.reflectors.points import ClaimedPoints

__all__ = ["without_free_space", "without_point_reflectors"]


@contextmanager
def without_free_space() -> Iterator[None]:
    """The run as it was before free space: no silent readings, no cut, no join, the
    merge's fixed gap."""
    saved = (refine.cut_openings, refine.join_pieces, refine.merge_collinear)
    saved_unseen = refine.cut_unseen
    saved_silent = selection._silent

    def passthrough(fits: Any, points: Any, readings: Any, cones: Any, **_: Any) -> Any:
        return list(fits), list(points), list(readings)

    def merge(fits: Any, cells: Any, *, cell: float, **_: Any) -> Any:
        return saved[2](fits, cells, cell=cell)

    refine.cut_openings, refine.join_pieces = passthrough, passthrough  # type: ignore[assignment]
    refine.cut_unseen = passthrough  # type: ignore[assignment]
    refine.merge_collinear = merge  # type: ignore[assignment]
    selection._silent = lambda log_: None  # type: ignore[assignment]
    try:
        yield
    finally:
        refine.cut_openings, refine.join_pieces, refine.merge_collinear = saved  # type: ignore[assignment]
        refine.cut_unseen = saved_unseen  # type: ignore[assignment]
        selection._silent = saved_silent  # type: ignore[assignment]


@contextmanager
def without_point_reflectors() -> Iterator[None]:
    """The run without point reflectors: their search, the points fitted as curves, the
    corners fitted as planes, the corners on the walls' lines and where walls meet each
    replaced by one that finds none."""

    def no_points(echoes: Any, *args: Any, **kwargs: Any) -> ClaimedPoints:
        return ClaimedPoints([], np.zeros(echoes.size, dtype=bool))

    saved = (
        surfacefit_module.claim_points,
        surfacefit_module._claim_at_wall_ends,
        points_module.curves_as_points,
        points_module.planes_as_corners,
        points_module.corners_on_wall_lines,
        points_module.corners_where_walls_meet,
    )
    surfacefit_module.claim_points = no_points  # type: ignore[assignment]
    # a long log's search, with the coarse map made for it alone
    surfacefit_module._claim_at_wall_ends = no_points  # type: ignore[assignment]
    points_module.curves_as_points = lambda *a, **k: ([], [])  # type: ignore[assignment]
    points_module.planes_as_corners = lambda *a, **k: ([], [])  # type: ignore[assignment]
    points_module.corners_on_wall_lines = lambda *a, **k: []  # type: ignore[assignment]
    points_module.corners_where_walls_meet = lambda *a, **k: []  # type: ignore[assignment]
    try:
        yield
    finally:
        (
            surfacefit_module.claim_points,
            surfacefit_module._claim_at_wall_ends,
            points_module.curves_as_points,
            points_module.planes_as_corners,
            points_module.corners_on_wall_lines,
            points_module.corners_where_walls_meet,
        ) = saved  # type: ignore[assignment]

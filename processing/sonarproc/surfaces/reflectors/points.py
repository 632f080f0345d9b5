"""Point reflectors in a surface map: found before the walls, reported beside them.

The surface stage runs in two steps round the walls' echo refits:

1. :func:`claim_points` finds the point reflectors
   (:func:`~sonarproc.surfaces.reflectors.rcd.find_point_features`) and says which
   readings they explain. Those readings are kept out of the walls' fits: the specular
   echo point of a corner's or an edge's reading lies along its beam's axis, not on any
   surface, and through a bundle of them a line would be fitted (the diagonal phantom
   lines through a corner's arcs).
2. :func:`refine_with_points` refits the surfaces without those readings, checks each
   point against the fitted surfaces (:mod:`sonarproc.surfaces.reflectors.confirm`),
   drops those in a row (:func:`~sonarproc.surfaces.reflectors.walls.in_rows`: samples
   of a diffusely scattering surface), ends each wall fitted past a point at that point
   (:func:`~sonarproc.surfaces.reflectors.complete.trim_to_points`: the points are
   checked against the walls so ended), turns an arc or a spline fitted through the arcs
   of a point heard over a narrow spread of bearings, where a wall's line ends, into that
   point (:func:`~sonarproc.surfaces.reflectors.curve_points.curves_as_points`), and a
   plane fitted through a corner's arcs into that corner
   (:func:`~sonarproc.surfaces.reflectors.corner_planes.planes_as_corners`: the ranges
   alone cannot tell them apart, the walls' lines can), looks on the walls' lines for the
   corners such readings make when no plane was fitted through them
   (:func:`~sonarproc.surfaces.reflectors.line_corners.corners_on_wall_lines`), places
   the corners whose readings a wall seen head on explains where their two fitted walls
   meet (:func:`~sonarproc.surfaces.reflectors.wall_meets.corners_where_walls_meet`:
   ``corner`` by construction; the head-on wall fitted past one ends there), gives
   each other point its kind
   (:mod:`sonarproc.surfaces.reflectors.classify`), then appends it to the surfaces
   as a :class:`~sonarproc.surfaces.fitting.models.SurfaceFit` of model ``corner`` or
   ``edge``: a polyline of one point, length 0, ``support`` its readings, ``arcs`` its
   distinct sensor positions, ``rms_m`` its RMS range residual, and ``params``
   ``position``, ``readings``, ``poses``, ``plane_rms_m`` and ``span_rad``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid
from sonarproc.surfaces.echoes.specular import EchoGeometry, SurfaceEchoes, echo_points
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.classify import point_kind
from sonarproc.surfaces.reflectors.complete import complete_to_corners, trim_to_points
from sonarproc.surfaces.reflectors.confirm import (
    confirm_points,
    heard_as_corner,
    line_ends,
    on_circles,
)
from sonarproc.surfaces.reflectors.corner_planes import planes_as_corners
from sonarproc.surfaces.reflectors.curve_points import curves_as_points
from sonarproc.surfaces.reflectors.line_corners import corners_on_wall_lines
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M
from sonarproc.surfaces.reflectors.rcd import PointFeature, find_point_features
from sonarproc.surfaces.reflectors.wall_meets import corners_where_walls_meet
from sonarproc.surfaces.reflectors.walls import END_REACH_M, in_rows, inside_walls, on_wall_lines

FloatArray = npt.NDArray[np.float64]

__all__ = ["POINT_MODELS", "ClaimedPoints", "claim_points", "point_fit", "refine_with_points"]

#: The models (and kinds) of point reflectors.
POINT_MODELS = ("corner", "edge")


@dataclass(frozen=True, eq=False)
class ClaimedPoints:
    """Point reflectors found in the readings, and the readings they explain."""

    points: list[PointFeature]
    #: true for every reading of ``echoes`` a point explains
    claimed: npt.NDArray[np.bool_]


def claim_points(
    echoes: EchoGeometry,
    counts: npt.ArrayLike,
    grid: Grid,
    *,
    free: npt.NDArray[np.bool_] | None = None,
    walls: list[tuple[FloatArray, FloatArray]] | None = None,
    ends_only: bool = False,
) -> ClaimedPoints:
    """The point reflectors of the readings and the readings they explain (module notes).

    Parameters
    ----------
    echoes : EchoGeometry
        The readings.
    counts : array_like of int
        The arc count map the candidates come from.
    grid : Grid
        Its grid.
    free : ndarray of bool, optional
        The readings a point may take (default: all; not those of walls found already).
    walls : list of (ndarray, ndarray), optional
        The ends of walls found already: no point is looked for inside them
        (:func:`~sonarproc.surfaces.reflectors.walls.inside_walls`: a wall that scatters
        diffusely would give a point at every place of it).
    ends_only : bool
        Look only near the ``walls``' ends, where corners and edges are (a long log's
        walls come from its readings, and what they leave goes to the map).

    Returns
    -------
    ClaimedPoints
    """
    skip, around = None, None
    if walls is not None:
        known = list(walls)
        if ends_only:
            around = np.array([e for w in known for e in w], dtype=np.float64).reshape(-1, 2)

        def skip(xy: FloatArray) -> npt.NDArray[np.bool_]:
            return inside_walls(xy, known)

    points = find_point_features(echoes, counts, grid, free=free, skip=skip, around=around,
                                 reach=END_REACH_M)  # fmt: skip
    claimed = np.zeros(echoes.size, dtype=bool)
    for p in points:
        claimed[p.readings] = True
    return ClaimedPoints(points, claimed)


def point_fit(point: PointFeature, kind: str) -> SurfaceFit:
    """A point reflector as a surface of one point (module notes).

    Examples
    --------
    >>> f = PointFeature(np.array([1.0, 2.0]), np.arange(9), 7, 0.008, 0.1, 1.2)
    >>> s = point_fit(f, "corner")
    >>> s.model, s.polyline.tolist(), s.length_m, s.support, s.arcs
    ('corner', [[1.0, 2.0]], 0.0, 9, 7)
    """
    xy = np.asarray(point.xy, dtype=np.float64).reshape(1, 2)
    params = {
        "position": [float(xy[0, 0]), float(xy[0, 1])],
        "readings": point.support,
        "poses": int(point.poses),
        "plane_rms_m": float(point.plane_rms_m),
        "span_rad": float(point.span_rad),
    }
    return SurfaceFit(kind, xy, 0.0, float(point.rms_m), point.support, int(point.poses),
                      False, params)  # fmt: skip


def refine_with_points(
    refine: Callable[[EchoGeometry], tuple[list[SurfaceFit], list[SurfaceCells]]],
    echoes: EchoGeometry,
    found: ClaimedPoints,
    *,
    exclude: bool = True,
) -> tuple[list[SurfaceFit], list[SurfaceCells]]:
    """The surfaces refitted without the points' readings, then the confirmed points.

    ``refine`` refits the surfaces through the readings it is given. It is given the
    readings no point claimed; the points are then checked against its surfaces
    (:func:`~sonarproc.surfaces.reflectors.confirm.confirm_points`; those in a row,
    :func:`~sonarproc.surfaces.reflectors.walls.in_rows`, go too). When some point goes,
    its readings were a surface's after all, and the surfaces are refitted once more
    without the readings of the points that stay only.

    Parameters
    ----------
    refine : callable
        ``refine(readings) -> (fits, cells)``.
    echoes : EchoGeometry
        The readings.
    found : ClaimedPoints
        From :func:`claim_points` on the same ``echoes``.
    exclude : bool
        Refit without the points' readings (default). A long log's walls, found from
        the readings' tangent votes, need not: its surfaces to refit were found without
        the points' readings already, and a reading echoes from a surface only at the
        foot of its perpendicular, which a point's reading is not.

    Returns
    -------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        The surfaces, then each point as one more surface (its cell its position).
    """
    exclude = exclude and bool(found.points)
    fits, cells = refine(echoes.subset(~found.claimed) if exclude else echoes)
    # a wall fitted past a point ends there (its stretch beyond is the point's echoes)
    kept = confirm_points(found.points, echoes, trim_to_points(fits, _positions(found.points)))
    if kept:
        rows = in_rows(np.array([p.xy for _, p in kept]))
        kept = [kp for kp, r in zip(kept, rows.tolist(), strict=True) if not r]
    if exclude and len(kept) < len(found.points):
        claimed = np.zeros(echoes.size, dtype=bool)
        for k, _ in kept:
            claimed[found.points[k].readings] = True
        fits, cells = refine(echoes.subset(~claimed))
        # a point is where a plane ends: one of the first fits may have gone
        walls = line_ends(fits)
        kept = [(k, p) for k, p in kept if _still_a_point(p, echoes, fits, walls)]
    fits = trim_to_points(fits, _positions([p for _, p in kept]))
    # the readings each surface explains, which the conversions and the line search ask:
    # found once, and again only when a surface goes (a first echo depends on every one)
    got = _echoes_of(fits, echoes)
    # a point heard over a narrow spread of bearings was fitted as an arc or a spline, or
    # (a corner) as a plane through it
    for as_points in (curves_as_points, planes_as_corners):
        gone, found_here = as_points(fits, echoes, got=got)
        if gone:
            fits = [f for k, f in enumerate(fits) if k not in gone]
            cells = [c for k, c in enumerate(cells) if k not in gone]
            kept += [(-1, p) for p in found_here]
            got = _echoes_of(fits, echoes)
    # a corner whose ranges a plane explains as well, and that no plane was fitted to
    kept += [(-1, p) for p in corners_on_wall_lines(fits, echoes, [p for _, p in kept], got=got)]
    # a corner whose readings a head-on wall owns, where its other wall was fitted too
    met = corners_where_walls_meet(fits, echoes, [p for _, p in kept])
    kinds = [(p, point_kind(p, echoes, fits)) for _, p in kept] + [(p, "corner") for p in met]
    # the head-on wall fitted past such a corner ends there
    out, out_cells = trim_to_points(fits, _positions(met)), list(cells)
    for p, kind in kinds:
        out.append(point_fit(p, kind))
        one = np.ones(1)
        out_cells.append(SurfaceCells(p.xy[:1].copy(), p.xy[1:].copy(), np.zeros(1), one, False))
    # a wall found short of the corner it runs into ends there
    return complete_to_corners(out, echoes), out_cells


def _echoes_of(fits: list[SurfaceFit], echoes: EchoGeometry) -> list[SurfaceEchoes] | None:
    """``echo_points`` of the fitted surfaces at :data:`RANGE_TOL_M` (None: no surfaces)."""
    if not fits:
        return None
    polylines, closed = [f.polyline for f in fits], [f.closed for f in fits]
    return echo_points(polylines, closed, echoes, tol=RANGE_TOL_M)


def _positions(points: list[PointFeature]) -> FloatArray:
    """The points' positions, (P, 2)."""
    return np.array([p.xy for p in points], dtype=np.float64).reshape(-1, 2)


def _still_a_point(
    p: PointFeature,
    echoes: EchoGeometry,
    fits: list[SurfaceFit],
    walls: list[tuple[FloatArray, FloatArray]],
) -> bool:
    """After a refit: off every fitted arc's circle, where a plane ends or heard as a corner.

    Every point given ended a plane of the first fit (:func:`confirm_points`); a
    retro-reflecting corner (:func:`heard_as_corner`) keeps its place when the refit
    without its readings loses that plane (a door recess's back wall, seen head on from
    a few poses only).
    """
    if on_circles(p.xy, fits, (echoes.xy[p.readings], echoes.range_m[p.readings])):
        return False
    return bool(walls and on_wall_lines(p.xy, walls)[0]) or heard_as_corner(p, echoes, walls)

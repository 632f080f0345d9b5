"""Point reflectors in a surface map: found before the walls, reported beside them.

The surface stage runs in two steps round the walls' echo refits:

1. :func:`claim_points` finds the point reflectors
   (:func:`~sonarproc.surfaces.reflectors.rcd.find_point_features`) and says which
   readings they explain. Those readings are kept out of the walls' fits: the specular
   echo point of a corner's or an edge's reading lies along its beam's axis, not on any
   surface, and through a bundle of them a line would be fitted (the diagonal phantom
   lines through a corner's arcs).
2. :func:`add_points` checks each point against the fitted surfaces and gives it its
   kind (:mod:`sonarproc.surfaces.reflectors.classify`), then appends it to the surfaces
   as a :class:`~sonarproc.surfaces.fitting.models.SurfaceFit` of model ``corner`` or
   ``edge``: a polyline of one point, length 0, ``support`` its readings, ``arcs`` its
   distinct sensor positions, ``rms_m`` its RMS range residual, and ``params``
   ``position``, ``readings``, ``poses``, ``plane_rms_m`` and ``span_rad``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.classify import confirm_points, point_kind
from sonarproc.surfaces.reflectors.rcd import PointFeature, find_point_features
from sonarproc.surfaces.reflectors.walls import END_REACH_M, inside_walls

FloatArray = npt.NDArray[np.float64]

__all__ = ["POINT_MODELS", "ClaimedPoints", "add_points", "claim_points", "point_fit"]

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
        The ends of walls found already: points are looked for only near their ends
        (:func:`~sonarproc.surfaces.reflectors.walls.near_ends`), where corners and edges
        are (the rest of a long log's readings go to the map).

    Returns
    -------
    ClaimedPoints
    """
    skip, around = None, None
    if walls is not None:
        known = list(walls)
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


def add_points(
    fits: list[SurfaceFit],
    cells: list[SurfaceCells],
    found: ClaimedPoints,
    echoes: EchoGeometry,
) -> tuple[list[SurfaceFit], list[SurfaceCells]]:
    """The fitted surfaces followed by the confirmed, classified point reflectors.

    Parameters
    ----------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        The fitted surfaces (without the points' readings) and their cells.
    found : ClaimedPoints
        From :func:`claim_points` on the same ``echoes``.
    echoes : EchoGeometry
        The readings.

    Returns
    -------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        Each point is one more surface, its cell its position.
    """
    points = confirm_points(found.points, echoes, fits)
    out, out_cells = list(fits), list(cells)
    for p in points:
        out.append(point_fit(p, point_kind(p, echoes, fits)))
        one = np.ones(1)
        out_cells.append(SurfaceCells(p.xy[:1].copy(), p.xy[1:].copy(), np.zeros(1), one, False))
    return out, out_cells

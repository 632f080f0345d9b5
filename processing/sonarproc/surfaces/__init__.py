"""Several surfaces from one arc map: a ridge that keeps every wall, extraction, fits.

The paper fits one curve y = f(x) through every kept cell. A robot in a corridor or a
room sees several walls, corners, boxes and pillars; this package finds them separately:

1. :func:`ridge_nms` thins the arc-count map across each ridge's own direction (every
   wall survives, whatever its direction);
2. :func:`find_surfaces` splits the kept cells into surfaces (gaps bridged, corners
   cut, each ordered along its length) and fits each with a line, an arc or a spline
   (:func:`fit_surface`, model chosen by a stated criterion);
3. :func:`decide` says whether the cells are after all one function of x (the paper's
   scenes, where the paper's polynomial applies);
   then :func:`refine_fits` refits each through its readings' specular echo points
   (the crest of the counts lies on the sensors' side of a surface);
4. :func:`surface_metrics` and :func:`seen_truth` measure fits against a multi-surface
   truth; :func:`write_surfaces_csv` and :func:`write_surfaces_geojson` write them.

The subpackages, by job: :mod:`.extraction` (ridge, paths, corners), :mod:`.fitting`
(lines, arcs, splines and the choice), :mod:`.echoes` (echo points, the one
implementation, and the refits through them), :mod:`.evaluation` (truth, seen, writers);
:mod:`.planar` is the plane geometry they share. Each imports only from those before it
in the order planar, extraction, fitting, echoes, evaluation.
"""

from sonarproc.surfaces.echoes.refine import refine_fits
from sonarproc.surfaces.echoes.specular import (
    EchoGeometry,
    SurfaceEchoes,
    count_seen_through,
    echo_points,
)
from sonarproc.surfaces.evaluation.truth import (
    SurfaceMetrics,
    seen_truth,
    surface_metrics,
    truth_is_function,
    truth_points,
)
from sonarproc.surfaces.evaluation.writers import write_surfaces_csv, write_surfaces_geojson
from sonarproc.surfaces.extraction.extract import SurfaceCells, SurfaceParams, extract_surfaces
from sonarproc.surfaces.extraction.ridge import ridge_nms
from sonarproc.surfaces.find import Decision, SurfaceSet, decide, find_surfaces
from sonarproc.surfaces.fitting.batch import fit_surface, fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit
from sonarproc.surfaces.planar.polylines import (
    distance_to_polylines,
    join_polylines,
    split_polylines,
)

__all__ = [
    "Decision",
    "EchoGeometry",
    "SurfaceCells",
    "SurfaceEchoes",
    "SurfaceFailure",
    "SurfaceFit",
    "SurfaceMetrics",
    "SurfaceParams",
    "SurfaceSet",
    "count_seen_through",
    "decide",
    "distance_to_polylines",
    "echo_points",
    "extract_surfaces",
    "find_surfaces",
    "fit_surface",
    "fit_surfaces",
    "join_polylines",
    "refine_fits",
    "ridge_nms",
    "seen_truth",
    "split_polylines",
    "surface_metrics",
    "truth_is_function",
    "truth_points",
    "write_surfaces_csv",
    "write_surfaces_geojson",
]

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

The names below are loaded on first use (a module ``__getattr__``): importing one
submodule (a map method's :class:`SurfaceFit`, say) then does not load the extraction,
the reflectors and their scipy solvers, a third of a second in a fresh process, in a run
that never fits surfaces (``--fit polar``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sonarproc.lazy import lazy_names

if TYPE_CHECKING:
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

#: Where each public name is defined.
_WHERE: dict[str, str] = {
    "refine_fits": "sonarproc.surfaces.echoes.refine",
    "EchoGeometry": "sonarproc.surfaces.echoes.specular",
    "SurfaceEchoes": "sonarproc.surfaces.echoes.specular",
    "count_seen_through": "sonarproc.surfaces.echoes.specular",
    "echo_points": "sonarproc.surfaces.echoes.specular",
    "SurfaceMetrics": "sonarproc.surfaces.evaluation.truth",
    "seen_truth": "sonarproc.surfaces.evaluation.truth",
    "surface_metrics": "sonarproc.surfaces.evaluation.truth",
    "truth_is_function": "sonarproc.surfaces.evaluation.truth",
    "truth_points": "sonarproc.surfaces.evaluation.truth",
    "write_surfaces_csv": "sonarproc.surfaces.evaluation.writers",
    "write_surfaces_geojson": "sonarproc.surfaces.evaluation.writers",
    "SurfaceCells": "sonarproc.surfaces.extraction.extract",
    "SurfaceParams": "sonarproc.surfaces.extraction.extract",
    "extract_surfaces": "sonarproc.surfaces.extraction.extract",
    "ridge_nms": "sonarproc.surfaces.extraction.ridge",
    "Decision": "sonarproc.surfaces.find",
    "SurfaceSet": "sonarproc.surfaces.find",
    "decide": "sonarproc.surfaces.find",
    "find_surfaces": "sonarproc.surfaces.find",
    "fit_surface": "sonarproc.surfaces.fitting.batch",
    "fit_surfaces": "sonarproc.surfaces.fitting.batch",
    "SurfaceFailure": "sonarproc.surfaces.fitting.models",
    "SurfaceFit": "sonarproc.surfaces.fitting.models",
    "distance_to_polylines": "sonarproc.surfaces.planar.polylines",
    "join_polylines": "sonarproc.surfaces.planar.polylines",
    "split_polylines": "sonarproc.surfaces.planar.polylines",
}

__getattr__ = lazy_names(__name__, _WHERE)

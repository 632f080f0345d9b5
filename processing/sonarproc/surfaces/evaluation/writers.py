"""Output files of fitted surfaces: ``surfaces.csv`` and ``surfaces.geojson``.

* ``surfaces.csv``: header ``surface,kind,x,y`` (Contract 2, v3; v2 files have no
  ``kind``); one polyline per surface id, points in order along the surface, sampled at
  the cell size (a closed surface repeats its first point); a point reflector (``corner``,
  ``edge``) is one row, its position.
* ``surfaces.geojson``: a FeatureCollection in the log's world frame (m, rounded to the
  micrometre): a LineString per surface, a Point per point reflector; properties
  ``surface``, ``kind``, ``model``, ``length_m``, ``rms_m``, ``support`` (and ``arcs``,
  ``closed``; a point's ``support`` is its readings, ``arcs`` its distinct poses).

Surface ids are the positions in the list given (longest first from
:func:`~sonarproc.surfaces.find_surfaces`), the same as in :meth:`SurfaceSet.to_json`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.surfaces.fitting.models import SurfaceFit

#: The reflector kind of each model (Contract 2, v3): a straight wall is a plane, a
#: circular arc a cylinder's section, a spline a free curve; corners and edges are points.
MODEL_KINDS = {"line": "plane", "arc": "cylinder", "spline": "curve",
               "corner": "corner", "edge": "edge"}  # fmt: skip
#: The kinds reported as one point.
POINT_KINDS = ("corner", "edge")

__all__ = [
    "MODEL_KINDS",
    "POINT_KINDS",
    "kind_of",
    "surfaces_geojson",
    "write_surfaces_csv",
    "write_surfaces_geojson",
]


def kind_of(model: str | None) -> str:
    """The reflector kind of a surface's model (``curve`` for anything unknown).

    >>> kind_of("line"), kind_of("arc"), kind_of("corner"), kind_of(None)
    ('plane', 'cylinder', 'corner', 'curve')
    """
    return MODEL_KINDS.get(str(model), "curve")


def write_surfaces_csv(surfaces: Sequence[SurfaceFit], path: str | Path) -> Path:
    """Write ``surface,kind,x,y`` rows, one polyline per surface in order; return the path.

    Examples
    --------
    >>> import tempfile
    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> f = SurfaceFit("line", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.0, 50, 50)
    >>> c = SurfaceFit("corner", np.array([[2.0, 3.0]]), 0.0, 0.01, 12, 9)
    >>> p = write_surfaces_csv([f, c], Path(tempfile.mkdtemp()) / "surfaces.csv")
    >>> p.read_text().splitlines()
    ['surface,kind,x,y', '0,plane,0,1', '0,plane,0.5,1', '1,corner,2,3']
    """
    p = Path(path)
    lines = ["surface,kind,x,y"]
    for i, s in enumerate(surfaces):
        pts = np.asarray(s.polyline, dtype=np.float64).reshape(-1, 2)
        if s.model in POINT_KINDS:
            pts = pts[:1]
        # (printf-style formatting of tuples is the fastest)
        row = f"{i},{kind_of(s.model)},%.6g,%.6g".__mod__
        lines.extend(map(row, map(tuple, pts.tolist())))
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def surfaces_geojson(surfaces: Sequence[SurfaceFit]) -> dict[str, Any]:
    """The FeatureCollection as a JSON-ready dict.

    Examples
    --------
    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> f = SurfaceFit("arc", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.002, 50, 80)
    >>> doc = surfaces_geojson([f, SurfaceFit("edge", np.array([[1.0, 2.0]]), 0.0, 0.01, 9, 7)])
    >>> [(g["geometry"]["type"], g["properties"]["kind"]) for g in doc["features"]]
    [('LineString', 'cylinder'), ('Point', 'edge')]
    """
    features = []
    for i, s in enumerate(surfaces):
        pts = np.round(np.asarray(s.polyline, dtype=np.float64).reshape(-1, 2), 6)
        point = s.model in POINT_KINDS or pts.shape[0] == 1
        geometry = (
            {"type": "Point", "coordinates": pts[0].tolist()}
            if point
            else {"type": "LineString", "coordinates": pts.tolist()}
        )
        features.append(
            {
                "type": "Feature",
                "geometry": geometry,
                "properties": {
                    "surface": i,
                    "kind": kind_of(s.model),
                    "model": s.model,
                    "length_m": float(s.length_m),
                    "rms_m": float(s.rms_m),
                    "support": int(s.support),
                    "arcs": int(s.arcs),
                    "closed": bool(s.closed),
                },
            }
        )
    return {"type": "FeatureCollection", "features": features}


def write_surfaces_geojson(surfaces: Sequence[SurfaceFit], path: str | Path) -> Path:
    """Write :func:`surfaces_geojson` to ``path``, one feature per line; return the path.

    (Indented JSON puts every coordinate on a line of its own and goes through the
    pure-Python encoder: a room's surfaces hold tens of thousands of points.)

    Examples
    --------
    >>> import tempfile
    >>> f = SurfaceFit("line", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.0, 50, 50)
    >>> p = write_surfaces_geojson([f, f], Path(tempfile.mkdtemp()) / "s.geojson")
    >>> len(p.read_text().splitlines()), len(json.loads(p.read_text())["features"])
    (4, 2)
    """
    p = Path(path)
    doc = surfaces_geojson(surfaces)
    features = ",\n".join(json.dumps(f) for f in doc["features"])
    body = '{"type": "FeatureCollection", "features": [\n' + features + "\n]}\n"
    p.write_text(body, encoding="utf-8")
    return p

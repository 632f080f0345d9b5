"""Output files of fitted surfaces: ``surfaces.csv`` and ``surfaces.geojson``.

* ``surfaces.csv``: header ``surface,x,y``; one polyline per surface id, points in order
  along the surface, sampled at the cell size (a closed surface repeats its first point).
* ``surfaces.geojson``: a FeatureCollection of LineStrings in the log's world frame (m,
  rounded to the micrometre), properties ``surface``, ``model``, ``length_m``,
  ``rms_m``, ``support`` (and ``arcs``, ``closed``).

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

__all__ = ["surfaces_geojson", "write_surfaces_csv", "write_surfaces_geojson"]


def write_surfaces_csv(surfaces: Sequence[SurfaceFit], path: str | Path) -> Path:
    """Write ``surface,x,y`` rows, one polyline per surface in order; return the path.

    Examples
    --------
    >>> import tempfile
    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> f = SurfaceFit("line", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.0, 50, 50)
    >>> p = write_surfaces_csv([f], Path(tempfile.mkdtemp()) / "surfaces.csv")
    >>> p.read_text().splitlines()
    ['surface,x,y', '0,0,1', '0,0.5,1']
    """
    p = Path(path)
    lines = ["surface,x,y"]
    for i, s in enumerate(surfaces):
        row = f"{i},%.6g,%.6g".__mod__  # (printf-style formatting of tuples is the fastest)
        lines.extend(map(row, map(tuple, np.asarray(s.polyline).tolist())))
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def surfaces_geojson(surfaces: Sequence[SurfaceFit]) -> dict[str, Any]:
    """The FeatureCollection as a JSON-ready dict.

    Examples
    --------
    >>> from sonarproc.surfaces.fitting.models import SurfaceFit
    >>> f = SurfaceFit("arc", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.002, 50, 80)
    >>> doc = surfaces_geojson([f])
    >>> doc["features"][0]["geometry"]["type"], doc["features"][0]["properties"]["model"]
    ('LineString', 'arc')
    """
    features = []
    for i, s in enumerate(surfaces):
        features.append(
            {
                "type": "Feature",
                "geometry": {
                    "type": "LineString",
                    "coordinates": np.round(np.asarray(s.polyline, dtype=np.float64), 6).tolist(),
                },
                "properties": {
                    "surface": i,
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

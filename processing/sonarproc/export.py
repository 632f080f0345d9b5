"""Exports of a method's map for robotics tools: ROS map_server, GeoJSON, PLY.

* **ros-map**: ``NAME.pgm`` + ``NAME.yaml`` in ROS ``map_server`` form (ROS 1 and the
  ROS 2 nav2 map server read the same pair). The PGM is binary (``P5``), header exactly
  ``P5\\n<width> <height>\\n255\\n``, first row = the top of the map (largest y); pixels are
  0 (occupied), 254 (free) and 205 (unknown). The YAML gives ``resolution`` (the cell),
  ``origin`` (the lower-left corner of the lower-left pixel, m, yaw 0), ``negate: 0``,
  ``occupied_thresh: 0.65``, ``free_thresh: 0.196`` and ``mode: trinary``; map_server's
  occupancy of a pixel is ``(255 - v) / 255``, so 0 reads as occupied, 254 as free and
  205 (0.196...) as unknown. A probabilistic method (``occupancy``) exports its p(occupied)
  with those thresholds; the others export their processed cells as occupied and all
  else as unknown. The fitted surfaces (or the one fitted curve) are drawn over it as
  occupied cells, each polyline rasterised at the map's resolution.
* **geojson**: the fitted surfaces in the map frame (x, y in m; *not* WGS 84
  longitude/latitude, which RFC 7946 assumes: tools must treat it as a local planar
  frame): one ``LineString`` per surface with ``surface, model, kind, length_m, rms_m,
  support`` (a surface of one point, a corner or an edge, is a ``Point``), or the one
  fitted profile as a ``LineString``; the method and the metrics are the collection's
  properties.
* **ply**: the processed cells as a binary little-endian PLY point cloud (element
  ``vertex``: ``float x, y, z`` with z = 0, and ``uint evidence``), readable by Open3D,
  CloudCompare, PCL and MeshLab, then the fitted surfaces as a second element
  ``surface_point`` (``float x, y, z``, ``int surface``: the polylines' points in order,
  each with its surface id; readers that know only ``vertex`` skip it).
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.errors import InputError, ParameterError
from sonarproc.fit import FitFailure
from sonarproc.grid import Grid
from sonarproc.methods.base import MethodResult
from sonarproc.surfaces import SurfaceFit

__all__ = [
    "FORMATS",
    "FREE",
    "OCCUPIED",
    "UNKNOWN",
    "parse_formats",
    "read_pgm",
    "read_ply",
    "read_ros_map",
    "ros_map_image",
    "surface_cells",
    "write_exports",
    "write_geojson",
    "write_ply",
    "write_ros_map",
]

FORMATS = ("ros-map", "geojson", "ply", "rosbag2")
OCCUPIED, FREE, UNKNOWN = 0, 254, 205
OCCUPIED_THRESH = 0.65
FREE_THRESH = 0.196


def parse_formats(text: str) -> list[str]:
    """Split ``"ros-map,geojson"`` into known format names.

    Examples
    --------
    >>> parse_formats("geojson, ros-map")
    ['geojson', 'ros-map']
    """
    names = list(dict.fromkeys(p.strip().lower() for p in text.split(",") if p.strip()))
    bad = [n for n in names if n not in FORMATS]
    if bad or not names:
        raise ParameterError("formats", f"must be among {', '.join(FORMATS)}, got {text!r}")
    return names


def ros_map_image(result: MethodResult) -> npt.NDArray[np.uint8]:
    """The map as map_server pixels, indexed ``[iy, ix]`` like the grid (row 0 = lowest y).

    The method's map (p(occupied) thresholded, or its processed cells occupied), with the
    fitted surfaces drawn over it as occupied cells (:func:`surface_cells`): a planner
    reading the map sees the walls the run found, unbroken.
    """
    run = result.run
    if result.probability is not None:
        p = result.probability
        img = np.full(p.shape, UNKNOWN, dtype=np.uint8)
        img[p > OCCUPIED_THRESH] = OCCUPIED
        img[p < FREE_THRESH] = FREE
    else:
        img = np.full(run.processed.shape, UNKNOWN, dtype=np.uint8)
        img[run.processed] = OCCUPIED
    iy, ix = surface_cells(fitted_polylines(result), run.grid)
    img[iy, ix] = OCCUPIED
    return img


def surface_cells(
    polylines: Sequence[npt.NDArray[np.float64]], grid: Grid
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """The grid cells ``(iy, ix)`` the polylines pass through, each segment rasterised.

    Consecutive points are joined by :func:`skimage.draw.line` in cell indices (a
    polyline sampled every cell leaves no gap); cells off the grid are dropped, and each
    cell is given once, in row-major order.

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=1.0, nx=5, ny=3)
    >>> iy, ix = surface_cells([np.array([[0.0, 1.0], [4.0, 1.0]])], g)
    >>> ix.tolist(), iy.tolist()
    ([0, 1, 2, 3, 4], [1, 1, 1, 1, 1])
    """
    from skimage.draw import line

    rows: list[npt.NDArray[np.intp]] = []
    cols: list[npt.NDArray[np.intp]] = []
    for poly in polylines:
        pts = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
        pts = pts[np.isfinite(pts).all(axis=1)]
        if pts.shape[0] == 0:
            continue
        iy, ix = grid.to_index(pts[:, 0], pts[:, 1])
        rows.append(iy)
        cols.append(ix)
        # a segment longer than the grid is no sampled surface (it would only cost memory)
        longest = 2 * (grid.nx + grid.ny)
        for k in range(pts.shape[0] - 1):
            if max(abs(int(iy[k + 1] - iy[k])), abs(int(ix[k + 1] - ix[k]))) > longest:
                continue
            rr, cc = line(int(iy[k]), int(ix[k]), int(iy[k + 1]), int(ix[k + 1]))
            rows.append(rr.astype(np.intp))
            cols.append(cc.astype(np.intp))
    if not rows:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    iy_all, ix_all = np.concatenate(rows), np.concatenate(cols)
    inside = grid.contains_index(iy_all, ix_all)
    flat = np.unique(iy_all[inside] * grid.nx + ix_all[inside])  # each cell once, row-major
    return flat // grid.nx, flat % grid.nx


def write_ros_map(result: MethodResult, stem: str | Path) -> tuple[Path, Path]:
    """Write ``STEM.pgm`` and ``STEM.yaml``; return both paths."""
    stem = Path(stem)
    img = ros_map_image(result)
    g = result.run.grid
    pgm, yml = stem.with_suffix(".pgm"), stem.with_suffix(".yaml")
    header = f"P5\n{g.nx} {g.ny}\n255\n".encode("ascii")
    pgm.write_bytes(header + np.ascontiguousarray(img[::-1]).tobytes())
    ox, _, oy, _ = g.extent
    yml.write_text(
        f"image: {pgm.name}\n"
        "mode: trinary\n"
        f"resolution: {g.cell:.10g}\n"
        f"origin: [{ox:.10g}, {oy:.10g}, 0.0]\n"
        "negate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\n"
        f"free_thresh: {FREE_THRESH}\n",
        encoding="utf-8",
    )
    return pgm, yml


def read_pgm(path: str | Path) -> npt.NDArray[np.uint8]:
    """Read a binary 8-bit PGM (``P5``, maxval 255); rows top first."""
    data = Path(path).read_bytes()
    parts = data.split(b"\n", 3)
    if len(parts) < 4 or parts[0] != b"P5" or parts[2] != b"255":
        raise InputError(f"{path}: not an 8-bit binary PGM with a plain header")
    w, h = (int(v) for v in parts[1].split())
    pix = np.frombuffer(parts[3], dtype=np.uint8)
    if pix.size != w * h:
        raise InputError(f"{path}: expected {w * h} pixels, found {pix.size}")
    return pix.reshape(h, w)


def read_ros_map(yaml_path: str | Path) -> tuple[Grid, npt.NDArray[np.uint8]]:
    """Read a map written by :func:`write_ros_map`: its grid and pixels ``[iy, ix]``."""
    import yaml

    p = Path(yaml_path)
    meta = yaml.safe_load(p.read_text(encoding="utf-8"))
    img = read_pgm(p.parent / meta["image"])[::-1]
    cell = float(meta["resolution"])
    ox, oy = float(meta["origin"][0]), float(meta["origin"][1])
    grid = Grid(x0=ox + 0.5 * cell, y0=oy + 0.5 * cell, cell=cell, nx=img.shape[1], ny=img.shape[0])
    return grid, np.ascontiguousarray(img)


def geojson_profile(result: MethodResult) -> dict[str, Any]:
    """The fitted surfaces as a GeoJSON FeatureCollection (map frame).

    One feature per surface (:func:`surface_feature`), numbered 0..N-1 as in
    ``surfaces.csv``; without surfaces, the one fitted profile as a ``LineString``; no
    feature (and ``fit_failure``) when the fit failed.
    """
    from sonarproc.report.jsonable import to_jsonable

    run = result.run
    props: dict[str, Any] = {
        "method": result.method,
        "source": run.source,
        "frame": "map",
        "units": "m",
        "fit": "surfaces" if result.surfaces else run.fit.kind,
        "fit_order": None if result.surfaces else run.fit.order,
        **run.metrics.to_json(),
        **(run.surface_metrics or {}),
        "surfaces": len(result.surfaces),
        "t_cpu_s": run.t_cpu_s,
    }
    features: list[dict[str, Any]] = []
    if result.surfaces:
        features = [surface_feature(k, s) for k, s in enumerate(result.surfaces)]
    elif not isinstance(run.fit, FitFailure):
        pts = run.fit.sample(run.grid.cell)
        coords = np.round(pts, 6).tolist()
        features.append(
            {
                "type": "Feature",
                "geometry": {"type": "LineString", "coordinates": coords},
                "properties": props,
            }
        )
    else:
        props["fit_failure"] = run.fit.reason
    return dict(
        to_jsonable({"type": "FeatureCollection", "features": features, "properties": props})
    )


def surface_feature(surface: int, fit: SurfaceFit) -> dict[str, Any]:
    """One surface as a GeoJSON feature: a ``LineString``, or a ``Point`` when it is one point.

    A surface reduced to one point (a corner or an edge: a reflector with no extent) is a
    ``Point``; ``kind`` is the reflector kind its model implies (Contract 2, v3).

    Examples
    --------
    >>> from sonarproc.surfaces import SurfaceFit
    >>> wall = SurfaceFit("line", np.array([[0.0, 1.0], [0.5, 1.0]]), 0.5, 0.002, 50, 80)
    >>> f = surface_feature(0, wall)
    >>> f["geometry"]["type"], f["properties"]["kind"], f["properties"]["length_m"]
    ('LineString', 'plane', 0.5)
    >>> corner = SurfaceFit("corner", np.array([[2.0, 3.0]]), 0.0, 0.001, 12, 40)
    >>> g = surface_feature(1, corner)
    >>> g["geometry"], g["properties"]["kind"]
    ({'type': 'Point', 'coordinates': [2.0, 3.0]}, 'corner')
    """
    from sonarproc.pipeline.surfacefit import surface_kind

    pts = np.round(np.asarray(fit.polyline, dtype=np.float64).reshape(-1, 2), 6)
    single = pts.shape[0] == 1 or bool(np.all(pts == pts[0]))
    geometry = (
        {"type": "Point", "coordinates": pts[0].tolist()}
        if single
        else {"type": "LineString", "coordinates": pts.tolist()}
    )
    return {
        "type": "Feature",
        "geometry": geometry,
        "properties": {
            "surface": surface,
            "model": fit.model,
            "kind": surface_kind(fit.model),
            "length_m": float(fit.length_m),
            "rms_m": float(fit.rms_m),
            "support": int(fit.support),
            "arcs": int(fit.arcs),
            "closed": bool(fit.closed),
        },
    }


def write_geojson(result: MethodResult, path: str | Path) -> Path:
    """Write :func:`geojson_profile` to ``path``."""
    p = Path(path)
    p.write_text(json.dumps(geojson_profile(result)) + "\n", encoding="utf-8")
    return p


PLY_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("evidence", "<u4")])
#: The second PLY element: the fitted surfaces' points, each with its surface id.
PLY_SURFACE_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("surface", "<i4")])


def write_ply(result: MethodResult, path: str | Path) -> Path:
    """Write the processed cells, then the fitted surfaces' points, as a binary PLY.

    Element ``vertex``: the processed cells (``x, y, z = 0, evidence``); element
    ``surface_point``: every point of every fitted polyline in order, with its
    ``surface`` id (0..N-1 as in ``surfaces.csv``; the one fitted profile is surface 0).
    """
    run = result.run
    ix, iy = np.nonzero(run.processed.T)
    v = np.zeros(ix.size, dtype=PLY_DTYPE)
    v["x"], v["y"] = run.grid.to_world(iy, ix)
    v["evidence"] = run.counts_map[iy, ix]
    polys = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in fitted_polylines(result)]
    sp = np.zeros(sum(p.shape[0] for p in polys), dtype=PLY_SURFACE_DTYPE)
    if polys:
        sp["x"] = np.concatenate([p[:, 0] for p in polys])
        sp["y"] = np.concatenate([p[:, 1] for p in polys])
        sp["surface"] = np.repeat(np.arange(len(polys)), [p.shape[0] for p in polys])
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"comment sonarmorph {result.method} processed map, map frame, m\n"
        f"comment {len(polys)} fitted surface(s) in element surface_point\n"
        f"element vertex {ix.size}\n"
        "property float x\nproperty float y\nproperty float z\nproperty uint evidence\n"
        f"element surface_point {sp.size}\n"
        "property float x\nproperty float y\nproperty float z\nproperty int surface\n"
        "end_header\n"
    ).encode("ascii")
    p = Path(path)
    p.write_bytes(header + v.tobytes() + sp.tobytes())
    return p


def read_ply(path: str | Path) -> dict[str, npt.NDArray[Any]]:
    """Read a PLY written by :func:`write_ply`: its elements by name (structured arrays)."""
    data = Path(path).read_bytes()
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise InputError(f"{path}: not a PLY file with a plain header")
    types = {"float": "<f4", "uint": "<u4", "int": "<i4"}
    elements: list[tuple[str, int, list[tuple[str, str]]]] = []
    for line in data[:end].decode("ascii").splitlines():
        words = line.split()
        if words[:1] == ["element"]:
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"] and elements:
            elements[-1][2].append((words[2], types[words[1]]))
    out: dict[str, npt.NDArray[Any]] = {}
    offset = end + len(b"end_header\n")
    for name, count, fields in elements:
        dtype = np.dtype(fields)
        out[name] = np.frombuffer(data, dtype=dtype, count=count, offset=offset)
        offset += count * dtype.itemsize
    return out


def fitted_polylines(result: MethodResult) -> list[npt.NDArray[np.float64]]:
    """The fitted surfaces of a run as polylines (world frame): each surface, or the profile."""
    run = result.run
    if result.surfaces:
        return [np.asarray(s.polyline, dtype=np.float64) for s in result.surfaces]
    if isinstance(run.fit, FitFailure):
        return []
    return [run.fit.sample(run.grid.cell)]


def write_rosbag2(
    result: MethodResult, log: SonarLog, path: str | Path, *, force: bool = False
) -> Path:
    """A ROS 2 bag replaying ``log``'s readings (Range + tf) over the fitted surfaces.

    Corners and edges are markers of their own (a sphere each, namespace their kind).
    """
    from sonarlog.sources import write_rosbag2 as write_bag

    points: dict[str, list[list[float]]] = {}
    for s in result.surfaces or []:
        if s.model in ("corner", "edge"):
            points.setdefault(s.model, []).append(np.asarray(s.polyline)[0].tolist())
    write_bag(log, path, surfaces=fitted_polylines(result), points=points, force=force)
    return Path(path)


def write_exports(
    result: MethodResult,
    out_dir: str | Path,
    formats: Iterable[str],
    *,
    log: SonarLog | None = None,
    force: bool = False,
) -> list[Path]:
    """Write each format of ``formats`` as ``OUT/<method>.<ext>``; return the paths.

    ``rosbag2`` (a bag directory ``OUT/<method>_rosbag2``) needs the ``log`` the run read;
    ``force`` lets it replace an existing bag.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    stem = out / result.method
    written: list[Path] = []
    for f in formats:
        if f == "ros-map":
            written.extend(write_ros_map(result, stem))
        elif f == "geojson":
            written.append(write_geojson(result, stem.with_suffix(".geojson")))
        elif f == "ply":
            written.append(write_ply(result, stem.with_suffix(".ply")))
        elif f == "rosbag2":
            if log is None:
                raise ParameterError("formats", "rosbag2 needs the log the run read")
            bag = out / f"{result.method}_rosbag2"
            written.append(write_rosbag2(result, log, bag, force=force))
        else:
            raise ParameterError("formats", f"must be among {', '.join(FORMATS)}, got {f!r}")
    return written

"""A run's map as Foxglove messages: count map, processed map, surfaces, quality.

:class:`MapPublisher` publishes a :class:`~sonarproc.pipeline.RunResult` on

* ``/map/arcs`` (``foxglove.Grid``): the arc count map, one ``uint16`` ``count`` per cell
  (counts above 65535 saturate; a cell is crossed by that many arcs only after hours);
* ``/map/processed`` (``foxglove.Grid``): the morphologically processed map, ``uint8``
  ``kept`` 0/1;
* ``/map/surfaces`` (``foxglove.SceneUpdate``): one entity ``surface/<i>`` per surface:
  a line strip, a point feature (sphere) or a cylinder, coloured by kind
  (:data:`KIND_COLORS`), with metadata ``kind``, ``model``, ``length_m``, ``support``,
  ``rms_m``, ``arcs``, ``readings`` and ``last_reading_t`` (the newest reading the fit
  saw, UNIX s);
* ``/map/quality`` (JSON): the run's truth-free quality figures when it has them, else
  its counts and metrics.

Publishing is incremental: a grid goes out only when its cells changed, a surface entity
only when that surface changed, and surfaces that disappeared are deleted by id.

Grids lie in ``map``; the grid's pose is the lower-left corner of cell (0, 0) (a Grid's
origin is its corner, a :class:`~sonarproc.grid.Grid`'s the cell centre).
"""

from __future__ import annotations

import hashlib
import json
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from sonarlog.foxglove_messages import FRAME_MAP, timestamp_of
from sonarlog.foxglove_server import json_channel

if TYPE_CHECKING:
    import foxglove

    from sonarproc.grid import Grid
    from sonarproc.pipeline import RunResult
    from sonarproc.surfaces import SurfaceFit

__all__ = ["KIND_COLORS", "MAP_TOPICS", "MapPublisher", "surface_kind"]

TOPIC_ARCS, TOPIC_PROCESSED = "/map/arcs", "/map/processed"
TOPIC_SURFACES, TOPIC_QUALITY = "/map/surfaces", "/map/quality"
MAP_TOPICS = (TOPIC_ARCS, TOPIC_PROCESSED, TOPIC_SURFACES, TOPIC_QUALITY)

#: RGBA per surface kind: planes blue, curves green, cylinders orange, corners red, edges
#: magenta (distinct under the common colour-vision deficiencies as hue and lightness).
KIND_COLORS: dict[str, tuple[float, float, float, float]] = {
    "plane": (0.12, 0.47, 0.71, 1.0),
    "curve": (0.17, 0.63, 0.17, 1.0),
    "cylinder": (1.0, 0.5, 0.05, 1.0),
    "corner": (0.84, 0.15, 0.16, 1.0),
    "edge": (0.8, 0.2, 0.8, 1.0),
}
POINT_KINDS = ("corner", "edge")
#: Line width (m) of a surface and the diameter of a point feature: a few map cells.
SURFACE_WIDTH_M = 0.02
POINT_DIAMETER_M = 0.06
_COUNT_MAX = np.iinfo(np.uint16).max
#: JSON schema of ``/map/quality`` (the Plot panel lists its numeric fields).
QUALITY_SCHEMA: dict[str, Any] = {
    "title": "sonarmorph.Quality",
    "type": "object",
    "properties": {
        "surfaces": {"type": "integer", "description": "surfaces fitted"},
        "counts": {"type": "object", "description": "readings, arcs and cells counted"},
        "quality": {"type": "object", "description": "truth-free quality figures"},
        "metrics": {"type": "object", "description": "the paper's measures (m)"},
        "live": {"type": "object", "description": "a live update: update_s, last_reading_t"},
    },
}


def surface_kind(s: SurfaceFit) -> str:
    """A surface's kind: its own ``kind`` when it has one, else the one its model implies.

    Examples
    --------
    >>> from sonarproc.surfaces import SurfaceFit
    >>> surface_kind(SurfaceFit("line", np.zeros((2, 2)), 1.0, 0.0, 10, 10))
    'plane'
    """
    from sonarproc.pipeline.surfacefit import surface_kind as kind_of_model

    kind = getattr(s, "kind", None)
    if isinstance(kind, str) and kind:
        return kind
    return kind_of_model(s.model)


def _digest(*parts: Any) -> str:
    h = hashlib.blake2b(digest_size=16)
    for p in parts:
        h.update(p if isinstance(p, bytes) else repr(p).encode())
    return h.hexdigest()


class MapPublisher:
    """Publish run results on a Foxglove context's map channels, only what changed.

    Parameters
    ----------
    context : foxglove.Context, optional
        Where the channels live; default the global context.

    Raises
    ------
    ImportError
        ``foxglove-sdk`` is not installed.
    """

    def __init__(self, *, context: foxglove.Context | None = None) -> None:
        import foxglove.channels as fc
        import foxglove.messages as fg

        self._fg = fg
        self.arcs_channel = fc.GridChannel(TOPIC_ARCS, context=context)
        self.processed_channel = fc.GridChannel(TOPIC_PROCESSED, context=context)
        self.surfaces_channel = fc.SceneUpdateChannel(TOPIC_SURFACES, context=context)
        self.quality_channel = json_channel(
            TOPIC_QUALITY, "sonarmorph.Quality", QUALITY_SCHEMA, context
        )
        self._grid_digest: dict[str, str] = {}
        self._surface_digest: dict[str, str] = {}
        self._last_grid: dict[str, tuple[Any, Any]] = {}  # topic -> (channel, message)
        self._entities: dict[str, Any] = {}  # entity id -> the entity last sent
        self._last_quality = b""
        self.updates = 0

    def publish(
        self,
        result: RunResult,
        *,
        t: float,
        readings: int = 0,
        last_reading_t: float = math.nan,
        update_s: float | None = None,
    ) -> dict[str, int]:
        """Publish what changed in ``result`` with log time ``t`` (UNIX s).

        Parameters
        ----------
        result : RunResult
            A run or a live snapshot.
        t : float
            Log time of the messages (UNIX s).
        readings : int
            Readings the result was made from (into the surfaces' metadata).
        last_reading_t : float
            Firing time of the newest of them (UNIX s).
        update_s : float, optional
            Wall time the live view took to make ``result`` (s). Given (by ``watch``), it
            goes into ``/map/quality`` with ``readings`` and ``last_reading_t``, so a client
            can tell how far behind the readings the map is.

        Returns
        -------
        dict
            Messages sent per kind: ``grids``, ``surfaces`` (entities), ``deleted``.
        """
        t_ns = round(t * 1e9)
        sent = {"grids": 0, "surfaces": 0, "deleted": 0}
        counts = np.minimum(result.counts_map, _COUNT_MAX).astype("<u2")
        kept = np.asarray(result.processed, dtype=np.uint8)
        for key, channel, data, numeric in (
            ("arcs", self.arcs_channel, counts, self._fg.PackedElementFieldNumericType.Uint16),
            ("kept", self.processed_channel, kept, self._fg.PackedElementFieldNumericType.Uint8),
        ):
            raw = np.ascontiguousarray(data).tobytes()
            digest = _digest(result.grid, raw)
            if self._grid_digest.get(key) != digest:
                self._grid_digest[key] = digest
                field = "count" if key == "arcs" else "kept"
                msg = self._grid(result.grid, raw, data, field, numeric, t)
                channel.log(msg, log_time=t_ns)
                self._last_grid[channel.topic()] = (channel, msg)
                sent["grids"] += 1
        update, n, gone = self._surfaces(result, t, readings, last_reading_t)
        if n or gone:
            self.surfaces_channel.log(update, log_time=t_ns)
        sent["surfaces"], sent["deleted"] = n, gone
        self._last_quality = json.dumps(
            quality_figures(result, live=_live_figures(update_s, readings, last_reading_t))
        ).encode()
        self.quality_channel.log(self._last_quality, log_time=t_ns)
        self.updates += 1
        return sent

    def resend(self, topics: set[str], *, t: float) -> None:
        """Send the current state again on ``topics`` (for clients that just subscribed).

        The protocol keeps no message for late subscribers: without this a viewer that
        connects after the map last changed would see no map until it changes again.
        """
        t_ns = round(t * 1e9)
        for topic, (channel, msg) in self._last_grid.items():
            if topic in topics:
                channel.log(msg, log_time=t_ns)
        if TOPIC_SURFACES in topics and self._entities:
            update = self._fg.SceneUpdate(entities=list(self._entities.values()))
            self.surfaces_channel.log(update, log_time=t_ns)
        if TOPIC_QUALITY in topics and self._last_quality:
            self.quality_channel.log(self._last_quality, log_time=t_ns)

    # ---- grids ---------------------------------------------------------------------------

    def _grid(
        self, grid: Grid, raw: bytes, data: np.ndarray, name: str, numeric: Any, t: float
    ) -> Any:
        fg = self._fg
        half = grid.cell / 2.0
        return fg.Grid(
            timestamp=timestamp_of(fg, t),
            frame_id=FRAME_MAP,
            pose=fg.Pose(
                position=fg.Vector3(x=grid.x0 - half, y=grid.y0 - half, z=0.0),
                orientation=fg.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            ),
            column_count=grid.nx,
            cell_size=fg.Vector2(x=grid.cell, y=grid.cell),
            row_stride=grid.nx * data.itemsize,
            cell_stride=data.itemsize,
            fields=[fg.PackedElementField(name=name, offset=0, type=numeric)],
            data=raw,
        )

    # ---- surfaces ------------------------------------------------------------------------

    def _surfaces(
        self, result: RunResult, t: float, readings: int, last_reading_t: float
    ) -> tuple[Any, int, int]:
        fg = self._fg
        fits = surfaces_of(result)
        stamp = timestamp_of(fg, t)
        entities = []
        now: dict[str, str] = {}
        for i, s in enumerate(fits):
            eid = f"surface/{i}"
            poly = np.ascontiguousarray(s.polyline, dtype=np.float64)
            digest = _digest(surface_kind(s), s.model, poly.tobytes(), s.support, s.rms_m)
            now[eid] = digest
            if self._surface_digest.get(eid) == digest:
                continue
            meta = {
                "kind": surface_kind(s),
                "model": s.model,
                "length_m": f"{s.length_m:.4f}",
                "support": str(int(s.support)),
                "rms_m": f"{s.rms_m:.5f}",
                "arcs": str(int(s.arcs)),
                "readings": str(int(readings)),
                "last_reading_t": repr(float(last_reading_t)),  # exact, as the beam's "t"
            }
            entity = self._entity(eid, s, poly, meta, stamp)
            self._entities[eid] = entity
            entities.append(entity)
        gone = sorted(set(self._surface_digest) - set(now))
        for eid in gone:
            self._entities.pop(eid, None)
        deletions = [
            fg.SceneEntityDeletion(
                timestamp=stamp, type=fg.SceneEntityDeletionType.MatchingId, id=eid
            )
            for eid in gone
        ]
        self._surface_digest = now
        return fg.SceneUpdate(deletions=deletions, entities=entities), len(entities), len(gone)

    def _entity(
        self, eid: str, s: SurfaceFit, poly: np.ndarray, meta: dict[str, str], stamp: Any
    ) -> Any:
        fg = self._fg
        kind = meta["kind"]
        r, g, b, a = KIND_COLORS.get(kind, KIND_COLORS["curve"])
        color = fg.Color(r=r, g=g, b=b, a=a)
        level = fg.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
        lines, spheres, cylinders = [], [], []
        centre = s.params.get("centre") if isinstance(s.params, dict) else None
        radius = s.params.get("radius") if isinstance(s.params, dict) else None
        if kind == "cylinder" and centre is not None and radius is not None:
            d = 2.0 * float(radius)
            cylinders.append(
                fg.CylinderPrimitive(
                    pose=fg.Pose(
                        position=fg.Vector3(x=float(centre[0]), y=float(centre[1]), z=0.0),
                        orientation=level,
                    ),
                    size=fg.Vector3(x=d, y=d, z=SURFACE_WIDTH_M),
                    bottom_scale=1.0,
                    top_scale=1.0,
                    color=color,
                )
            )
        elif kind in POINT_KINDS or len(poly) == 1:
            x, y = poly.mean(axis=0) if len(poly) else (math.nan, math.nan)
            spheres.append(
                fg.SpherePrimitive(
                    pose=fg.Pose(
                        position=fg.Vector3(x=float(x), y=float(y), z=0.0), orientation=level
                    ),
                    size=fg.Vector3(x=POINT_DIAMETER_M, y=POINT_DIAMETER_M, z=POINT_DIAMETER_M),
                    color=color,
                )
            )
        else:
            lines.append(
                fg.LinePrimitive(
                    type=fg.LinePrimitiveLineType.LineStrip,
                    thickness=SURFACE_WIDTH_M,
                    points=[fg.Point3(x=x, y=y, z=0.0) for x, y in poly.tolist()],
                    color=color,
                )
            )
        return fg.SceneEntity(
            timestamp=stamp,
            frame_id=FRAME_MAP,
            id=eid,
            metadata=[fg.KeyValuePair(key=k, value=v) for k, v in meta.items()],
            lines=lines,
            spheres=spheres,
            cylinders=cylinders,
        )


def surfaces_of(result: RunResult) -> list[SurfaceFit]:
    """The run's surfaces; a single-profile run's fitted profile as one curve; or none."""
    from sonarproc.fit import FitFailure
    from sonarproc.surfaces import SurfaceFit

    if result.surfaces is not None and result.surfaces.surfaces:
        return list(result.surfaces.surfaces)
    if isinstance(result.fit, FitFailure):
        return []
    poly = np.asarray(result.fit.sample(result.grid.cell), dtype=np.float64)
    if len(poly) == 0:
        return []
    length = float(np.hypot(*np.diff(poly, axis=0).T).sum()) if len(poly) > 1 else 0.0
    rms = result.metrics.sigma_y_m
    return [
        SurfaceFit(
            model=f"profile-{result.fit.kind}",
            polyline=poly,
            length_m=length,
            rms_m=float(rms) if rms is not None else math.nan,
            support=int(result.points_x.size),
            arcs=int(result.counts_map.sum()),
        )
    ]


def _live_figures(
    update_s: float | None, readings: int, last_reading_t: float
) -> dict[str, Any] | None:
    if update_s is None:
        return None
    t = float(last_reading_t)
    return {"update_s": round(float(update_s), 6), "readings": int(readings),
            "last_reading_t": t if math.isfinite(t) else None}  # fmt: skip


def quality_figures(result: RunResult, *, live: dict[str, Any] | None = None) -> dict[str, Any]:
    """The ``/map/quality`` document: truth-free figures if the run has them, else counts.

    Always holds ``surfaces`` (how many) and ``counts``; ``quality`` when the run carries
    its truth-free figures, else ``metrics`` (the paper's measures, ``None`` where
    undefined); ``live`` when given (a live map update: its wall time ``update_s``, the
    ``readings`` it maps and the firing time ``last_reading_t`` of the newest).
    """
    doc: dict[str, Any] = {
        "surfaces": len(result.surfaces.surfaces) if result.surfaces is not None else 0,
        "counts": {k: int(v) for k, v in result.counts.items()},
    }
    quality = getattr(result, "quality", None)
    if quality:
        doc["quality"] = quality if isinstance(quality, dict) else _jsonable(quality)
    else:
        doc["metrics"] = result.metrics.to_json()
    if live is not None:
        doc["live"] = live
    return doc


def _jsonable(obj: Any) -> Any:
    to_json = getattr(obj, "to_json", None)
    return to_json() if callable(to_json) else str(obj)

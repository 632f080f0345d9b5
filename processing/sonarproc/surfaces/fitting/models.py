"""One fit per surface: a line segment, a circular arc or a smoothing spline in arc length.

Each candidate is fitted to the surface's cells and scored by its RMS orthogonal residual
(m). The model is chosen by this stated criterion, simplest first:

    choose the first of line, arc, spline whose RMS residual is at most
    ``1.25 * rms_spline + 0.25 * cell``

i.e. a line or an arc is kept unless the flexible spline explains the cells clearly
better (by more than a quarter of the spline's own residual plus a quarter cell: the
cells are quantised to the grid, so differences below a fraction of a cell mean
nothing). The spline (the costly fit: its smoothing is chosen by GCV) is fitted only
when neither the line nor the arc passes the same test against a cheaper stand-in for
its residual, the RMS distance of the cells to their own means over 5-cell bins of arc
length (a curve that follows the cells about as closely as the spline does). An arc
must also bend: its radius at most 20 times its length and its centre on a side of the
cells (otherwise the line, which fits as well, is taken).

* line: total least squares (the principal axis of the cells), refitted once without the
  cells further than ``max(3 rms, 2 cells)`` from it (the corner cells of a neighbour);
  the segment spans the projections of the cells.
* arc: algebraic circle (Kasa) refined by Gauss-Newton on the geometric distance, trimmed
  like the line; the arc spans the cells' angles in their order along the surface, or
  the whole circle for a closed surface.
* spline: cubic smoothing splines (:mod:`sonarproc.surfaces.fitting.smoothing`) of x(s) and
  y(s) over the cells averaged in bins of arc length (one cell, or the length over
  :data:`MAX_SPLINE_BINS` on long surfaces), smoothing chosen by GCV.

Degenerate input (fewer than :data:`MIN_CELLS` cells, all cells in one place, a singular
system) gives a :class:`SurfaceFailure` with the reason, never a curve. The criterion is
applied by :func:`~sonarproc.surfaces.fitting.batch.fit_surfaces` (many surfaces at once) and
:func:`~sonarproc.surfaces.fitting.batch.fit_surface` (one); the line and circle fits here are
the one-group case of :mod:`sonarproc.surfaces.fitting.grouped`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.grouped import fit_circles, fit_lines
from sonarproc.surfaces.fitting.smoothing import smoothing_spline
from sonarproc.surfaces.planar.polylines import (
    distance_to_polylines,
    resample,
    to_adjacent_segments,
)

__all__ = [
    "MIN_CELLS",
    "Candidate",
    "SurfaceFailure",
    "SurfaceFit",
    "arc_candidate",
    "choose_model",
    "fit_arc",
    "fit_line",
    "fit_spline",
    "line_candidate",
    "line_params",
]

FloatArray = npt.NDArray[np.float64]

#: Fewest cells a surface needs for any fit.
MIN_CELLS = 5
#: Fewest cells (or echo points) a spline is fitted to: through fewer, a smoothing spline
#: chosen by cross-validation says nothing a line or an arc does not, and costs as much.
MIN_SPLINE_CELLS = 20
#: Most arc-length bins a spline is fitted over (longer surfaces get wider bins): the GCV
#: choice of the smoothing costs a Python step per bin and per trial, and a surface's
#: shape needs far fewer knots than a long ridge has cells.
MAX_SPLINE_BINS = 64
#: The criterion's constants (see the module docstring).
SPLINE_FACTOR = 1.25
CELL_FACTOR = 0.25
#: An arc flatter than this (radius / length) is a line.
MAX_RADIUS_PER_LENGTH = 20.0
MODELS = ("line", "arc", "spline")


@dataclass(frozen=True)
class SurfaceFit:
    """A fitted surface.

    Attributes
    ----------
    model : {"line", "arc", "spline"}
    polyline : ndarray, shape (K, 2)
        The fitted surface sampled every cell size, in order along it (closed: the first
        point repeated last).
    length_m : float
        Length of ``polyline`` (m).
    rms_m : float
        RMS distance of the surface's cells to ``polyline`` (m).
    support : int
        Cells of the surface.
    arcs : int
        Sum of the cells' evidence (arc crossings; the cell count without counts).
    closed : bool
        The surface closes on itself.
    params : dict
        Model parameters (line: ``point``, ``direction``; arc: ``centre``, ``radius``,
        ``start_rad``, ``sweep_rad``; spline: ``knots``).
    candidates : dict
        RMS residual (m) of every model tried, for the report.
    """

    model: str
    polyline: FloatArray
    length_m: float
    rms_m: float
    support: int
    arcs: int
    closed: bool = False
    params: dict[str, Any] = field(default_factory=dict)
    candidates: dict[str, float] = field(default_factory=dict)
    ok: bool = True

    def to_json(self, surface: int) -> dict[str, Any]:
        """JSON-ready summary (no polyline) with its ``surface`` id."""
        return {
            "surface": surface,
            "ok": True,
            "model": self.model,
            "length_m": self.length_m,
            "rms_m": self.rms_m,
            "support": self.support,
            "arcs": self.arcs,
            "closed": self.closed,
            "params": self.params,
            "candidates_rms_m": self.candidates,
        }


@dataclass(frozen=True)
class SurfaceFailure:
    """A surface that could not be fitted, and why."""

    reason: str
    support: int = 0
    ok: bool = False

    def to_json(self, surface: int) -> dict[str, Any]:
        """JSON-ready description with its ``surface`` id."""
        return {"surface": surface, "ok": False, "reason": self.reason, "support": self.support}


@dataclass(frozen=True)
class Candidate:
    """One model fitted to a surface's cells: its polyline, RMS residual (m), parameters."""

    model: str
    polyline: FloatArray
    rms: float
    params: dict[str, Any]
    closed: bool = False


def line_candidate(
    point: FloatArray, direction: FloatArray, lo: float, hi: float, rms: float, cell: float
) -> Candidate:
    """The line segment ``point + u direction`` for ``lo <= u <= hi``, sampled every cell."""
    poly = resample(np.stack((point + direction * lo, point + direction * hi)), cell)
    return Candidate("line", poly, rms, line_params(point, direction))


def line_params(point: FloatArray, direction: FloatArray) -> dict[str, Any]:
    """A line's parameters as :class:`Candidate` and ``report.json`` hold them."""
    return {"point": point.tolist(), "direction": direction.tolist()}


def fit_line(cells: SurfaceCells, *, cell: float) -> Candidate | SurfaceFailure:
    """Total least squares line segment through the cells (one trimmed refit).

    See :func:`sonarproc.surfaces.fitting.grouped.fit_lines` (this is its one-group case).
    """
    if cells.size < 2:
        return SurfaceFailure(f"line: {cells.size} cells, need at least 2", cells.size)
    got = fit_lines(cells.x, cells.y, np.array([cells.size]), cell=cell)
    if not got.ok[0]:
        return SurfaceFailure("line: all cells at one point", cells.size)
    lo, hi, rms = float(got.lo[0]), float(got.hi[0]), float(got.rms[0])
    return line_candidate(got.point[0], got.direction[0], lo, hi, rms, cell)


def arc_candidate(cells: SurfaceCells, centre: FloatArray, radius: float, cell: float) -> Candidate:
    """The arc of a circle over the cells' angles (the whole circle for a closed surface)."""
    x, y = cells.x, cells.y
    cx, cy, r = float(centre[0]), float(centre[1]), float(radius)
    ang = np.unwrap(np.arctan2(y - cy, x - cx))
    if cells.closed:
        start, sweep = float(ang[0]), 2.0 * math.pi
    else:
        start, sweep = float(ang[0]), float(ang[-1] - ang[0])
        lo, hi = float(ang.min()), float(ang.max())
        start, sweep = (lo, hi - lo) if sweep >= 0 else (hi, lo - hi)
    n = max(2, math.ceil(abs(sweep) * r / cell) + 1)
    phi = start + sweep * np.linspace(0.0, 1.0, n)
    poly = np.stack((cx + r * np.cos(phi), cy + r * np.sin(phi)), axis=1)
    dist = _arc_distances(np.stack((x, y), 1), poly, cx, cy, start, sweep)
    rms = float(np.sqrt(np.mean(dist**2)))
    params = {"centre": [cx, cy], "radius": r, "start_rad": start, "sweep_rad": sweep}
    return Candidate("arc", poly, rms, params, closed=cells.closed)


def _arc_distances(
    q: FloatArray, poly: FloatArray, cx: float, cy: float, start: float, sweep: float
) -> FloatArray:
    """:func:`distance_to_polylines` of ``q`` to an arc's polyline, its vertices at equal angles.

    The nearest vertex of a circle's polyline is the one nearest in angle, so no search
    is needed; the distance is then taken to it and its two segments, as there.
    """
    n = poly.shape[0]
    span = abs(sweep)
    if n < 2 or span <= 0:
        return distance_to_polylines(q, [poly])
    ang = np.arctan2(q[:, 1] - cy, q[:, 0] - cx)
    rel = np.mod((ang - start) if sweep >= 0 else (start - ang), 2 * math.pi)
    # the two vertices either side of the angle, both ends beyond the arc (or at the
    # seam of a closed one): the nearest of them, the lower index on ties, as the search
    low = np.minimum(np.floor(np.minimum(rel, span) / span * (n - 1)), n - 2).astype(np.intp)
    past = (rel > span) | (low == 0) | (low == n - 2)
    cand = np.stack((low, low + 1, np.where(past, 0, low), np.where(past, n - 1, low)), axis=1)
    cand.sort(axis=1)
    d = q[:, None, :] - poly[cand]
    dist = np.sqrt(d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])
    pick = np.argmin(dist, axis=1)
    rows = np.arange(q.shape[0])
    k, best = cand[rows, pick], dist[rows, pick]
    ends = np.zeros_like(k), np.full_like(k, n - 1)
    return to_adjacent_segments(q, poly, k, best, *ends)


def fit_arc(cells: SurfaceCells, *, cell: float) -> Candidate | SurfaceFailure:
    """Circular arc through the cells: algebraic start, geometric refinement, one trim.

    See :func:`sonarproc.surfaces.fitting.grouped.fit_circles` (this is its one-group case).
    """
    if cells.size < 3:
        return SurfaceFailure(f"arc: {cells.size} cells, need at least 3", cells.size)
    got = fit_circles(cells.x, cells.y, np.array([cells.size]), cell=cell)
    if not got.ok[0]:
        return SurfaceFailure("arc: no circle fits (collinear or degenerate cells)", cells.size)
    return arc_candidate(cells, got.centre[0], float(got.radius[0]), cell)


def fit_spline(cells: SurfaceCells, *, cell: float) -> Candidate | SurfaceFailure:
    """Smoothing splines x(s), y(s) in arc length over arc-length bins, GCV smoothing."""
    width = max(cell, cells.extent_m / MAX_SPLINE_BINS)
    b = np.floor(cells.s / width).astype(np.int64)
    _, inv, cnt = np.unique(b, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    if cnt.size < MIN_CELLS:
        return SurfaceFailure(f"spline: {cnt.size} arc-length bins, need {MIN_CELLS}", cells.size)
    sb = np.bincount(inv, weights=cells.s) / cnt
    xb = np.bincount(inv, weights=cells.x) / cnt
    yb = np.bincount(inv, weights=cells.y) / cnt
    w = cnt.astype(np.float64)
    try:
        spline = smoothing_spline(sb, np.stack((xb, yb), axis=1), w)
    except (ValueError, np.linalg.LinAlgError) as err:
        return SurfaceFailure(f"spline: {err}", cells.size)
    fine = np.linspace(sb[0], sb[-1], max(2, 4 * cnt.size))
    dense = spline(fine)
    if not np.all(np.isfinite(dense)):
        return SurfaceFailure("spline: not finite", cells.size)
    poly = resample(dense, cell)
    rms = float(
        np.sqrt(np.mean(distance_to_polylines(np.stack((cells.x, cells.y), 1), [dense]) ** 2))
    )
    return Candidate("spline", poly, rms, {"knots": int(cnt.size)})


def choose_model(rms: dict[str, float], *, cell: float, reference: float | None = None) -> str:
    """The model the criterion picks from the candidates' RMS residuals (m).

    ``reference`` stands in for the spline's residual when no spline was fitted.

    Examples
    --------
    >>> choose_model({"line": 0.004, "arc": 0.0039, "spline": 0.0035}, cell=0.01)
    'line'
    >>> choose_model({"line": 0.03, "arc": 0.004, "spline": 0.0035}, cell=0.01)
    'arc'
    >>> choose_model({"line": 0.03, "arc": 0.004}, cell=0.01, reference=0.0035)
    'arc'
    """
    ref = rms.get("spline", reference)
    for m in MODELS:
        if m not in rms:
            continue
        if ref is None or rms[m] <= SPLINE_FACTOR * ref + CELL_FACTOR * cell:
            return m
    return min(rms, key=lambda k: rms[k])

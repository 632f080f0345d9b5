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
* spline: cubic smoothing splines (:mod:`sonarproc.surfaces.smoothing`) of x(s) and y(s) over the
  cells averaged in bins of arc length (one cell, or the length over
  :data:`MAX_SPLINE_BINS` on long surfaces), smoothing chosen by GCV.

Degenerate input (fewer than :data:`MIN_CELLS` cells, all cells in one place, a singular
system) gives a :class:`SurfaceFailure` with the reason, never a curve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extract import SurfaceCells
from sonarproc.surfaces.polylines import distance_to_polylines, resample
from sonarproc.surfaces.smoothing import smoothing_spline

__all__ = [
    "MIN_CELLS",
    "SurfaceFailure",
    "SurfaceFit",
    "choose_model",
    "fit_arc",
    "fit_line",
    "fit_spline",
    "fit_surface",
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
#: Arc-length bins (cells) of the spline's stand-in (see the module docstring).
FLOOR_BIN_CELLS = 5
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
class _Candidate:
    model: str
    polyline: FloatArray
    rms: float
    params: dict[str, Any]
    closed: bool = False


def _trim(resid: FloatArray, cell: float) -> npt.NDArray[np.bool_]:
    rms = float(np.sqrt(np.mean(resid**2))) if resid.size else 0.0
    return np.abs(resid) <= max(3.0 * rms, 2.0 * cell)


def _tls(x: FloatArray, y: FloatArray) -> tuple[FloatArray, FloatArray] | None:
    c = np.array([x.mean(), y.mean()])
    d = np.stack((x - c[0], y - c[1]), axis=1)
    _, sv, vt = np.linalg.svd(d, full_matrices=False)
    if sv.size < 2 or sv[0] <= 0:
        return None
    return c, vt[0]


def fit_line(cells: SurfaceCells, *, cell: float) -> _Candidate | SurfaceFailure:
    """Total least squares line segment through the cells (one trimmed refit)."""
    x, y = cells.x, cells.y
    first = _tls(x, y)
    if first is None:
        return SurfaceFailure("line: all cells at one point", cells.size)
    c, t = first
    resid = (x - c[0]) * -t[1] + (y - c[1]) * t[0]
    keep = _trim(resid, cell)
    if keep.sum() >= 2:
        again = _tls(x[keep], y[keep])
        if again is not None:
            c, t = again
    # orient along the surface's order (a group whose ends project alike keeps the
    # direction of positive x, as :func:`~sonarproc.surfaces.batchfit.fit_lines` does)
    if t[0] < 0 or (t[0] == 0 and t[1] < 0):
        t = -t
    u = (x - c[0]) * t[0] + (y - c[1]) * t[1]
    if u[-1] < u[0]:
        t, u = -t, -u
    ends = np.stack((c + t * u.min(), c + t * u.max()))
    poly = resample(ends, cell)
    rms = float(np.sqrt(np.mean(distance_to_polylines(np.stack((x, y), 1), [poly]) ** 2)))
    return _Candidate("line", poly, rms, {"point": c.tolist(), "direction": t.tolist()})


def _circle(x: FloatArray, y: FloatArray) -> tuple[float, float, float] | None:
    """Kasa's algebraic circle, then Gauss-Newton on the geometric residual.

    Both steps solve their 3 x 3 normal equations (the columns are well scaled: the
    points are centred on their mean first).
    """
    mx, my = x.mean(), y.mean()
    u, v = x - mx, y - my
    a = np.stack((u, v, np.ones_like(u)))
    try:
        sol = np.linalg.solve(a @ a.T, a @ -(u * u + v * v))
    except np.linalg.LinAlgError:
        return None
    cx, cy = -0.5 * sol[0], -0.5 * sol[1]
    r2 = cx * cx + cy * cy - sol[2]
    if not (np.isfinite(r2) and r2 > 0):
        return None
    p = np.array([cx, cy, math.sqrt(r2)])
    jac = np.empty((3, u.size))
    jac[2] = -1.0
    for _ in range(20):
        dx, dy = u - p[0], v - p[1]
        dist = np.maximum(np.hypot(dx, dy), 1e-12)
        jac[0], jac[1] = -dx / dist, -dy / dist
        try:
            step = np.linalg.solve(jac @ jac.T, jac @ (p[2] - dist))
        except np.linalg.LinAlgError:
            break
        p = p + step
        if not np.all(np.isfinite(p)):
            return None
        if np.abs(step).max() < 1e-10 * max(1.0, abs(p[2])):
            break
    if not p[2] > 0:
        return None
    return float(p[0] + mx), float(p[1] + my), float(p[2])


def fit_arc(cells: SurfaceCells, *, cell: float) -> _Candidate | SurfaceFailure:
    """Circular arc through the cells: algebraic start, geometric refinement, one trim."""
    x, y = cells.x, cells.y
    circ = _circle(x, y)
    if circ is None:
        return SurfaceFailure("arc: no circle fits (collinear or degenerate cells)", cells.size)
    keep = _trim(np.hypot(x - circ[0], y - circ[1]) - circ[2], cell)
    if keep.sum() >= 3:
        circ = _circle(x[keep], y[keep]) or circ
    cx, cy, r = circ
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
    rms = float(np.sqrt(np.mean(distance_to_polylines(np.stack((x, y), 1), [poly]) ** 2)))
    params = {"centre": [cx, cy], "radius": r, "start_rad": start, "sweep_rad": sweep}
    return _Candidate("arc", poly, rms, params, closed=cells.closed)


def fit_spline(cells: SurfaceCells, *, cell: float) -> _Candidate | SurfaceFailure:
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
    return _Candidate("spline", poly, rms, {"knots": int(cnt.size)})


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


def _floor_rms(cells: SurfaceCells, cell: float) -> float:
    """RMS distance of the cells to their means over bins of arc length (m)."""
    b = np.floor(cells.s / (FLOOR_BIN_CELLS * cell)).astype(np.int64)
    _, inv, cnt = np.unique(b, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    mx = np.bincount(inv, weights=cells.x) / cnt
    my = np.bincount(inv, weights=cells.y) / cnt
    return float(np.sqrt(np.mean((cells.x - mx[inv]) ** 2 + (cells.y - my[inv]) ** 2)))


def _lengths(poly: FloatArray) -> float:
    return float(np.hypot(*np.diff(poly, axis=0).T).sum()) if len(poly) > 1 else 0.0


def fit_surface(cells: SurfaceCells, *, cell: float) -> SurfaceFit | SurfaceFailure:
    """Fit line, arc and spline to one surface and keep the one the criterion picks.

    Parameters
    ----------
    cells : SurfaceCells
        One surface's cells in order (from :func:`~sonarproc.surfaces.extract_surfaces`).
    cell : float
        Cell size (m): the sampling step of the polyline and the criterion's unit.

    Returns
    -------
    SurfaceFit or SurfaceFailure

    Examples
    --------
    >>> from sonarproc.surfaces.extract import SurfaceCells
    >>> x = np.arange(0.0, 1.0, 0.01); y = 0.5 + 0 * x
    >>> f = fit_surface(SurfaceCells(x, y, x, 1 + 0 * x, False), cell=0.01)
    >>> f.model, round(f.length_m, 3), round(f.rms_m, 6), f.support
    ('line', 0.99, 0.0, 100)
    """
    if cells.size < MIN_CELLS:
        return SurfaceFailure(f"{cells.size} cells, need at least {MIN_CELLS}", cells.size)
    if not (np.ptp(cells.x) > 0 or np.ptp(cells.y) > 0):
        return SurfaceFailure("all cells at one point", cells.size)
    found: dict[str, _Candidate] = {}
    reasons: list[str] = []
    floor = _floor_rms(cells, cell)
    for fitter in (fit_line, fit_arc):
        got = fitter(cells, cell=cell)
        if isinstance(got, SurfaceFailure):
            reasons.append(got.reason)
        else:
            found[got.model] = got
            # A line within the criterion's bound is what the criterion picks whatever
            # the arc gives (models are tried simplest first): skip the arc's fit.
            if got.model == "line" and got.rms <= SPLINE_FACTOR * floor + CELL_FACTOR * cell:
                break
    arc = found.get("arc")
    if arc is not None and not cells.closed:
        length = max(_lengths(arc.polyline), cell)
        if arc.params["radius"] > MAX_RADIUS_PER_LENGTH * length:
            found.pop("arc")
    if cells.size >= MIN_SPLINE_CELLS and not any(
        c.rms <= SPLINE_FACTOR * floor + CELL_FACTOR * cell for c in found.values()
    ):
        got = fit_spline(cells, cell=cell)
        if isinstance(got, SurfaceFailure):
            reasons.append(got.reason)
        else:
            found[got.model] = got
    if not found:
        return SurfaceFailure("; ".join(reasons) or "no model fits", cells.size)
    rms = {m: c.rms for m, c in found.items()}
    best = found[choose_model(rms, cell=cell, reference=floor)]
    poly = best.polyline
    if best.closed and len(poly) > 1:
        poly = np.vstack((poly[:-1], poly[:1])) if np.allclose(poly[0], poly[-1]) else poly
    return SurfaceFit(
        model=best.model,
        polyline=poly,
        length_m=_lengths(poly),
        rms_m=best.rms,
        support=cells.size,
        arcs=round(float(cells.weight.sum())),
        closed=best.closed,
        params=best.params,
        candidates=rms,
    )

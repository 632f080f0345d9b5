"""``fit = "auto"``: the paper's polynomial for one curve y = f(x), surfaces otherwise.

:func:`choose_fit` looks at the processed map. When its cells are one thin band with one
run of cells per column (the paper's scenes), it answers "function" without further work
and the run fits the paper's polynomial. Otherwise it extracts the surfaces
(:mod:`sonarproc.surfaces`) from the arc count map through the chain that keeps every
wall (a vote of :data:`SURFACE_VOTES` arcs, then the ridge across each wall's own
direction), and decides by :func:`sonarproc.surfaces.decide`: still one function of x,
or several surfaces, each fitted with a line, an arc or a spline. Given the readings,
each surface is then refitted through its readings' specular echo points
(:mod:`sonarproc.surfaces.echoes.refine`): the crest of the counts lies on the sensors' side of
a surface, the echo points on it. As that refit sets the precision, the surfaces are
then extracted on a map of :data:`EXTRACT_CELL_M` cells (the counts summed over blocks;
on a 1 cm map, a quarter of the cells and far fewer chance ridges).
:func:`measure_surfaces` gives precision and completeness against a truth of several
surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.arcs import rasterize
from sonarproc.grid import Grid
from sonarproc.morphology import vote
from sonarproc.pipeline.selection import Beams
from sonarproc.surfaces import (
    EchoGeometry,
    SurfaceCells,
    SurfaceFailure,
    SurfaceFit,
    SurfaceSet,
    decide,
    find_surfaces,
    fit_surfaces,
    refine_fits,
    ridge_nms,
    seen_truth,
    surface_metrics,
    truth_points,
)
from sonarproc.surfaces.echoes.refine import MIN_ECHOES, MIN_SPREAD_M, ROUNDS_M
from sonarproc.surfaces.echoes.tangents import tangent_lines
from sonarproc.surfaces.evaluation.writers import kind_of
from sonarproc.surfaces.extraction.coarse import coarse_counts
from sonarproc.surfaces.reflectors.points import (
    ClaimedPoints,
    claim_points,
    refine_with_points,
)

__all__ = [
    "EXTRACT_CELL_M",
    "AutoFit",
    "FitStart",
    "choose_fit",
    "coarse_counts",
    "column_spans",
    "measure_surfaces",
    "one_curve_at_a_glance",
    "refine_surfaces",
    "seen_of_truth",
    "silent_geometry",
    "start_fit",
    "surface_kind",
    "surfaces_fit_record",
]

#: One function of x when the kept cells of a median column span at most this (m)...
MEDIAN_SPAN_M = 0.75
#: ... and those of 90 % of the columns at most this (m): less than a corridor's width.
P90_SPAN_M = 1.0
#: Arc votes a cell needs before the ridge (a cell crossed by one arc is no evidence).
SURFACE_VOTES = 1
#: Given the readings, surfaces are extracted on a map of cells about this size (m): the
#: refit through the echo points, not the map, sets their precision, and a coarser map
#: has far fewer cells to suppress and far fewer chance ridges to fit.
EXTRACT_CELL_M = 0.02
#: Logs with at least this many mapped readings find their walls from the readings
#: themselves first (:func:`_lines_first`): the arc map's chance crossings, and the ridges
#: they make, grow with the square of the readings per area, the tangent votes linearly.
LINES_FIRST_READINGS = 20_000
#: A reading votes for a wall when its tangent lies within this (m) of it.
TANGENT_TOL_M = 0.05
#: Fewest readings a wall found from the votes needs (a long log sees a wall many times;
#: shorter or rarer surfaces are left to the map).
LINE_MIN_VOTES = 20
#: The readings the walls leave go to the map only when there are at least this share of
#: all (fewer are stray echoes: a surface the map could find needs many readings in a
#: long log, and the map costs as much for a few arcs as for many).
RESIDUAL_SHARE = 0.001
#: A wall's echo points further apart than this (m) start a new wall (a doorway).
BRIDGE_M = 0.30


@dataclass(frozen=True)
class AutoFit:
    """What ``fit = "auto"`` chose, and why (``report.json``'s ``auto``)."""

    choice: str  # "function" or "surfaces"
    criterion: str
    surfaces: SurfaceSet | None = None
    detail: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        """JSON-ready mapping for ``report.json``."""
        return {"choice": self.choice, "criterion": self.criterion, **(self.detail or {})}


def column_spans(
    processed: npt.NDArray[np.bool_],
    cell: float,
    *,
    cells: tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]] | None = None,
) -> npt.NDArray[np.float64]:
    """For each column with kept cells, the height (m) from its lowest to its highest one.

    ``cells`` may give the kept cells as ``np.nonzero(processed.T)`` (columns, then rows,
    both ascending), when the caller has them already.

    Examples
    --------
    >>> m = np.zeros((6, 4), bool); m[2, :] = True; m[4, 1] = True
    >>> column_spans(m, 0.5).tolist()
    [0.5, 1.5, 0.5, 0.5]
    >>> column_spans(m, 0.5, cells=np.nonzero(m.T)).tolist()
    [0.5, 1.5, 0.5, 0.5]
    """
    if cells is not None:
        ix, iy = cells
        if ix.size == 0:
            return np.zeros(0)
        first = np.flatnonzero(np.r_[True, ix[1:] != ix[:-1]])
        last = np.r_[first[1:] - 1, ix.size - 1]
        return (iy[last] - iy[first] + 1).astype(np.float64) * cell
    m = np.asarray(processed, dtype=bool)
    occupied = m.any(axis=0)
    # the first kept cell from the bottom row up and from the top row down (argmax of a
    # bool map stops at the first True: no integer maps)
    bottom = m.argmax(axis=0)[occupied]
    top = m.shape[0] - 1 - m[::-1].argmax(axis=0)[occupied]
    return (top - bottom + 1).astype(np.float64) * cell


def one_curve_at_a_glance(
    processed: npt.NDArray[np.bool_],
    cell: float,
    *,
    cells: tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]] | None = None,
) -> bool:
    """:func:`choose_fit`'s first test: the kept cells are one thin band, one function of x.

    True when :func:`choose_fit` answers "function" without extracting surfaces (the
    median column span at most :data:`MEDIAN_SPAN_M`, 90 % at most :data:`P90_SPAN_M`).

    >>> m = np.zeros((50, 40), bool); m[20, :] = True
    >>> one_curve_at_a_glance(m, 0.05), one_curve_at_a_glance(np.ones((50, 40), bool), 0.05)
    (True, False)
    """
    spans = column_spans(processed, cell, cells=cells)
    if spans.size == 0:
        return False
    return (
        float(np.median(spans)) <= MEDIAN_SPAN_M and float(np.percentile(spans, 90)) <= P90_SPAN_M
    )


@dataclass(frozen=True, eq=False)
class FitStart:
    """The first half of :func:`choose_fit` on one map (:func:`start_fit`): the surfaces
    found on the map's ridge, before they are refitted through the echo points.

    Attributes
    ----------
    answer : AutoFit or None
        The choice itself, where nothing follows (nothing to fit, one function of x).
    found : SurfaceSet or None
        The surfaces found on the ridge, to be refitted.
    detail : dict or None
        The choice's record so far.
    criterion : str
        Why surfaces.
    extract : tuple or None
        The coarse count map and its grid the surfaces were found on.
    lines_first : bool
        A long log's path (:func:`_lines_first`): nothing is done ahead.
    spread : dict or None
        The kept cells' column spans (the record's first entries).
    """

    answer: AutoFit | None
    found: SurfaceSet | None = None
    detail: dict[str, Any] | None = None
    criterion: str = ""
    extract: tuple[npt.NDArray[Any], Grid] | None = None
    lines_first: bool = False
    spread: dict[str, float] | None = None


def start_fit(
    processed: npt.NDArray[np.bool_],
    counts: npt.NDArray[Any],
    grid: Grid,
    beams: Beams | None = None,
    *,
    cells: tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]] | None = None,
    lines_first: bool | None = None,
) -> FitStart:
    """The first half of :func:`choose_fit` (same parameters): the map's column spans,
    the surfaces on its ridge and the choice between one function and surfaces; what
    needs only the map. ``run`` computes it while the align stage decides whether the
    map is the run's (:func:`sonarproc.pipeline.run.process`)."""
    if not np.any(processed):
        empty = find_surfaces(processed, grid, counts)
        return FitStart(AutoFit("surfaces", "nothing is left to fit", empty, {"surfaces": 0}))
    spans = column_spans(processed, grid.cell, cells=cells)
    median = float(np.median(spans)) if spans.size else 0.0
    p90 = float(np.percentile(spans, 90)) if spans.size else 0.0
    spread = {"median_column_span_m": median, "p90_column_span_m": p90}
    fast = (
        f"one function of x when the kept cells of the median column span <= "
        f"{MEDIAN_SPAN_M:g} m and those of 90 % of the columns <= {P90_SPAN_M:g} m"
    )
    if median <= MEDIAN_SPAN_M and p90 <= P90_SPAN_M:
        return FitStart(AutoFit("function", fast, None, spread))
    if lines_first is None:
        lines_first = beams is not None and beams.path.size >= LINES_FIRST_READINGS
    if beams is not None and lines_first:
        return FitStart(None, lines_first=True, spread=spread)
    if beams is not None:
        ex_counts, ex_grid = coarse_counts(counts, grid, EXTRACT_CELL_M)
    else:
        ex_counts, ex_grid = np.asarray(counts), grid
    kept = ridge_nms(vote(ex_counts > 0, ex_counts, SURFACE_VOTES), ex_counts)
    found = find_surfaces(kept, ex_grid, ex_counts)
    decision = decide(found)
    detail = {**spread, **decision.to_json()}
    detail.pop("choice", None)
    criterion = detail.pop("criterion")
    if decision.single_function:
        return FitStart(AutoFit("function", str(criterion), None, detail))
    return FitStart(None, found, detail, str(criterion), (ex_counts, ex_grid))


def choose_fit(
    processed: npt.NDArray[np.bool_],
    counts: npt.NDArray[Any],
    grid: Grid,
    beams: Beams | None = None,
    *,
    cells: tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]] | None = None,
    lines_first: bool | None = None,
    start: FitStart | None = None,
) -> AutoFit:
    """Decide between the paper's polynomial and several surfaces (see the module notes).

    Parameters
    ----------
    processed : ndarray of bool
        The cells the ``ops`` chain kept.
    counts : ndarray of int
        Arc counts per cell (the evidence of the map).
    grid : Grid
        The maps' grid.
    beams : Beams, optional
        The mapped readings: surfaces are refitted through their echo points (without
        them, the fits to the ridge cells are kept).
    cells : tuple of ndarray, optional
        ``np.nonzero(processed.T)``, when the caller has it already.
    lines_first : bool, optional
        Find the walls from the readings' tangent votes first (:func:`_lines_first`);
        by default when ``beams`` holds at least :data:`LINES_FIRST_READINGS` readings.
        ``--auto`` scores a long log's surfaces on subsets of it with the fit the run on
        every reading makes.
    start : FitStart, optional
        :func:`start_fit` of these same arguments, when the caller has it already.

    Returns
    -------
    AutoFit
    """
    s = start
    if s is None:
        s = start_fit(processed, counts, grid, beams, cells=cells, lines_first=lines_first)
    if s.answer is not None:
        return s.answer
    if s.lines_first:
        assert beams is not None and s.spread is not None
        return _lines_first(counts, grid, beams, s.spread)
    assert s.found is not None and s.detail is not None and s.extract is not None
    found, detail = s.found, dict(s.detail)
    if beams is not None and found.surfaces:
        found = refine_surfaces(found, beams, grid.cell, counts=s.extract)
        detail["surfaces"] = len(found.surfaces)
    return AutoFit("surfaces", s.criterion, found, detail)


def _lines_first(
    counts: npt.NDArray[Any], grid: Grid, beams: Beams, spread: dict[str, float]
) -> AutoFit:
    """A long log's surfaces: walls from the readings' tangent votes, the rest from the map.

    The walls (:func:`sonarproc.surfaces.echoes.tangents.tangent_lines`) explain most readings
    of a building; the ridge of the arc map is then extracted from the arcs of the
    readings they leave, and the two refitted together through the echo points.
    """
    echoes = EchoGeometry.of_poses(beams.poses, beams.path)
    assert echoes.rows is not None  # made by from_beams
    segs, claimed = tangent_lines(
        echoes, tol=TANGENT_TOL_M, min_votes=LINE_MIN_VOTES, bridge_m=BRIDGE_M,
        min_spread_m=MIN_SPREAD_M,
    )  # fmt: skip
    # point reflectors (corners, edges) from the readings the walls do not own, outside them
    own = np.zeros(echoes.size, dtype=bool)
    for g in segs:
        own[g.readings] = True
    walls = [(g.points[0], g.points[-1]) for g in segs]
    points = _claim_at_wall_ends(echoes, counts, grid, ~own, walls)
    claimed |= points.claimed
    sets = [SurfaceCells(g.points[:, 0], g.points[:, 1], g.along, np.ones(g.along.size), False)
            for g in segs]  # fmt: skip
    fitted = fit_surfaces(sets, cell=grid.cell)
    fits = [f for f in fitted if isinstance(f, SurfaceFit)]
    cells = [c for c, f in zip(sets, fitted, strict=True) if isinstance(f, SurfaceFit)]
    failures = [f for f in fitted if isinstance(f, SurfaceFailure)]
    rest = np.ones(beams.path.size, dtype=bool)
    rest[echoes.rows[claimed]] = False
    left = int(rest.sum())
    mapped = left >= max(MIN_ECHOES, RESIDUAL_SHARE * beams.path.size)
    if mapped:
        arcs = beams.arcs[rest[beams.arcs.arc]]  # type: ignore[index]
        ex_counts, ex_grid = coarse_counts(rasterize(arcs, grid), grid, EXTRACT_CELL_M)
        kept = ridge_nms(vote(ex_counts > 0, ex_counts, SURFACE_VOTES), ex_counts)
        found = find_surfaces(kept, ex_grid, ex_counts)
        fits += found.surfaces
        cells += found.cells
        failures += found.failures
    # the walls lie on their readings' echo points already: without the map's ridges (and
    # their chance ones, and their bias) the screen and the first, wide round are not needed
    rounds = ROUNDS_M if mapped else ROUNDS_M[-1:]
    silent = silent_geometry(beams)
    refined, refined_cells = refine_with_points(
        lambda e: refine_fits(
            fits, cells, e, cell=grid.cell, rounds=rounds, screen=mapped, silent=silent
        ),
        echoes, points, exclude=False,
    )  # fmt: skip
    reason = None if refined else "no reading echoes from any surface found"
    found = SurfaceSet(refined, failures, int(np.count_nonzero(counts)), 0, reason, refined_cells)
    criterion = (
        f"a log of >= {LINES_FIRST_READINGS} readings: walls from the readings' tangent "
        "votes, the rest from the ridge of the arcs they leave, all refitted through the "
        "echo points"
    )
    detail = {**spread, "surfaces": len(refined), "tangent_lines": len(segs),
              "readings_left_to_the_map": left}  # fmt: skip
    return AutoFit("surfaces", criterion, found, detail)


def _claim_at_wall_ends(
    echoes: EchoGeometry,
    counts: npt.NDArray[Any],
    grid: Grid,
    free: npt.NDArray[np.bool_],
    walls: list[tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]],
) -> ClaimedPoints:
    """A long log's point reflectors: near its walls' ends, from the ``free`` readings,
    found on the arc counts summed to :data:`EXTRACT_CELL_M` cells (made for them alone)."""
    return claim_points(echoes, *coarse_counts(counts, grid, EXTRACT_CELL_M), free=free,
                        walls=walls, ends_only=True)  # fmt: skip


def refine_surfaces(
    found: SurfaceSet,
    beams: Beams,
    cell: float,
    *,
    counts: tuple[npt.NDArray[Any], Grid] | None = None,
) -> SurfaceSet:
    """``found`` refitted through the readings' echo points (surfaces nothing echoes from go).

    Given the arc ``counts`` and their grid, the point reflectors (corners, edges) are
    found first and their readings kept out of the refits
    (:mod:`sonarproc.surfaces.reflectors`); they are appended as surfaces of one point.
    """
    echoes = EchoGeometry.of_poses(beams.poses, beams.path)
    silent = silent_geometry(beams)
    if counts is None:
        fits, cells = refine_fits(found.surfaces, found.cells, echoes, cell=cell, silent=silent)
    else:
        points = claim_points(echoes, *counts)
        fits, cells = refine_with_points(
            lambda e: refine_fits(
                found.surfaces, found.cells, e, cell=cell, witnesses=echoes, silent=silent
            ),
            echoes,
            points,
        )
    reason = None if fits else "no reading echoes from any surface found on the ridge"
    assigned = found.cells_assigned if fits else 0
    return SurfaceSet(fits, found.failures, found.cells_kept, assigned, reason, cells)


def silent_geometry(beams: Beams) -> EchoGeometry | None:
    """The readings that heard nothing, each as a sensor with its largest range."""
    p = beams.silent
    if p is None:
        return None
    hb = np.minimum(p.tx_half_beamwidth, p.rx_half_beamwidth)
    return EchoGeometry(p.tx_xy, p.tx_heading, hb, np.asarray(p.max_range, dtype=np.float64))


def measure_surfaces(
    found: SurfaceSet,
    truth: npt.NDArray[np.float64],
    arcs_args: tuple[Any, ...],
    *,
    seen: npt.NDArray[np.bool_] | None = None,
    **beams: Any,
) -> dict[str, Any]:
    """Precision and completeness of the fitted surfaces against a multi-surface truth.

    ``arcs_args`` and ``beams`` are the readings' geometry (transmitter and receiver
    positions and headings, path lengths; half beamwidths), which says which part of the
    truth the sonars could see; ``seen`` is that part when the caller has it already
    (:func:`seen_of_truth` of the same readings).
    """
    if seen is None:
        pts = np.concatenate(truth_points(truth))
        seen = seen_truth(pts, *arcs_args, **beams)
    return dict(surface_metrics(found.polylines(), truth, seen=seen).to_json())


def seen_of_truth(truth: npt.NDArray[np.float64], beams: Beams) -> npt.NDArray[np.bool_]:
    """The points of ``truth`` (:func:`truth_points`) some reading of ``beams`` could have
    produced (:func:`seen_truth`): what :func:`measure_surfaces` measures completeness on."""
    tp = beams.poses
    pts = np.concatenate(truth_points(truth))
    return seen_truth(pts, tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, beams.path,
                      tx_half_beamwidth=tp.tx_half_beamwidth,
                      rx_half_beamwidth=tp.rx_half_beamwidth)  # fmt: skip


def surface_kind(model: str | None) -> str:
    """The reflector kind (``plane``, ``cylinder``, ``curve``, ``corner``, ``edge``) of a model.

    >>> surface_kind("line"), surface_kind("arc"), surface_kind("spline")
    ('plane', 'cylinder', 'curve')
    >>> surface_kind("corner"), surface_kind(None)
    ('corner', 'curve')
    """
    return kind_of(model)


def surfaces_fit_record(found: SurfaceSet) -> dict[str, Any]:
    """``report.json``'s ``fit`` for a surfaces fit (Contract 2, v3).

    A surfaces fit is a successful fit when at least one surface was fitted: ``ok``,
    ``surfaces`` (how many were fitted), ``failed`` (how many could not be), and
    ``kinds`` (how many of each reflector kind). With none, ``ok`` is false and
    ``reason`` says why.

    >>> r = surfaces_fit_record(SurfaceSet([], [], 0, 0, "nothing kept"))
    >>> r["kind"], r["ok"], r["surfaces"], r["reason"]
    ('surfaces', False, 0, 'nothing kept')
    """
    kinds: dict[str, int] = {}
    for s in found.surfaces:
        k = surface_kind(s.model)
        kinds[k] = kinds.get(k, 0) + 1
    n = len(found.surfaces)
    record: dict[str, Any] = {
        "kind": "surfaces",
        "ok": n > 0,
        "surfaces": n,
        "failed": len(found.failures),
        "kinds": dict(sorted(kinds.items())),
    }
    if n == 0:
        record["reason"] = str(found.reason or "no surface could be fitted")
    return record

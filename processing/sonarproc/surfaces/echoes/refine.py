"""Surfaces refitted through their readings' specular echo points.

A sonar's range arc is tangent to the surface that reflected it, at the one point where
the surface's normal points at the sensor, and lies on the sensor's side of the surface
everywhere else. Where many arcs touch a surface at one point (the robot driving towards
a wall, or round a pillar) the crest of the arc counts therefore lies on the sensors'
side of the surface, and arcs crossing at a shallow angle (the tails of a bundle) make
ridges where there is no surface at all. The ridge gives a first estimate of each
surface; this module replaces it by the surface through the readings' echo points
(:mod:`sonarproc.surfaces.echoes.specular`: the point at the measured range along the
perpendicular from the sensor).

The direction of the foot is the surface normal even when the estimate is displaced
along it, so the echo points lie on the true surface: the refit removes the bias. Each
surface is refitted (:func:`~sonarproc.surfaces.fitting.batch.fit_surfaces`, same criterion)
through its echo points, twice, with the tolerances of :data:`ROUNDS_M` (a spline that
is two straight walls meeting at an obtuse corner becomes their two lines:
:mod:`sonarproc.surfaces.fitting.bends`; a long log's
first round scores a fixed random subset of :data:`FIRST_ROUND_READINGS` readings, with
the fewest echoes scaled down alike: that round only weeds out the chance ridges, a
thousand of them in an hour's log of a room, and refits the rest roughly for the last
round, which scores every reading); a surface that fewer than :data:`MIN_ECHOES`
readings echo from, or whose echo points span less than :data:`MIN_SPREAD_M`, is dropped
(no reading reflected there, or only at one point), unless those readings came from
depths along one pass far enough apart to fix its direction: a wall heard head on, which
is refitted square to the pass (:mod:`sonarproc.surfaces.echoes.approach`; its ridge,
fitted as an arc none of its readings echoes from, is first replaced by the tangent
where the arcs touch); so is one
that more than :data:`MAX_SEEN_THROUGH` of the readings facing it see through (their
range reaches beyond it: a chance crossing of arcs in free space, which the sound
crossed; a real surface is seen through only by a stray long echo). The rounds
count the readings whose arcs end near a surface, and only between the feet of its
outermost echoes: a fit runs on past its echoes over its ridge (the tails of the arcs
reach beyond a desk's or a workbench's face), sound passing beyond those feet says where
the surface ends (the openings' cut ends it there), not that it is absent, and a chance
crossing of arcs is crossed by sound between its echoes, where it would stand. That holds
for a surface heard by few readings (a sparse log's short face) as for one heard by
many, once its echoes' feet span :data:`MIN_SPREAD_M` (echoes at one spot span nothing
to be seen through, and the readings beside them are then the only test). After the
last round, a surface fewer than
:data:`WEAK_ECHOES` readings echo from is tested against every reading, between its
outermost echo points (the phantoms have few echoes, and the sound that crossed them may
end far behind; a fit's ends are stretched beyond its echoes, and sound passing the end
of a box did not cross it).
After every round a refitted line or open arc is stretched over the ridge cells within
that round's tolerance of it (the ridge sees the surface further than the perpendiculars
reach; and a fit through echo points ends at the outermost ones, whose feet would fall on
its ends in the next round), by at most :data:`MAX_STRETCH_M` at each end. Before the
first round the straight pieces that no reading of that round echoes from are dropped
(:mod:`sonarproc.surfaces.echoes.screen`: half the chance ridges of an hour's log, found far
faster than by that round) and the pieces of one wall are joined
(:mod:`sonarproc.surfaces.fitting.merge`); after the last, of two surfaces that contradict each
other the weaker goes (:mod:`sonarproc.surfaces.echoes.occlusion`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.approach import approach_line, join_directed, spread_m
from sonarproc.surfaces.echoes.occlusion import contradicted, path_ends
from sonarproc.surfaces.echoes.openings import STRAIGHT_SHARE, cut_openings, join_pieces
from sonarproc.surfaces.echoes.screen import screen_fits
from sonarproc.surfaces.echoes.specular import EchoGeometry, count_seen_through, echo_points
from sonarproc.surfaces.echoes.support import (
    MAX_SEEN_THROUGH,
    MIN_ECHOES,
    MIN_SPREAD_M,
    MIN_VIEWPOINTS,
    WEAK_ECHOES,
    enough,
    head_on_arcs,
    seen_through,
    surfaces_left,
    unsupported,
)
from sonarproc.surfaces.echoes.unseen import cut_unseen
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.bends import points_subset, straight_pieces
from sonarproc.surfaces.fitting.merge import merge_collinear
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit
from sonarproc.surfaces.freespace import FreeCones, viewpoint_ids
from sonarproc.surfaces.planar.polylines import resample

__all__ = [
    "MAX_SEEN_THROUGH", "MIN_ECHOES", "MIN_SPREAD_M", "MIN_VIEWPOINTS", "ROUNDS_M", "WEAK_ECHOES",
    "refine_fits",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Range tolerances (m) of the refinement rounds: the first covers the ridge's bias.
ROUNDS_M = (0.08, 0.03)
#: The first round scores at most about this many readings (a random subset, the same
#: for every run of a log); the last round scores every reading.
FIRST_ROUND_READINGS = 20_000
#: A refitted line or arc is stretched over nearby ridge cells by at most this (m) at
#: each end.
MAX_STRETCH_M = 0.25


def _extend(fit: SurfaceFit, cells: SurfaceCells, tol: float, cell: float) -> SurfaceFit:
    """Stretch a refitted line or open arc over the ridge cells within ``tol`` of it."""
    if fit.closed or cells.size == 0:
        return fit
    x, y = cells.x, cells.y
    if fit.model == "line":
        c, t = np.asarray(fit.params["point"]), np.asarray(fit.params["direction"])
        near = np.abs((x - c[0]) * -t[1] + (y - c[1]) * t[0]) <= tol
        u0 = (fit.polyline - c) @ t
        u = (np.stack((x, y), 1)[near] - c) @ t
        u = np.clip(np.concatenate((u0, u)), u0.min() - MAX_STRETCH_M, u0.max() + MAX_STRETCH_M)
        poly = resample(np.stack((c + t * u.min(), c + t * u.max())), cell)
        if (fit.polyline[-1] - fit.polyline[0]) @ t < 0:
            poly = poly[::-1]
    elif fit.model == "arc":
        cx, cy = fit.params["centre"]
        r = float(fit.params["radius"])
        near = np.abs(np.hypot(x - cx, y - cy) - r) <= tol
        start, sweep = float(fit.params["start_rad"]), float(fit.params["sweep_rad"])
        mid = start + 0.5 * sweep
        ang = mid + (np.arctan2(y[near] - cy, x[near] - cx) - mid + math.pi) % (2 * math.pi)
        ang -= math.pi
        ends = np.array([start, start + sweep])
        lo, hi = float(ends.min()), float(ends.max())
        if ang.size:
            reach = MAX_STRETCH_M / r
            lo = max(min(lo, float(ang.min())), lo - reach)
            hi = min(max(hi, float(ang.max())), hi + reach)
        if hi - lo >= 2 * math.pi:
            return fit
        k = max(2, math.ceil((hi - lo) * r / cell) + 1)
        phi = np.linspace(lo, hi, k)
        poly = np.stack((cx + r * np.cos(phi), cy + r * np.sin(phi)), axis=1)
        if sweep < 0:
            poly = poly[::-1]
    else:
        return fit
    length = float(np.hypot(*np.diff(poly, axis=0).T).sum())
    return replace(fit, polyline=poly, length_m=length)


def _pieces(
    fit: SurfaceFit, points: SurfaceCells, rows: IntArray, cell: float, noise: float
) -> list[tuple[SurfaceFit, SurfaceCells, IntArray]]:
    """A refit, or the straight walls its spline rounds a corner of
    (:func:`~sonarproc.surfaces.fitting.bends.straight_pieces`), with their echo points
    and readings' indices."""
    pieces = straight_pieces(points, cell=cell, scatter=noise) if fit.model == "spline" else None
    if pieces is None:
        return [(fit, points, rows)]
    return [(piece, points_subset(points, idx), rows[idx]) for piece, idx in pieces]


def _scored(echoes: EchoGeometry, r: int, rounds: int, min_echoes: int) -> tuple[EchoGeometry, int]:
    """The readings round ``r`` scores, and the fewest echoes it keeps a surface with.

    Rounds before the last weed out chance ridges (a thousand in an hour's log): a fixed
    subset of :data:`FIRST_ROUND_READINGS` readings does that at a fraction of the cost.
    """
    if r == rounds - 1 or echoes.size <= FIRST_ROUND_READINGS:
        return echoes, min_echoes
    frac = FIRST_ROUND_READINGS / echoes.size
    keep = np.random.default_rng(0).random(echoes.size) < frac
    return echoes.subset(keep), max(2, math.ceil(min_echoes * frac))


def _joined(a: EchoGeometry, b: EchoGeometry) -> EchoGeometry:
    """The readings of ``a``, then those of ``b`` (``a``'s rows keep their indices)."""
    return EchoGeometry(np.concatenate((a.xy, b.xy)), np.concatenate((a.heading, b.heading)),
                        np.concatenate((a.half_beam, b.half_beam)),
                        np.concatenate((a.range_m, b.range_m)))  # fmt: skip


def _crossed(echoes: EchoGeometry, witnesses: EchoGeometry | None) -> EchoGeometry | None:
    """The ``witnesses`` not among ``echoes`` (by their rows): the point reflectors' readings.

    A corner or an edge heard through a doorway answers readings whose sound crossed the
    doorway: they echo from no surface, but they are free space up to their range as
    much as a wall's readings are (Leonard & Durrant-Whyte 1991: every range bounds the
    empty cone in front of its sensor). Without their rows the two cannot be told apart,
    and none are added.

    Examples
    --------
    >>> g = EchoGeometry(np.zeros((3, 2)), np.zeros(3), np.full(3, 0.2), np.ones(3),
    ...                  np.arange(3))
    >>> _crossed(g.subset(np.array([True, False, True])), g).rows.tolist()
    [1]
    """
    if witnesses is None or witnesses.rows is None or echoes.rows is None:
        return None
    return witnesses.subset(~np.isin(witnesses.rows, echoes.rows))


def refine_fits(
    fits: list[SurfaceFit],
    cells: list[SurfaceCells],
    echoes: EchoGeometry,
    *,
    cell: float,
    rounds: tuple[float, ...] = ROUNDS_M,
    min_echoes: int = MIN_ECHOES,
    screen: bool = True,
    witnesses: EchoGeometry | None = None,
    silent: EchoGeometry | None = None,
) -> tuple[list[SurfaceFit], list[SurfaceCells]]:
    """Refit surfaces through their readings' echo points (see the module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The surfaces fitted to the ridge cells.
    cells : list of SurfaceCells
        Their ridge cells (same order).
    echoes : EchoGeometry
        The readings.
    cell : float
        Cell size (m): the polylines' step and the fits' unit.
    rounds : tuple of float
        Range tolerance (m) of each round.
    min_echoes : int
        A surface with fewer echoing readings is dropped.
    screen : bool
        Drop the straight pieces no reading echoes from before the rounds (the chance
        ridges of a map; surfaces found from the readings themselves need no screen).
    witnesses : EchoGeometry, optional
        The readings the last test for surfaces seen through counts (default:
        ``echoes``): every reading, when ``echoes`` leaves out those of point
        reflectors (they echo from no surface, but their sound crossed free space). Those
        not in ``echoes`` are free space for the openings' cut and the joins of pieces
        too (:func:`_crossed`); the test of stretches hidden behind something else
        keeps to ``echoes``: a point's readings faced the point, not the walls.
    silent : EchoGeometry, optional
        Readings that heard nothing, with their sensor's largest range as ``range_m``:
        free space up to there, which cuts walls at openings as the echoes' does
        (:mod:`sonarproc.surfaces.echoes.openings`).

    Returns
    -------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        The refitted surfaces (longest first) and their echo points as cells.
    """
    # straight pieces no reading of the first round echoes from go at once (most of the
    # chance ridges); pieces of one wall cut apart on the ridge share its echoes: join them
    cur, ridge = list(fits), list(cells)
    if rounds and screen:
        first, _ = _scored(echoes, 0, len(rounds), min_echoes)
        cur, ridge = screen_fits(cur, ridge, first, tol=rounds[0])
    every = echoes if silent is None else _joined(echoes, silent)
    cones = FreeCones.of(every.xy, every.heading, every.half_beam, every.range_m)
    # the openings' cut and joins: every reading's sound crossed free space up to its
    # range, whatever echoed (rows after ``every``'s own, which the echo points index)
    crossed = _crossed(echoes, witnesses)
    if crossed is not None and crossed.size:
        every = _joined(every, crossed)
        open_cones = FreeCones.of(every.xy, every.heading, every.half_beam, every.range_m)
    else:
        open_cones = cones
    # the ridge lies up to the first round's tolerance off the wall
    cur, ridge = merge_collinear(cur, ridge, cell=cell, cones=cones,
                                 margin=rounds[0] if rounds else ROUNDS_M[0])  # fmt: skip
    if rounds:
        # the crest of a wall heard head on bends towards the sensors and is fitted as an
        # arc none of them echoes from: the wall is its tangent where the arcs touch
        first, need = _scored(echoes, 0, len(rounds), min_echoes)
        cur = head_on_arcs(cur, first, rounds[0], need, cell)
    pts_cells: list[SurfaceCells] = []
    pts_idx: list[IntArray] = []
    # the most a reading's echo point scatters about its surface: the last round's range
    # tolerance as an RMS (uniform within it), whatever a looser round gathered
    noise = STRAIGHT_SHARE * rounds[-1] if rounds else 0.0
    for r, tol in enumerate(rounds):
        scored, need = _scored(echoes, r, len(rounds), min_echoes)
        # a surface with echoes enough to stay, over a stretch of its own, is seen through
        # only between them, as after the last round: its ridge may run on past them
        # (module notes)
        got = echo_points([f.polyline for f in cur], [f.closed for f in cur], scored, tol=tol,
                          spanned_from=need, spanned_over=MIN_SPREAD_M)  # fmt: skip
        view = viewpoint_ids(scored.xy)
        nxt: list[SurfaceFit] = []
        nxt_ridge: list[SurfaceCells] = []
        pts_cells, pts_idx = [], []
        todo = [
            k
            for k, (idx, pts, _, through) in enumerate(got)
            if enough(idx, pts, view, need, scored.range_m) and not seen_through(idx.size, through)
        ]
        sets = [
            SurfaceCells(got[k][1][:, 0], got[k][1][:, 1], got[k][2] - got[k][2][0],
                         np.ones(got[k][0].size), cur[k].closed)
            for k in todo
        ]  # fmt: skip
        refits = fit_surfaces(sets, cell=cell, scatter=noise)
        # echo points at one spot, heard head on: the wall square to the pass (approach)
        refits = [
            approach_line(ec, scored.xy[got[k][0]], cell=cell)
            if spread_m(ec) < MIN_SPREAD_M and not ec.closed else new
            for k, ec, new in zip(todo, sets, refits, strict=True)
        ]  # fmt: skip
        for k, ec, new in zip(todo, sets, refits, strict=True):
            if isinstance(new, SurfaceFailure):
                continue
            for piece, sub, rows in _pieces(new, ec, got[k][0], cell, noise):
                # stretched over its ridge before the next round: a fit through echo
                # points ends at the outermost ones, whose feet would then fall on its ends
                nxt.append(_extend(replace(piece, arcs=int(rows.size)), ridge[k], tol, cell))
                nxt_ridge.append(ridge[k])
                pts_cells.append(sub)
                pts_idx.append(rows)
        cur, ridge = nxt, nxt_ridge
    if rounds:
        # openings: free space (readings that saw through a wall) cuts it
        cur, pts_cells, pts_idx = cut_openings(cur, pts_cells, pts_idx, open_cones,
                                               margin=rounds[-1], cell=cell)  # fmt: skip
        cur, pts_cells, pts_idx = surfaces_left(
            cur, pts_cells, pts_idx, cones, min_echoes, echoes.range_m
        )
        # ... and joins the pieces of one wall where it did not see through the gap; a
        # stretch no sensor could see at all is not wall, though
        # (a piece heard only head on has no direction of its own to be collinear by)
        cur, pts_cells, pts_idx = join_directed(
            lambda f, p, i: join_pieces(f, p, i, open_cones, margin=rounds[-1], cell=cell),
            cur, pts_cells, pts_idx, min_spread=MIN_SPREAD_M,
        )  # fmt: skip
        cur, pts_cells, pts_idx = cut_unseen(cur, pts_cells, pts_idx, cones, margin=rounds[-1],
                                              cell=cell)  # fmt: skip
        cur, pts_cells, pts_idx = surfaces_left(
            cur, pts_cells, pts_idx, cones, min_echoes, echoes.range_m
        )
    weak = [i for i, idx in enumerate(pts_idx) if idx.size < WEAK_ECHOES]
    through = count_seen_through(
        [cur[i].polyline for i in weak],
        [cur[i].closed for i in weak],
        echoes if witnesses is None else witnesses,
        tol=rounds[-1],
        confirmed=[np.stack((pts_cells[i].x, pts_cells[i].y), axis=1) for i in weak],
    )
    drop = {i for i, n in zip(weak, through, strict=True) if seen_through(pts_idx[i].size, n)}
    drop |= set(
        contradicted(
            [f.polyline for f in cur],
            [echoes.xy[i] for i in pts_idx],
            path_ends(
                [f.polyline for f in cur],
                [f.closed for f in cur],
                [echoes.xy[i] for i in pts_idx],
                [echoes.range_m[i] for i in pts_idx],
            ),
            cell=cell,
        )
    )
    if rounds:
        drop |= set(unsupported(cur, echoes, rounds[-1], min_echoes))
    out = [
        replace(f, viewpoints=int(np.unique(cones.viewpoint[pts_idx[i]]).size))
        for i, f in enumerate(cur)
        if i not in drop
    ]
    pts_cells = [c for i, c in enumerate(pts_cells) if i not in drop]
    order = sorted(range(len(out)), key=lambda i: -out[i].length_m)
    return [out[i] for i in order], [pts_cells[i] for i in order]

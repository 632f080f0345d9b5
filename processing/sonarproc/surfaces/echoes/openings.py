"""Openings are never bridged, closed stretches are: free space cuts and joins walls.

A straight wall refitted through its echo points is one line from its first echo to its
last, stretched a little over its ridge. Where it passes a doorway, the readings facing
the doorway did not echo from the line: their beams went through it and echoed from the
room behind (:mod:`sonarproc.surfaces.freespace`: their *free feet* lie on the line).

Along the line, the echoing readings' feet and the free feet alternate. Between two
consecutive echo feet (or between the outermost echo foot and the line's end, or just
past the end, within :data:`END_LOOK_M`), a stretch
holding free feet from :data:`~sonarproc.surfaces.freespace.MIN_FREE_POSES` distinct
viewpoints is open: the wall is cut there. The true end of the wall lies between the
nearest free foot and its last echo foot less the reach of the end's own echo: a free end
is a convex edge, and sensors whose feet lie past it still hear it, at a range within the
tolerance of the wall's (:func:`end_echo_reach`, about a beam's width at a metre). Each
side ends halfway between those two (the estimate with the smallest largest error). A
stretch with no free feet stays closed, however long: nothing saw through it.

The pieces keep the line of the whole fit (both sides of a doorway are one wall, and the
line through all their echo points is the better estimate); a piece whose echoes no
longer make a surface (too few, from too few viewpoints, or spread over too little) is
dropped, as the refinement drops such surfaces.

The other way round, :func:`join_pieces` joins refitted surfaces that are pieces of one
wall (:func:`~sonarproc.surfaces.fitting.merge.collinear_groups`: on one line within their
fits' uncertainty, and no gap between them that readings from two viewpoints saw
through), however long the gap. A sparse log leaves a wall in pieces, some of which
are fitted as flat arcs or splines; a surface counts as straight here when its echo
points lie within :data:`STRAIGHT_SHARE` of the range tolerance (RMS) of a line, the
RMS of points spread evenly over that tolerance either side: the echoes cannot tell it
from a line. The pooled echo points are fitted again (model chosen by the same
criterion).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import fit_surfaces
from sonarproc.surfaces.fitting.merge import collinear_groups, pool_cells
from sonarproc.surfaces.fitting.models import SurfaceFailure, SurfaceFit
from sonarproc.surfaces.freespace import MIN_FREE_POSES, FreeCones, free_feet
from sonarproc.surfaces.planar.polylines import resample
from sonarsim.transducer import PISTON_FIRST_NULL, TransducerParams

__all__ = ["STRAIGHT_SHARE", "cut_openings", "end_echo_reach", "join_pieces", "split_line"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Free feet are looked for this far (m) past a line's ends: as far as a refit stretches
#: a line over its ridge beyond its echoes
#: (:data:`~sonarproc.surfaces.echoes.refine.MAX_STRETCH_M`), so an end the sound passed
#: just beyond is placed as a cut's end is.
END_LOOK_M = 0.25
#: A surface whose echo points lie within this share of the range tolerance (RMS) of a
#: line is straight to the sonar (1 / sqrt(3): points spread evenly within it).
STRAIGHT_SHARE = 1.0 / np.sqrt(3.0)


def end_echo_reach(dist: npt.ArrayLike, half_beam: npt.ArrayLike, margin: float) -> FloatArray:
    """How far past a wall's free end (m, along the wall) a sensor ``dist`` m from its line
    still takes the end's echo for the wall's own.

    A wall's free end (a door jamb, the end of a partition) is a convex edge: it
    diffracts, a weak point source heard over the main lobe while its amplitude
    ``rho_e D(theta)^2 (r_ref / r)^n`` clears the receiver threshold (Kuc & Siegel 1987;
    the amplitude of :func:`sonarsim.transducer.main_lobe_amplitude` with the edge's
    reflectivity and spreading of :class:`sonarsim.transducer.TransducerParams`). A
    sensor whose foot lies ``u`` past the end hears it at ``sqrt(dist^2 + u^2)``: within
    the range tolerance ``margin`` of the wall's own distance while
    ``u <= sqrt((dist + margin)^2 - dist^2)``, so the wall's echo feet run on past its end
    by up to the lesser of that and ``dist tan(theta)``, the widest angle at which the end
    is heard. With the Gaussian main lobe (``D^2 = exp(-(ka sin theta)^2 / 4)``, ``ka``
    from the nominal half-width as the piston's first null) that angle has
    ``ka sin theta = 2 sqrt(ln(A0 / threshold))``, ``A0`` the head-on amplitude at
    ``dist`` (taken for the whole slant range: the reach is not understated); 0 where
    even head-on the end is too weak to hear.

    Examples
    --------
    A jamb 0.6 m, 1.1 m and 2 m from a sensor with a 12.5 degree half beam:

    >>> end_echo_reach([0.6, 1.1, 2.0], np.radians(12.5), 0.03).round(3).tolist()
    [0.116, 0.124, 0.0]
    """
    tp = TransducerParams()
    d = np.maximum(np.asarray(dist, dtype=np.float64), 1e-3)
    ka = PISTON_FIRST_NULL / np.sin(np.clip(half_beam, 1e-3, 0.5 * np.pi))
    head_on = tp.edge_reflectivity * (tp.reference_range / d) ** tp.edge_spreading_exponent
    ratio = np.maximum(head_on / tp.threshold, 1.0)
    sin_t = np.minimum(2.0 * np.sqrt(np.log(ratio)) / ka, 1.0 - 1e-12)
    heard = d * sin_t / np.sqrt(1.0 - sin_t**2)
    within = np.sqrt((d + margin) ** 2 - d**2)
    return np.asarray(np.minimum(heard, within), dtype=np.float64)


def _open_intervals(
    echo_s: FloatArray, free_s: FloatArray, free_view: IntArray
) -> tuple[IntArray, FloatArray, FloatArray]:
    """The open intervals between sorted echo feet ``echo_s`` (interval ``k`` lies
    before echo ``k``; ``len(echo_s)`` is the one after the last), and the smallest and
    largest free foot in each."""
    k = np.searchsorted(echo_s, free_s)
    # free feet at an echo foot's own position say nothing
    pairs = np.unique(np.stack((k, free_view), axis=1), axis=0)
    views = np.bincount(pairs[:, 0], minlength=echo_s.size + 1)
    opened = np.flatnonzero(views >= MIN_FREE_POSES)
    lo = np.full(echo_s.size + 1, np.inf)
    hi = np.full(echo_s.size + 1, -np.inf)
    np.minimum.at(lo, k, free_s)
    np.maximum.at(hi, k, free_s)
    return opened.astype(np.intp), lo, hi


def _pieces(
    length: float, echo_s: FloatArray, free_s: FloatArray, free_view: IntArray,
    reach: FloatArray | None = None,
) -> list[tuple[float, float]]:  # fmt: skip
    """The stretches ``(start, end)`` of a line of ``length`` m that stay closed.

    ``reach``: how far past the wall's end each echo foot's sensor still hears the end
    (:func:`end_echo_reach`, same order as ``echo_s``; default none).
    """
    reach = np.zeros(echo_s.size) if reach is None else reach
    if echo_s.size == 0 or free_s.size == 0:
        return [(0.0, length)]
    opened, lo, hi = _open_intervals(echo_s, free_s, free_view)
    if opened.size == 0:
        return [(0.0, length)]
    pieces: list[tuple[float, float]] = []
    start = 0.0
    first_echo = 0  # the first echo foot of the current piece
    for k in opened.tolist():
        if k > 0 and k > first_echo:  # a piece with echoes ends before interval k
            end = min(0.5 * (echo_s[k - 1] - reach[k - 1] + lo[k]), length)
            pieces.append((start, end))
        if k < echo_s.size:
            start = max(0.5 * (hi[k] + echo_s[k] + reach[k]), 0.0)
            first_echo = k
        else:
            first_echo = echo_s.size + 1  # nothing after
    if first_echo <= echo_s.size - 1:
        pieces.append((start, length))
    return pieces


def cut_openings(
    fits: list[SurfaceFit],
    points: list[SurfaceCells],
    readings: list[IntArray],
    cones: FreeCones,
    *,
    margin: float,
    cell: float,
) -> tuple[list[SurfaceFit], list[SurfaceCells], list[IntArray]]:
    """Cut the straight surfaces where readings saw through them (see the module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The refitted surfaces.
    points : list of SurfaceCells
        Their echo points (same order).
    readings : list of ndarray of int
        The readings (rows of ``cones``) of those echo points.
    cones : FreeCones
        Every reading.
    margin : float
        Range tolerance (m) of the refit that placed the surfaces.
    cell : float
        The polylines' step (m).

    Returns
    -------
    fits, points, readings
        Curved surfaces unchanged; each straight one replaced by its closed pieces, in
        order (a piece is a :class:`SurfaceFit` on the same line).

    Examples
    --------
    A wall y = 1 from x = 0 to 3 heard from x = 0.1 .. 0.9 and 2.1 .. 2.9, and seen
    through from x = 1.2 .. 1.8 (a doorway from 1 to 2):

    >>> from sonarproc.surfaces.fitting.batch import fit_surfaces
    >>> xs = np.r_[np.arange(0.1, 0.95, 0.1), np.arange(2.1, 2.95, 0.1)]
    >>> xt = np.arange(1.2, 1.85, 0.1)
    >>> cones = FreeCones.of(np.c_[np.r_[xs, xt], 0 * np.r_[xs, xt]],
    ...                      np.full(xs.size + xt.size, np.pi / 2), np.full(xs.size + xt.size, 0.2),
    ...                      np.r_[np.ones(xs.size), np.full(xt.size, 3.0)])
    >>> x = np.arange(0.0, 3.001, 0.01)
    >>> wall = fit_surfaces([SurfaceCells(x, 1 + 0 * x, x, 1 + 0 * x, False)], cell=0.01)[0]
    >>> pts = SurfaceCells(xs, 1 + 0 * xs, xs - xs[0], 1 + 0 * xs, False)
    >>> cut, _, _ = cut_openings([wall], [pts], [np.arange(xs.size)], cones, margin=0.03,
    ...                          cell=0.01)
    >>> [(round(float(f.polyline[0, 0]), 2), round(float(f.polyline[-1, 0]), 2)) for f in cut]
    [(0.0, 0.99), (2.01, 3.0)]
    """
    line = [i for i, f in enumerate(fits) if f.model == "line" and not f.closed
            and len(f.polyline) >= 2]  # fmt: skip
    if not line or cones.size == 0:
        return list(fits), list(points), list(readings)
    a = np.array([fits[i].polyline[0] for i in line])
    b = np.array([fits[i].polyline[-1] for i in line])
    # free feet just past the ends too: an end the sound passed is a free end
    chord = b - a
    out_t = chord / np.maximum(np.hypot(*chord.T), 1e-300)[:, None] * END_LOOK_M
    seg, read, along = free_feet(a - out_t, b + out_t, cones, margin=margin)
    along = along - END_LOOK_M
    order = np.argsort(seg, kind="stable")
    seg, read, along = seg[order], read[order], along[order]
    bounds = np.searchsorted(seg, np.arange(len(line) + 1))
    cut: dict[int, list[tuple[SurfaceFit, SurfaceCells, IntArray]]] = {}
    for k, i in enumerate(line):
        lo, hi = bounds[k], bounds[k + 1]
        if lo == hi:
            continue
        f, p = fits[i], points[i]
        length = float(np.hypot(*(b[k] - a[k])))
        t = (b[k] - a[k]) / max(length, 1e-300)
        es = (np.stack((p.x, p.y), axis=1) - a[k]) @ t
        order = np.argsort(es, kind="stable")
        rows = readings[i][order]
        rel = cones.xy[rows] - a[k]
        dist = np.abs(rel[:, 0] * t[1] - rel[:, 1] * t[0])
        reach = end_echo_reach(dist, cones.half_beam[rows], margin)
        stretches = _pieces(length, es[order], along[lo:hi], cones.viewpoint[read[lo:hi]], reach)
        if stretches == [(0.0, length)]:
            continue
        cut[i] = split_line(f, p, readings[i], a[k], t, stretches, cell)
    new_fits: list[SurfaceFit] = []
    new_points: list[SurfaceCells] = []
    new_reads: list[IntArray] = []
    for i, whole in enumerate(zip(fits, points, readings, strict=True)):
        for f, p, r in cut.get(i, [whole]):
            new_fits.append(f)
            new_points.append(p)
            new_reads.append(r)
    return new_fits, new_points, new_reads


def split_line(
    fit: SurfaceFit,
    cells: SurfaceCells,
    rows: IntArray,
    start: FloatArray,
    direction: FloatArray,
    stretches: list[tuple[float, float]],
    cell: float,
) -> list[tuple[SurfaceFit, SurfaceCells, IntArray]]:
    """The pieces of a straight surface over ``stretches`` (m along it from ``start``).

    Each piece is the line over its stretch with the echo points (and their readings'
    rows) that fall in it, in order along the line; a stretch holding none gives no piece.
    """
    along = (np.stack((cells.x, cells.y), axis=1) - start) @ direction
    order = np.argsort(along, kind="stable")
    pieces = []
    for s0, s1 in stretches:
        inside = order[(along[order] >= s0) & (along[order] <= s1)]
        if inside.size == 0 or s1 <= s0:
            continue
        poly = resample(np.stack((start + direction * s0, start + direction * s1)), cell)
        sub = SurfaceCells(cells.x[inside], cells.y[inside], along[inside] - along[inside][0],
                           cells.weight[inside], False)  # fmt: skip
        piece = replace(fit, polyline=poly, length_m=float(s1 - s0),
                        support=int(inside.size), arcs=int(inside.size))  # fmt: skip
        pieces.append((piece, sub, rows[inside]))
    return pieces


def _spanning(fit: SurfaceFit, pieces: list[SurfaceFit], cell: float) -> SurfaceFit:
    """A line through pooled echo points, spanning its pieces (each was stretched over
    its ridge beyond its outermost echoes; the pooled fit ends at them)."""
    if fit.model != "line":
        return fit
    c = np.asarray(fit.params["point"], dtype=np.float64)
    t = np.asarray(fit.params["direction"], dtype=np.float64)
    u = np.concatenate([(p.polyline[[0, -1]] - c) @ t for p in pieces] + [(fit.polyline - c) @ t])
    poly = resample(np.stack((c + t * u.min(), c + t * u.max())), cell)
    if (fit.polyline[-1] - fit.polyline[0]) @ t < 0:
        poly = poly[::-1]
    return replace(fit, polyline=poly, length_m=float(u.max() - u.min()))


def join_pieces(
    fits: list[SurfaceFit],
    points: list[SurfaceCells],
    readings: list[IntArray],
    cones: FreeCones,
    *,
    margin: float,
    cell: float,
) -> tuple[list[SurfaceFit], list[SurfaceCells], list[IntArray]]:
    """Join the refitted pieces of one wall (see the module notes).

    Parameters and returns as :func:`cut_openings`; each group of pieces is replaced, where
    its first piece stood, by the surface fitted through their pooled echo points.

    Examples
    --------
    Two pieces of the wall y = 1, 0 .. 1 and 1.6 .. 3 m, nothing facing the gap:

    >>> x = np.r_[np.arange(0.1, 1.0, 0.1), np.arange(1.7, 2.95, 0.1)]
    >>> n = x.size
    >>> cones = FreeCones.of(np.c_[x, 0 * x], np.full(n, np.pi / 2), np.full(n, 0.2), np.ones(n))
    >>> pieces = [SurfaceCells(x[k], 1 + 0 * x[k], x[k] - x[k][0], 1 + 0 * x[k], False)
    ...           for k in (x < 1.3, x > 1.3)]
    >>> fits = fit_surfaces(pieces, cell=0.01)
    >>> joined, pts, idx = join_pieces(fits, pieces, [np.flatnonzero(x < 1.3),
    ...                                np.flatnonzero(x > 1.3)], cones, margin=0.03, cell=0.01)
    >>> [(f.model, round(f.length_m, 1), f.arcs) for f in joined]
    [('line', 2.8, 22)]
    >>> sorted(idx[0].tolist()) == list(range(n))
    True
    """
    groups = collinear_groups(fits, points, cell=cell, cones=cones, margin=margin,
                              straight_rms=STRAIGHT_SHARE * margin)  # fmt: skip
    if not groups:
        return list(fits), list(points), list(readings)
    # the readings ride along as the cells' weights while the pieces are pooled
    pooled = [
        pool_cells([replace(points[m], weight=readings[m].astype(np.float64)) for m in g])
        for g in groups
    ]
    refit = fit_surfaces(
        [replace(p, weight=np.ones(p.size)) for p in pooled],
        cell=cell,
        scatter=STRAIGHT_SHARE * margin,
    )
    group_of = {m: k for k, g in enumerate(groups) for m in g}
    out_f: list[SurfaceFit] = []
    out_p: list[SurfaceCells] = []
    out_r: list[IntArray] = []
    for i, (f, p, r) in enumerate(zip(fits, points, readings, strict=True)):
        k = group_of.get(i)
        new = None if k is None else refit[k]
        if k is None or isinstance(new, SurfaceFailure):
            out_f.append(f)
            out_p.append(p)
            out_r.append(r)
        elif i == groups[k][0] and new is not None:
            idx = pooled[k].weight.astype(np.intp)
            new = _spanning(new, [fits[m] for m in groups[k]], cell)
            out_f.append(replace(new, arcs=int(idx.size)))
            out_p.append(replace(pooled[k], weight=np.ones(idx.size)))
            out_r.append(idx)
    return out_f, out_p, out_r

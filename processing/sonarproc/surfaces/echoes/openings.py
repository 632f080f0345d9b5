"""Openings are never bridged: free space cuts a fitted wall.

A straight wall refitted through its echo points is one line from its first echo to its
last, stretched a little over its ridge. Where it passes a doorway, the readings facing
the doorway did not echo from the line: their beams went through it and echoed from the
room behind (:mod:`sonarproc.surfaces.freespace`: their *free feet* lie on the line).

Along the line, the echoing readings' feet and the free feet alternate. Between two
consecutive echo feet (or between the outermost echo foot and the line's end), a stretch
holding free feet from :data:`~sonarproc.surfaces.freespace.MIN_FREE_POSES` distinct
viewpoints is open: the wall is cut there. Each side ends halfway between its last echo
foot and the nearest free foot (the true end of the wall lies somewhere between them; the
midpoint is the estimate with the smallest largest error). A stretch with no free feet
stays closed, however long: nothing saw through it.

The pieces keep the line of the whole fit (both sides of a doorway are one wall, and the
line through all their echo points is the better estimate); a piece whose echoes no
longer make a surface (too few, from too few viewpoints, or spread over too little) is
dropped, as the refinement drops such surfaces.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import MIN_FREE_POSES, FreeCones, free_feet
from sonarproc.surfaces.planar.polylines import resample

__all__ = ["cut_openings"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


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
    length: float, echo_s: FloatArray, free_s: FloatArray, free_view: IntArray
) -> list[tuple[float, float]]:
    """The stretches ``(start, end)`` of a line of ``length`` m that stay closed."""
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
            end = 0.5 * (echo_s[k - 1] + lo[k])
            pieces.append((start, end))
        if k < echo_s.size:
            start = 0.5 * (hi[k] + echo_s[k])
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
    [(0.0, 1.05), (1.95, 3.0)]
    """
    line = [i for i, f in enumerate(fits) if f.model == "line" and not f.closed
            and len(f.polyline) >= 2]  # fmt: skip
    if not line or cones.size == 0:
        return list(fits), list(points), list(readings)
    a = np.array([fits[i].polyline[0] for i in line])
    b = np.array([fits[i].polyline[-1] for i in line])
    seg, read, along = free_feet(a, b, cones, margin=margin)
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
        o = np.argsort(es, kind="stable")
        stretches = _pieces(length, es[o], along[lo:hi], cones.viewpoint[read[lo:hi]])
        if stretches == [(0.0, length)]:
            continue
        out = []
        for s0, s1 in stretches:
            inside = o[(es[o] >= s0) & (es[o] <= s1)]
            if inside.size == 0 or s1 <= s0:
                continue
            poly = resample(np.stack((a[k] + t * s0, a[k] + t * s1)), cell)
            sub = SurfaceCells(p.x[inside], p.y[inside], es[inside] - es[inside][0],
                               p.weight[inside], False)  # fmt: skip
            piece = replace(f, polyline=poly, length_m=float(s1 - s0),
                            support=int(inside.size), arcs=int(inside.size))  # fmt: skip
            out.append((piece, sub, readings[i][inside]))
        cut[i] = out
    new_fits: list[SurfaceFit] = []
    new_points: list[SurfaceCells] = []
    new_reads: list[IntArray] = []
    for i, whole in enumerate(zip(fits, points, readings, strict=True)):
        for f, p, r in cut.get(i, [whole]):
            new_fits.append(f)
            new_points.append(p)
            new_reads.append(r)
    return new_fits, new_points, new_reads

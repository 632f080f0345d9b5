"""Straight ridge pieces no reading echoes from, dropped before the echo rounds.

An hour's log of a room leaves about a thousand chance ridges (arcs crossing in free
space) for a dozen walls, and the first echo round of :mod:`sonarproc.surfaces.echoes`
drops almost all of them, but only after they were merged (:mod:`sonarproc.surfaces.merge`)
and scored with the others. Half of them are straight pieces that no reading of that
round echoes from at all; :func:`screen_fits` drops those first. Such a piece adds no
echo to a wall it would have been merged with (the same readings, on nearly the same
line), so that wall keeps the echoes it needs.

:func:`echo_counts` counts the readings echoing from each straight polyline with the
test of :func:`~sonarproc.surfaces.specular.echo_points` (the foot of the sensor on the
line inside the polyline and inside the beam, its distance within ``tol`` of the range),
each reading counted for every surface it echoes from. Its pairs come from direction
bins of :data:`BIN_DEG`, not from a radius search round each reading's arc:

* a reading is entered in every bin whose centre lies within half a bin of its beam, at
  the point at its range along the bin's centre;
* a line is entered in the bins of its two normals (the sensor may lie on either side);
* a reading echoing from a line meets it along the line's normal, whose bin it is
  entered in; there its point lies within ``tol + r * bin / 2`` of the line's segment
  (``r`` the range), so a look-up in square buckets of :data:`BUCKET_M` round each
  segment finds it, and the exact test follows.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extract import SurfaceCells
from sonarproc.surfaces.feet import median_steps
from sonarproc.surfaces.models import SurfaceFit
from sonarproc.surfaces.runs import ragged_arange
from sonarproc.surfaces.specular import EchoGeometry

__all__ = ["BIN_DEG", "BUCKET_M", "echo_counts", "screen_fits"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Width (deg) of the direction bins.
BIN_DEG = 3.0
#: Side (m) of the square buckets the readings' points are looked up in.
BUCKET_M = 0.5


def screen_fits(
    fits: list[SurfaceFit], cells: list[SurfaceCells], echoes: EchoGeometry, *, tol: float
) -> tuple[list[SurfaceFit], list[SurfaceCells]]:
    """``fits`` and their ``cells`` without the straight ones no reading echoes from.

    Parameters
    ----------
    fits : list of SurfaceFit
        Surfaces fitted to ridge cells.
    cells : list of SurfaceCells
        Their cells (same order).
    echoes : EchoGeometry
        The readings (those of the first echo round).
    tol : float
        Range tolerance (m) of the first echo round.

    Returns
    -------
    fits, cells : list of SurfaceFit, list of SurfaceCells
        The curved surfaces and the straight ones some reading echoes from, in order.

    Examples
    --------
    A wall along y = 1 that a sensor below it faces, and a piece of ridge beside the
    sensor, along its beam:

    >>> from sonarproc.surfaces.batchfit import fit_surfaces
    >>> x = np.arange(-0.5, 0.5, 0.01)
    >>> wall = SurfaceCells(x, 1 + 0 * x, x + 0.5, np.ones_like(x), False)
    >>> side = SurfaceCells(0.5 + 0 * x, x + 0.5, x + 0.5, np.ones_like(x), False)
    >>> fits = fit_surfaces([wall, side], cell=0.01)
    >>> g = EchoGeometry(np.zeros((1, 2)), np.array([np.pi / 2]), np.array([0.2]),
    ...                  np.array([1.02]))
    >>> kept, kept_cells = screen_fits(fits, [wall, side], g, tol=0.08)
    >>> [round(float(f.polyline[0, 1]), 2) for f in kept], kept_cells[0] is wall
    ([1.0], True)
    """
    line = np.array(
        [i for i, f in enumerate(fits) if f.model == "line" and len(f.polyline) >= 2], np.intp
    )
    if line.size == 0:
        return list(fits), list(cells)
    count = echo_counts([fits[i].polyline for i in line], echoes, tol=tol)
    drop = set(line[count == 0].tolist())
    keep = [i for i in range(len(fits)) if i not in drop]
    return [fits[i] for i in keep], [cells[i] for i in keep]


def echo_counts(polylines: list[FloatArray], echoes: EchoGeometry, *, tol: float) -> IntArray:
    """How many readings echo from each straight polyline (see the module notes).

    Parameters
    ----------
    polylines : list of ndarray, shape (K_i, 2)
        Straight polylines, sampled finely (every cell), at least 2 points each.
    echoes : EchoGeometry
        The readings.
    tol : float
        Range tolerance (m).

    Returns
    -------
    ndarray of int, shape (len(polylines),)
        Each reading counted for every polyline it echoes from.

    Examples
    --------
    >>> wall = np.column_stack((np.linspace(-1, 1, 201), np.ones(201)))
    >>> g = EchoGeometry(np.zeros((2, 2)), np.array([np.pi / 2, 0.0]), np.full(2, 0.2),
    ...                  np.array([1.02, 1.02]))
    >>> echo_counts([wall, wall[::-1]], g, tol=0.05).tolist()
    [1, 1]
    """
    m = len(polylines)
    if m == 0 or echoes.size == 0:
        return np.zeros(m, dtype=np.intp)
    ends = np.stack([np.asarray(p, dtype=np.float64)[[0, -1]] for p in polylines])
    step_in = 0.5 * median_steps([np.asarray(p, dtype=np.float64) for p in polylines])
    g, j = _pairs(ends, echoes, tol)
    # the test of echo_points on a straight polyline
    a = ends[g, 0]
    ab = ends[g, 1] - a
    length = np.maximum(np.hypot(*ab.T), 1e-300)
    t = np.clip(np.einsum("ij,ij->i", echoes.xy[j] - a, ab) / (length * length), 0.0, 1.0)
    along = t * length
    foot = a + ab * t[:, None]
    v = foot - echoes.xy[j]
    d = np.hypot(*v.T)
    off = np.abs(
        (np.arctan2(v[:, 1], v[:, 0]) - echoes.heading[j] + math.pi) % (2 * math.pi) - math.pi
    )
    ok = (
        (along > step_in[g])
        & (along < length - step_in[g])
        & (off <= echoes.half_beam[j])
        & (np.abs(d - echoes.range_m[j]) <= tol)
    )
    return np.bincount(g[ok], minlength=m).astype(np.intp)


def _pairs(ends: FloatArray, echoes: EchoGeometry, tol: float) -> tuple[IntArray, IntArray]:
    """Distinct (segment, reading) pairs that may echo: every echoing pair among them."""
    nbin = math.ceil(360.0 / BIN_DEG)
    step = 2 * math.pi / nbin
    centre = (np.arange(nbin) + 0.5) * step
    unit = np.stack((np.cos(centre), np.sin(centre)), axis=1)
    # readings: every bin whose centre lies within half a bin of the beam
    th = np.mod(echoes.heading, 2 * math.pi)
    half = np.minimum(echoes.half_beam, math.pi) + 0.5 * step
    k_lo = np.ceil((th - half) / step - 0.5).astype(np.intp)
    k_hi = np.floor((th + half) / step - 0.5).astype(np.intp)
    read, k = ragged_arange(np.clip(k_hi - k_lo + 1, 0, nbin))
    k = np.mod(k_lo[read] + k, nbin)
    q = echoes.xy[read] + echoes.range_m[read, None] * unit[k]
    # segments: the bins (one or two) within half a bin of each normal
    t = ends[:, 1] - ends[:, 0]
    normal = np.arctan2(t[:, 0], -t[:, 1])  # the direction of (-t_y, t_x)
    side_g = np.repeat(np.arange(ends.shape[0]), 2)
    side_dir = np.mod(np.stack((normal, normal + math.pi), axis=1).ravel(), 2 * math.pi)
    s_lo = np.ceil((side_dir - 0.5 * step) / step - 0.5).astype(np.intp)
    s_hi = np.floor((side_dir + 0.5 * step) / step - 0.5).astype(np.intp)
    side, ks = ragged_arange(s_hi - s_lo + 1)
    ks = np.mod(s_lo[side] + ks, nbin)
    seg = side_g[side]
    # the buckets round each (segment, bin) entry, its box grown by the largest reach
    grow = tol + 0.5 * step * float(echoes.range_m.max()) + 1e-6
    lo = np.floor((ends[seg].min(axis=1) - grow) / BUCKET_M).astype(np.int64)
    hi = np.floor((ends[seg].max(axis=1) + grow) / BUCKET_M).astype(np.int64)
    qb = np.floor(q / BUCKET_M).astype(np.int64)
    base = np.minimum(lo.min(axis=0), qb.min(axis=0))
    span = np.maximum(hi.max(axis=0), qb.max(axis=0)) - base + 1
    nx_, ny_ = int(span[0]), int(span[1])
    ex, bx = ragged_arange((hi[:, 0] - lo[:, 0] + 1).astype(np.intp))
    ey, by = ragged_arange((hi[ex, 1] - lo[ex, 1] + 1).astype(np.intp))
    entry = ex[ey]
    key = (ks[entry].astype(np.int64) * nx_ + (lo[entry, 0] + bx[ey] - base[0])) * ny_ + (
        lo[entry, 1] + by - base[1]
    )
    order = np.argsort(key, kind="stable")
    key, entry = key[order], entry[order]
    pkey = (k.astype(np.int64) * nx_ + (qb[:, 0] - base[0])) * ny_ + (qb[:, 1] - base[1])
    first = np.searchsorted(key, pkey, side="left")
    point, off = ragged_arange(np.searchsorted(key, pkey, side="right") - first)
    g = seg[entry[first[point] + off]]
    # a reading in two bins of one segment is one pair
    pair = np.unique(g.astype(np.int64) * echoes.size + read[point])
    return (pair // echoes.size).astype(np.intp), (pair % echoes.size).astype(np.intp)

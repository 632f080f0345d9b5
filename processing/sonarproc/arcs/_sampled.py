"""Paper-style arcs: each arc drawn as samples at a fixed angular step (optional mode).

:func:`sonarproc.arcs.rasterize` draws every arc as a gap-free 8-connected chain of
cells (the default). The paper's C implementation is not described; a common way
to draw an arc in C is to step an angle and set the cell under each sample, which leaves
gaps wherever the step covers more than one cell of arc (radius x step > cell). This
module draws arcs that way, so the effect on the paper's morphology can be measured
(``sonarproc run --arc-step DEG``).

Choice of angle: the eccentric anomaly E of :mod:`sonarproc.arcs._geometry`, the
parameter of the point ``(a cos E, b sin E)`` in the ellipse's own frame. For a circle
(transmitter = receiver) E is the polar angle about the centre, i.e. about the sensor;
for the ellipses of the shipped scenarios (``c << a``) it differs little from the polar
angle about the centre or a focus. Each joint-region interval ``[lo, lo + length]`` of E
is sampled at ``lo + k step`` for ``k = 0 .. floor(length / step)`` (the sweep starts at
the interval's start, as a C ``for`` loop would; the far end is reached only when the
length is a multiple of the step). Every sample sets the cell holding it
(:meth:`Grid.to_index`); samples outside the grid are dropped; a cell hit by several
samples of one arc (both intervals of a reading count as one arc) is counted once, so
the count map holds, as for connected arcs, the number of distinct arcs per cell.

Everything is vectorised over samples; arcs are processed in batches of whole arcs of
about :data:`_BATCH` samples, which only bounds the memory.
"""

from __future__ import annotations

import itertools
import logging

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs._geometry import ArcGeometry, point_at
from sonarproc.grid import Grid

__all__ = ["arc_samples", "sample_anomalies"]

log = logging.getLogger(__name__)

#: Samples per batch of whole arcs (bounds the temporaries).
_BATCH = 1 << 22

#: A length within this many steps short of a multiple of the step still reaches its end.
_ROUND_TOL = 1e-9

IntArray = NDArray[np.intp]
FloatArray = NDArray[np.float64]


def _check_step(step_rad: float) -> float:
    step = float(step_rad)
    if not (np.isfinite(step) and step > 0.0):
        raise ValueError(f"arc step must be > 0 rad, got {step_rad!r}")
    return step


def _per_interval_counts(geom: ArcGeometry, step: float) -> IntArray:
    """Samples per interval, (K, 2): ``floor(length / step) + 1``, 0 where absent."""
    length = geom.length
    with np.errstate(invalid="ignore"):
        q = np.nan_to_num(length) / step
        n = np.where(np.isfinite(length), np.floor(q + _ROUND_TOL) + 1.0, 0.0)
    return n.astype(np.intp)


def sample_anomalies(geom: ArcGeometry, step_rad: float) -> tuple[IntArray, FloatArray]:
    """The E of every sample of every arc of ``geom``, in order along each arc.

    Parameters
    ----------
    geom : ArcGeometry
        Arcs (from :func:`sonarproc.arcs._geometry.arc_geometry`).
    step_rad : float
        Angular step (rad) in eccentric anomaly, > 0.

    Returns
    -------
    row, e : ndarray
        For each sample, the row of ``geom`` it belongs to and its eccentric anomaly.

    Examples
    --------
    >>> from sonarproc.arcs import arc_geometry
    >>> g = arc_geometry([[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [2.0],
    ...                  tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)
    >>> row, e = sample_anomalies(g, 0.1)
    >>> row.tolist(), [round(float(v), 6) for v in e]
    ([0, 0, 0, 0, 0], [-0.2, -0.1, 0.0, 0.1, 0.2])
    """
    step = _check_step(step_rad)
    n = _per_interval_counts(geom, step).ravel()  # interval i = 2 * row + piece
    total = int(n.sum())
    interval = np.repeat(np.arange(n.size, dtype=np.intp), n)
    first = np.cumsum(n) - n
    k = np.arange(total, dtype=np.intp) - first[interval]
    lo = np.nan_to_num(geom.lo.ravel())[interval]
    return interval // 2, lo + k * step


def _batches(per_row: IntArray) -> list[tuple[int, int]]:
    """Row ranges of about :data:`_BATCH` samples each (whole arcs)."""
    if per_row.size == 0:
        return []
    ends = np.cumsum(per_row)
    cuts = np.searchsorted(ends, np.arange(_BATCH, int(ends[-1]), _BATCH), side="left") + 1
    bounds = np.unique(np.concatenate(([0], cuts, [per_row.size])))
    return [(int(a), int(b)) for a, b in itertools.pairwise(bounds) if b > a]


def _distinct_cells(geom: ArcGeometry, step: float, grid: Grid) -> tuple[IntArray, IntArray]:
    """Geometry rows and flat cell keys of every distinct (arc, cell) pair in the grid."""
    per_row = _per_interval_counts(geom, step).sum(axis=1)
    size = grid.ny * grid.nx
    rows_out: list[IntArray] = []
    keys_out: list[IntArray] = []
    for r0, r1 in _batches(per_row):
        part = geom[r0:r1]
        row, e = sample_anomalies(part, step)
        x, y = point_at(e, part.cx[row], part.cy[row], part.a[row], part.b[row],
                        part.ca[row], part.sa[row])  # fmt: skip
        iy, ix = grid.to_index(x, y)
        inside = grid.contains_index(iy, ix)
        row, iy, ix = row[inside], iy[inside], ix[inside]
        # Unique (arc, cell) pairs: one cell per arc however many samples fall in it.
        pair = np.unique(row.astype(np.int64) * size + (iy.astype(np.int64) * grid.nx + ix))
        local, key = np.divmod(pair, size)
        rows_out.append(local.astype(np.intp) + r0)
        keys_out.append(key.astype(np.intp))
    if not keys_out:
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty.copy()
    return np.concatenate(rows_out), np.concatenate(keys_out)


def arc_samples(
    arcs: ArcGeometry, grid: Grid, *, step: float
) -> tuple[IntArray, IntArray, IntArray]:
    """The distinct cells of every arc drawn as samples every ``step`` rad of E.

    Same arc rules as :func:`sonarproc.arcs.arc_cells` (joint beam region, cells outside
    the grid dropped), but each arc is a set of samples, not a connected chain.

    Parameters
    ----------
    arcs : ArcGeometry
        The arcs (:func:`sonarproc.arcs.arc_geometry`).
    grid : Grid
        The map grid.
    step : float
        Angular step (rad) in eccentric anomaly (the polar angle for a circle), > 0.

    Returns
    -------
    arc_id, iy, ix : ndarray of intp
        For each distinct (arc, cell) pair, the index of its reading and the cell's row and
        column; sorted by reading, then cell.

    Raises
    ------
    ValueError
        ``step`` not > 0.

    Examples
    --------
    A circle of radius 1 m, +-0.2 rad, sampled every 0.1 rad on a 1 cm grid: five
    samples 10 cm apart, five cells.

    >>> g = Grid.covering(-1.1, 1.1, -1.1, 1.1, cell=0.01)
    >>> from sonarproc.arcs import arc_geometry
    >>> arcs = arc_geometry([[0, 0]], [0.0], [[0, 0]], [0.0], [2.0],
    ...                     tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)
    >>> arc, iy, ix = arc_samples(arcs, g, step=0.1)
    >>> len(arc), sorted(set(arc.tolist()))
    (5, [0])
    """
    rows, keys = _distinct_cells(arcs, _check_step(step), grid)
    iy, ix = np.divmod(keys, grid.nx)
    return arcs.arc[rows].astype(np.intp), iy.astype(np.intp), ix.astype(np.intp)

"""Straight ridge pieces no reading echoes from, dropped before the echo rounds.

An hour's log of a room leaves about a thousand chance ridges (arcs crossing in free
space) for a dozen walls, and the first echo round of :mod:`sonarproc.surfaces.echoes.refine`
drops almost all of them, but only after they were merged (:mod:`sonarproc.surfaces.fitting.merge`)
and scored with the others. Half of them are straight pieces that no reading of that
round echoes from at all; :func:`screen_fits` drops those first. Such a piece adds no
echo to a wall it would have been merged with (the same readings, on nearly the same
line), so that wall keeps the echoes it needs.

:func:`echo_counts` counts the readings echoing from each straight polyline with the
test of :func:`~sonarproc.surfaces.echoes.specular.echo_points` (the foot of the sensor on the
line inside the polyline and inside the beam, its distance within ``tol`` of the range),
each reading counted for every surface it echoes from. Its pairs come from a search over
direction bins (:func:`~sonarproc.surfaces.echoes.dirbins.normal_bin_pairs`), not from a radius
search round each reading's arc.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.dirbins import normal_bin_pairs
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.planar.feet import median_steps

__all__ = ["echo_counts", "screen_fits"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


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

    >>> from sonarproc.surfaces.fitting.batch import fit_surfaces
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
    g, j = normal_bin_pairs(ends, np.full(m, tol), echoes.xy, echoes.heading,
                            echoes.half_beam, echoes.range_m)  # fmt: skip
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

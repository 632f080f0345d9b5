"""The ``surfaces`` candidate of ``--auto``: several surfaces instead of one profile y(x).

A room, a corridor or a pillar is not one curve ``y = f(x)``. The ``surfaces``
candidate fits the map as ``sonarproc run --fit auto`` does
(:func:`sonarproc.pipeline.surfacefit.choose_fit`: a line, an arc or a spline per
surface) and is judged by the same held-out criterion as the others: each held-out
reading's path is predicted from every fitted surface with the first-echo model, and the
reading's echo of rank ``k`` is the ``k``-th shortest of those paths (one specular point
per surface: a surface bent enough to give a reading two echoes is rare at sonar ranges).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MethodMap
from sonarproc.methods.echo_model import first_echo_path
from sonarproc.surfaces.find import decide

__all__ = ["fitted_surfaces", "surfaces_path"]

FloatArray = npt.NDArray[np.float64]


def fitted_surfaces(
    mmap: MethodMap, grid: Grid, beams: Beams, *, lines_first: bool | None = None
) -> list[FloatArray] | None:
    """The polylines ``fit = "auto"`` fits to ``mmap`` and refits through the echo points of
    ``beams`` (the readings ``mmap`` was built from); None where it finds one function of x,
    on the map or among the refitted surfaces.

    ``lines_first``: whether the walls are found from the readings' tangent votes first
    (:func:`sonarproc.pipeline.surfacefit.choose_fit`); a fold of a long log is fitted as
    the run on every reading fits it.
    """
    from sonarproc.pipeline.surfacefit import choose_fit  # scipy's graph and trees: lazily

    found = choose_fit(mmap.processed, mmap.evidence, grid, beams, lines_first=lines_first)
    if found.surfaces is None or decide(found.surfaces).single_function:
        # the map's stray cells (a noisy log's ghosts) can hide one curve from the first
        # decision; the refit through the echo points drops them, and one open curve that
        # is a function of x is left to the y(x) candidates and their echo refit
        return None
    return [np.asarray(p, dtype=np.float64) for p in found.surfaces.polylines() if len(p) >= 2]


def surfaces_path(
    polylines: list[FloatArray], beams: Beams, rows: npt.NDArray[np.intp], step: float
) -> FloatArray:
    """Path length the surfaces predict for readings ``rows`` (NaN: no surface in the beams).

    Examples
    --------
    >>> from sonarproc.methods.testing import flat_wall_beams
    >>> beams, _ = flat_wall_beams(10)
    >>> wall = np.array([[-1.0, 1.0], [3.0, 1.0]])
    >>> far = np.array([[-1.0, 3.0], [3.0, 3.0]])
    >>> p = surfaces_path([far, wall], beams, np.arange(3), 0.01)
    >>> bool(np.allclose(p, beams.path[:3], atol=1e-3))
    True
    """
    p = beams.poses
    n = rows.size
    if not polylines or n == 0:
        return np.full(n, np.nan)
    paths = np.full((len(polylines), n), np.inf)
    for k, line in enumerate(polylines):  # a handful of surfaces, each vectorised
        curve = _resample(line, step)
        got = first_echo_path(
            p.tx_xy[rows], p.tx_heading[rows], p.tx_half_beamwidth[rows],
            p.rx_xy[rows], p.rx_heading[rows], p.rx_half_beamwidth[rows], curve,
        )  # fmt: skip
        paths[k] = np.where(np.isfinite(got), got, np.inf)
    paths.sort(axis=0)
    rank = np.clip(np.asarray(beams.readings["echo"][rows], dtype=np.intp), 0, len(polylines) - 1)
    out = paths[rank, np.arange(n)]
    return np.where(np.isfinite(out), out, np.nan)


def _resample(line: FloatArray, step: float) -> FloatArray:
    """``line`` with points every ``step`` (m) or closer, so specular points are found."""
    seg = np.hypot(*np.diff(line, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    if s[-1] <= 0:
        return line
    t = np.linspace(0.0, s[-1], max(2, int(np.ceil(s[-1] / step)) + 1))
    return np.column_stack((np.interp(t, s, line[:, 0]), np.interp(t, s, line[:, 1])))

"""What a surface fit is, and the criterion that picks one of line, arc and spline.

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

The candidates are fitted by :mod:`~sonarproc.surfaces.fitting.lines` (total least
squares), :mod:`~sonarproc.surfaces.fitting.arcs` (Kasa + Gauss-Newton circles) and
:mod:`~sonarproc.surfaces.fitting.splines` (smoothing splines x(s), y(s), GCV smoothing).

Degenerate input (fewer than :data:`MIN_CELLS` cells, all cells in one place, a singular
system) gives a :class:`SurfaceFailure` with the reason, never a curve. The criterion is
applied by :func:`~sonarproc.surfaces.fitting.batch.fit_surfaces` (many surfaces at once)
and :func:`~sonarproc.surfaces.fitting.batch.fit_surface` (one).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = ["MIN_CELLS", "Candidate", "SurfaceFailure", "SurfaceFit", "choose_model"]

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
    viewpoints : int or None
        Distinct viewpoints (sensor positions an inch apart) its echoes came from, once
        refitted through the readings; None before.
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
    viewpoints: int | None = None

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
            "viewpoints": self.viewpoints,
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


def choose_model(
    rms: dict[str, float], *, cell: float, reference: float | None = None, noise: float = 0.0
) -> str:
    """The model the criterion picks from the candidates' RMS residuals (m).

    ``reference`` stands in for the spline's residual when no spline was fitted;
    ``noise`` is the points' own scatter (echo points' range noise), below which no
    model's residual means anything: the reference is at least that.

    Examples
    --------
    >>> choose_model({"line": 0.004, "arc": 0.0039, "spline": 0.0035}, cell=0.01)
    'line'
    >>> choose_model({"line": 0.03, "arc": 0.004, "spline": 0.0035}, cell=0.01)
    'arc'
    >>> choose_model({"line": 0.03, "arc": 0.004}, cell=0.01, reference=0.0035)
    'arc'
    >>> choose_model({"line": 0.013, "spline": 0.001}, cell=0.02, noise=0.012)
    'line'
    """
    ref = rms.get("spline", reference)
    if ref is not None:
        ref = max(ref, noise)
    for m in MODELS:
        if m not in rms:
            continue
        if ref is None or rms[m] <= SPLINE_FACTOR * ref + CELL_FACTOR * cell:
            return m
    return min(rms, key=lambda k: rms[k])

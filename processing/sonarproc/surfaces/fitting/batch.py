"""The model of every surface, chosen by the criterion of :mod:`sonarproc.surfaces.fitting.models`.

A room's ridge breaks into about a thousand groups of cells, and the refinement fits
hundreds of echo sets. :func:`fit_surfaces` fits the lines and circles of all groups
together (:mod:`sonarproc.surfaces.fitting.grouped`: grouped sums instead of one SVD or solve per
group), computes every group's floor the same way, and builds polylines only for the
candidates the criterion needs:

1. fewer than :data:`~sonarproc.surfaces.fitting.models.MIN_CELLS` cells, or all at one point:
   a :class:`~sonarproc.surfaces.fitting.models.SurfaceFailure`;
2. the line, kept at once when its RMS residual is at most ``1.25 floor + 0.25 cell``
   (the criterion would pick it whatever the others give); for echo points the floor is
   at least their scatter about their neighbours (the range noise), which a spline
   threading sparse points would otherwise undercut;
3. otherwise the arc (dropped if it does not bend: radius above 20 times its length);
4. the spline, only when neither passes the same test and there are at least
   :data:`~sonarproc.surfaces.fitting.models.MIN_SPLINE_CELLS` cells;
5. :func:`~sonarproc.surfaces.fitting.models.choose_model` among those fitted.

A group's result does not depend on the other groups given with it: :func:`fit_surface`
is the one-group case.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.arcs import arc_candidate, fit_circles
from sonarproc.surfaces.fitting.grouped import floor_rms, scatter_rms
from sonarproc.surfaces.fitting.lines import fit_lines, line_candidate, line_params
from sonarproc.surfaces.fitting.models import (
    CELL_FACTOR,
    MAX_RADIUS_PER_LENGTH,
    MIN_CELLS,
    MIN_SPLINE_CELLS,
    SPLINE_FACTOR,
    Candidate,
    SurfaceFailure,
    SurfaceFit,
    choose_model,
)
from sonarproc.surfaces.fitting.splines import fit_spline
from sonarproc.surfaces.planar.polylines import resample_segments

__all__ = ["fit_surface", "fit_surfaces"]

FloatArray = npt.NDArray[np.float64]

#: Fewest echo points whose scatter sets the floor (``scatter``): the RMS of m deviations
#: is uncertain by about 1 / sqrt(2 m) of itself, a quarter with the 8 deviations of 10
#: points; fewer say too little about the range noise to overrule the floor.
MIN_SCATTER_POINTS = 10


def _length(poly: FloatArray) -> float:
    return float(np.hypot(*np.diff(poly, axis=0).T).sum()) if len(poly) > 1 else 0.0


def fit_surfaces(
    groups: Sequence[SurfaceCells], *, cell: float, scatter: float = 0.0
) -> list[SurfaceFit | SurfaceFailure]:
    """Fit every group and keep the model the criterion picks (see the module notes).

    Parameters
    ----------
    groups : sequence of SurfaceCells
        Surfaces' cells, each in order along it.
    cell : float
        Cell size (m): the polylines' step and the criterion's unit.
    scatter : float
        When positive, the groups are echo points, not cells, and this is the largest
        RMS range scatter (m) a reading's echo point can have about its surface (the
        refinement's range tolerance as an RMS): the floor is at least the points'
        scatter about their neighbours
        (:func:`~sonarproc.surfaces.fitting.grouped.scatter_rms`, the range noise no
        model can explain), up to this. Sparse readings leave one echo point or none per
        bin of the floor, whose distance to its own mean is nil, so that a line through
        a straight wall's noisy points would always lose to an arc or a spline threading
        them (which breaks the wall into pieces that no longer join); points scattered
        more widely than a reading's range can err are no surface's noise (the chance
        gatherings of a first, loose round), and excuse nothing beyond the bound.

    Returns
    -------
    list of SurfaceFit or SurfaceFailure
        One per group, in order.

    Examples
    --------
    >>> x = np.arange(0.0, 1.0, 0.01)
    >>> wall = SurfaceCells(x, 0.5 + 0 * x, x, np.ones_like(x), False)
    >>> phi = np.linspace(0.0, 3.0, 150)
    >>> pillar = SurfaceCells(np.cos(phi), np.sin(phi), phi, np.ones_like(phi), False)
    >>> [(f.model, round(f.length_m, 2)) for f in fit_surfaces([wall, pillar], cell=0.01)]
    [('line', 0.99), ('arc', 3.0)]
    """
    out: list[SurfaceFit | SurfaceFailure] = [
        SurfaceFailure(f"{c.size} cells, need at least {MIN_CELLS}", c.size) for c in groups
    ]
    sizes = np.array([c.size for c in groups], dtype=np.intp)
    big = [i for i in range(len(groups)) if sizes[i] >= MIN_CELLS]
    if not big:
        return out
    x = np.concatenate([groups[i].x for i in big])
    y = np.concatenate([groups[i].y for i in big])
    s = np.concatenate([groups[i].s for i in big])
    n = sizes[big]
    lines = fit_lines(x, y, n, cell=cell)
    floor = floor_rms(x, y, s, n, cell=cell)
    if scatter > 0:
        noise = np.minimum(scatter_rms(x, y, s, n, lines.point, lines.direction), scatter)
        floor = np.where(n >= MIN_SCATTER_POINTS, np.maximum(floor, noise), floor)
    bound = SPLINE_FACTOR * floor + CELL_FACTOR * cell
    for k in np.flatnonzero(~lines.ok).tolist():
        out[big[k]] = SurfaceFailure("all cells at one point", int(n[k]))
    straight = lines.ok & (lines.rms <= bound)
    # a line within the bound is what the criterion picks whatever the others give
    ks = np.flatnonzero(straight)
    p, d = lines.point[ks], lines.direction[ks]
    polys = resample_segments(p + d * lines.lo[ks, None], p + d * lines.hi[ks, None], cell)
    for k, poly in zip(ks.tolist(), polys, strict=True):
        line_rms = float(lines.rms[k])
        line = Candidate("line", poly, line_rms, line_params(lines.point[k], lines.direction[k]))
        out[big[k]] = _surface(groups[big[k]], line, {"line": line_rms})
    rest = np.flatnonzero(lines.ok & ~straight)
    if rest.size == 0:
        return out
    keep = np.repeat(np.isin(np.arange(n.size), rest), n)
    circles = fit_circles(x[keep], y[keep], n[rest], cell=cell)
    for j, k in enumerate(rest.tolist()):
        c = groups[big[k]]
        found: dict[str, Candidate] = {
            "line": line_candidate(
                lines.point[k], lines.direction[k], float(lines.lo[k]), float(lines.hi[k]),
                float(lines.rms[k]), cell,
            )
        }  # fmt: skip
        if circles.ok[j] and c.size >= 3:
            arc = arc_candidate(c, circles.centre[j], float(circles.radius[j]), cell)
            flat = arc.params["radius"] > MAX_RADIUS_PER_LENGTH * max(_length(arc.polyline), cell)
            if c.closed or not flat:
                found["arc"] = arc
        if c.size >= MIN_SPLINE_CELLS and not any(f.rms <= bound[k] for f in found.values()):
            spline = fit_spline(c, cell=cell)
            if isinstance(spline, Candidate):
                found["spline"] = spline
        rms = {m: f.rms for m, f in found.items()}
        out[big[k]] = _surface(
            c,
            found[
                choose_model(
                    rms,
                    cell=cell,
                    reference=float(floor[k]),
                    noise=float(floor[k]) if scatter > 0 else 0.0,
                )
            ],
            rms,
        )
    return out


def _surface(cells: SurfaceCells, best: Candidate, rms: dict[str, float]) -> SurfaceFit:
    poly = best.polyline
    if best.closed and len(poly) > 1 and np.allclose(poly[0], poly[-1]):
        poly = np.vstack((poly[:-1], poly[:1]))  # closes exactly
    return SurfaceFit(
        model=best.model,
        polyline=poly,
        length_m=_length(poly),
        rms_m=best.rms,
        support=cells.size,
        arcs=round(float(cells.weight.sum())),
        closed=best.closed,
        params=best.params,
        candidates=rms,
    )


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
    >>> x = np.arange(0.0, 1.0, 0.01); y = 0.5 + 0 * x
    >>> f = fit_surface(SurfaceCells(x, y, x, 1 + 0 * x, False), cell=0.01)
    >>> f.model, round(f.length_m, 3), round(f.rms_m, 6), f.support
    ('line', 0.99, 0.0, 100)
    """
    return fit_surfaces([cells], cell=cell)[0]

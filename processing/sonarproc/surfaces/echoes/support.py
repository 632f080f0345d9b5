"""What a refitted surface needs to stay: echoes, viewpoints, spread, and few readings through it.

The refinement rounds of :mod:`sonarproc.surfaces.echoes.refine` gather each surface's
echoes (:func:`~sonarproc.surfaces.echoes.specular.echo_points`) and keep it only when
they are enough (:func:`enough`): :data:`MIN_ECHOES` of them (scaled to a round's share of
the readings), from :data:`MIN_VIEWPOINTS` distinct viewpoints, spread over
:data:`MIN_SPREAD_M` or heard head on
(:func:`~sonarproc.surfaces.echoes.approach.heard_head_on`), and not seen through by more
than :data:`MAX_SEEN_THROUGH` of the readings facing it (:func:`seen_through`). Before the
rounds, a wall heard head on whose ridge was fitted as an arc none of its readings echo
from is replaced by the arc's tangent (:func:`head_on_arcs`); after them, a surface that
too few readings echo from as it will be reported goes (:func:`unsupported`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.approach import apex_tangent, driven_at, heard_head_on
from sonarproc.surfaces.echoes.specular import EchoGeometry, echo_points
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import FreeCones, viewpoint_ids

__all__ = [
    "MAX_SEEN_THROUGH", "MIN_ECHOES", "MIN_SEEN_THROUGH", "MIN_SPREAD_M", "MIN_VIEWPOINTS",
    "WEAK_ECHOES", "enough", "head_on_arcs", "seen_through", "surfaces_left", "unsupported",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Fewest echoing readings a surface needs to be kept.
MIN_ECHOES = 5
#: Fewest distinct viewpoints (:func:`~sonarproc.surfaces.freespace.viewpoint_ids`) its
#: echoes must come from: one reading's arc, or a robot standing still and ranging one
#: spot again, is no surface; two viewpoints fix a line's direction and distance, a third
#: checks them.
MIN_VIEWPOINTS = 3
#: Shortest stretch (m) its echo points must cover: echoes all at one point (a corner's
#: double reflections, arriving at the corner's distance) say nothing of a direction,
#: unless their ranges do (:func:`~sonarproc.surfaces.echoes.approach.heard_head_on`).
MIN_SPREAD_M = 0.10
#: Largest share of the readings facing a surface (echoing from it or seeing through
#: it) that may see through it; and fewer than :data:`MIN_SEEN_THROUGH` never count.
MAX_SEEN_THROUGH = 0.25
MIN_SEEN_THROUGH = 2
#: Surfaces with fewer echoes are tested for readings seeing through against every reading.
WEAK_ECHOES = 50


def seen_through(echoing: int, through: int) -> bool:
    """Whether too many of the readings facing a surface saw through it."""
    return through >= MIN_SEEN_THROUGH and through > MAX_SEEN_THROUGH * (echoing + through)


def enough(idx: IntArray, pts: FloatArray, view: IntArray, need: int, range_m: FloatArray) -> bool:
    """Whether echoes ``idx`` (points ``pts``) are enough for a surface: as many as
    ``need``, from :data:`MIN_VIEWPOINTS` viewpoints, spread over :data:`MIN_SPREAD_M`
    or heard head on (:func:`~sonarproc.surfaces.echoes.approach.heard_head_on`, their
    ranges ``range_m[idx]``)."""
    return (
        idx.size >= need
        and np.unique(view[idx]).size >= MIN_VIEWPOINTS
        and (float(np.hypot(*np.ptp(pts, axis=0))) >= MIN_SPREAD_M or heard_head_on(idx, range_m))
    )


def surfaces_left(
    fits: list[SurfaceFit], pts: list[SurfaceCells], idx: list[IntArray], cones: FreeCones,
    min_echoes: int, range_m: FloatArray,
) -> tuple[list[SurfaceFit], list[SurfaceCells], list[IntArray]]:  # fmt: skip
    """The pieces whose echoes still make a surface (:func:`enough`)."""
    kept = [
        i
        for i, (r, c) in enumerate(zip(idx, pts, strict=True))
        if enough(r, np.stack((c.x, c.y), axis=1), cones.viewpoint, min_echoes, range_m)
    ]
    return [fits[i] for i in kept], [pts[i] for i in kept], [idx[i] for i in kept]


def unsupported(
    fits: list[SurfaceFit], echoes: EchoGeometry, tol: float, min_echoes: int
) -> list[int]:
    """The surfaces that, as they will be reported, too few readings echo from.

    A surface's echoes are gathered against the geometry of the round before: the last
    refit through them, its stretch over the ridge and the cuts at openings all move it
    afterwards. Through the echo points of a robot turning on one spot (its sensors a few
    centimetres apart, every range the same) a line may be fitted that faces none of
    the beams that heard it; no reading's foot then lies on it, and its support was
    counted on a line that is not reported. The echoes are therefore gathered once more
    against the surfaces as they stand, at the last round's tolerance and each reading
    to its best match (a first echo comes from one surface), and a surface that fewer
    than ``min_echoes`` of them, or fewer than :data:`MIN_VIEWPOINTS` viewpoints, echo
    from goes. Their spread is not asked again: a wall the robot drove straight at has
    its feet at one spot once its line faces the approach, and its direction is then
    the approach's, from many viewpoints.

    Examples
    --------
    A wall along y = 1 heard from three spots below it, and a short line turned 20
    degrees off it near the middle spot (no beam's foot lies on it):

    >>> wall = np.column_stack((np.linspace(-1, 1, 201), np.ones(201)))
    >>> t = np.radians(20.0)
    >>> turned = np.array([[0.3, 1.0], [0.3 + 0.2 * np.cos(t), 1.0 + 0.2 * np.sin(t)]])
    >>> fits = [SurfaceFit("line", p, 1.0, 0.0, 6, 6, False, {}) for p in (wall, turned)]
    >>> x = np.repeat([-0.6, 0.0, 0.6], 2) + np.tile([0.0, 0.01], 3)
    >>> g = EchoGeometry(np.column_stack((x, np.zeros(6))), np.full(6, np.pi / 2),
    ...                  np.full(6, 0.2), np.ones(6))
    >>> unsupported(fits, g, 0.03, 5)
    [1]
    """
    if not fits:
        return []
    got = echo_points([f.polyline for f in fits], [f.closed for f in fits], echoes, tol=tol)
    view = viewpoint_ids(echoes.xy)
    return [
        i
        for i, e in enumerate(got)
        if e.readings.size < min_echoes or np.unique(view[e.readings]).size < MIN_VIEWPOINTS
    ]


def head_on_arcs(
    fits: list[SurfaceFit], echoes: EchoGeometry, tol: float, need: int, cell: float
) -> list[SurfaceFit]:
    """``fits`` with each open arc that no reading echoes from enough (:func:`enough`)
    replaced by its tangent at its middle
    (:func:`~sonarproc.surfaces.echoes.approach.apex_tangent`) where that tangent is a
    wall heard head on: echoes enough (:func:`enough`), not seen through, at ranges
    from depths along the pass
    (:func:`~sonarproc.surfaces.echoes.approach.heard_head_on`), from sensors of one
    heading that drove along their axis within :data:`MIN_SPREAD_M` of one line
    (:func:`~sonarproc.surfaces.echoes.approach.driven_at`).
    The crest of range arcs tangent at one spot is such an arc; a chance crossing of
    arcs or a curved surface that its readings do not reach keeps its arc (and goes as
    before, for want of echoes)."""
    arcs = [i for i, f in enumerate(fits) if f.model == "arc" and not f.closed]
    if not arcs:
        return fits
    view = viewpoint_ids(echoes.xy)
    got = echo_points([fits[i].polyline for i in arcs], [False] * len(arcs), echoes, tol=tol)
    dead = [
        i
        for i, (idx, pts, _, _) in zip(arcs, got, strict=True)
        if not enough(idx, pts, view, need, echoes.range_m)
    ]
    if not dead:
        return fits
    lines = [apex_tangent(fits[i], cell=cell) for i in dead]
    got = echo_points([f.polyline for f in lines], [False] * len(lines), echoes, tol=tol)
    out = list(fits)
    for i, line, (idx, pts, _, through) in zip(dead, lines, got, strict=True):
        if (
            heard_head_on(idx, echoes.range_m)
            and driven_at(echoes.xy[idx], echoes.heading[idx], across=MIN_SPREAD_M)
            and enough(idx, pts, view, need, echoes.range_m)
            and not seen_through(idx.size, through)
        ):
            out[i] = line
    return out

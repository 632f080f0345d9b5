"""A wall is not continued through a stretch that stood hidden behind something else.

:func:`~sonarproc.surfaces.echoes.openings.join_pieces` and
:func:`~sonarproc.surfaces.fitting.merge.merge_collinear` bridge a gap between two pieces
of one line that no reading saw through, however long: a stretch of wall that nobody
faced (passed by a sparse log) sends no echo back, and yet it is wall. But where the
readings that did face the stretch squarely all came back short of it, something else
stood in front (the solid block between the two arms of a U-shaped hall, in front of the
line joining the arms' end walls; the corridor wall in front of the line joining the back
walls of two door recesses). The readings then say nothing of the stretch, and a wall
drawn there is a guess, often a wrong one.

:func:`cut_unseen` therefore cuts a straight surface where a stretch between two of its
consecutive echo feet holds a run longer than
:data:`~sonarproc.surfaces.fitting.merge.MERGE_GAP_M` (the gap bridged without any
evidence) of *hidden* points. A point is hidden when readings facing the line squarely
(the line's normal within :data:`~sonarproc.surfaces.freespace.FREE_BEAM_FRACTION` of
the half beam of their heading, so that a wall there would have echoed) and holding the
point in that part of the beam came from at least
:data:`~sonarproc.surfaces.freespace.MIN_FREE_POSES` distinct viewpoints with ranges
short of it (less than its distance less the range tolerance), and from fewer with
ranges reaching it. Each side ends where the run begins; a side whose echoes no longer
make a surface goes, as in the refinement.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.openings import split_line
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.merge import MERGE_GAP_M
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.freespace import MIN_FREE_POSES, FreeCones

__all__ = ["SIGHT_STEP_M", "cut_unseen", "facing_views", "hidden_runs"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Points of a gap are tested this far apart (m), a sixth of the longest bridged gap.
SIGHT_STEP_M = 0.05
#: Points x readings tested at once, at most (bounds the memory).
_CHUNK = 2_000_000
#: The screen's margin on a squared cosine (relative): far above its rounding (a few
#: 1e-16; then the exact test decides), far below any beam's edge.
_SCREEN_COS = 1e-9
#: A cosine under this keeps every offset in :func:`_square_bound` (its relative margin
#: would no longer cover the rounding, about 1e-15 over the cosine).
_MIN_COS = 1e-3


def facing_views(
    points: npt.ArrayLike, normal: npt.ArrayLike, cones: FreeCones, *, margin: float
) -> tuple[IntArray, IntArray]:
    """Distinct viewpoints facing a line squarely whose beams held each of its points:
    those whose range reached the point, and those whose range fell short (module notes).

    ``normal`` is the line's unit normal pointing at the sensors.

    Examples
    --------
    The line y = 1; sensors at x = 0 and 0.1 look up, one pair ranging 2 m, one 0.5 m:

    >>> c = FreeCones.of([[0.0, 0.0], [0.1, 0.0]] * 2, [np.pi / 2] * 4, [0.2] * 4,
    ...                  [2.0, 2.0, 0.5, 0.5])
    >>> reached, short = facing_views([[0.05, 1.0], [2.0, 1.0]], [0.0, -1.0], c, margin=0.03)
    >>> reached.tolist(), short.tolist()
    ([2, 0], [2, 0])
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    n = np.asarray(normal, dtype=np.float64)
    reached = np.zeros(p.shape[0], dtype=np.intp)
    short = np.zeros(p.shape[0], dtype=np.intp)
    toward = np.arctan2(-n[1], -n[0])  # the direction a sensor faces the line in
    # a screen by the cosine of each heading's angle to it (a dot product, rounding
    # about 1e-16; the readings without a finite range left out) leaves out the sensors
    # facing well away; the exact test decides the rest
    cone_all, bound = cones.free_cones
    c_all, s_all = cones.axes
    near = np.flatnonzero(c_all * np.cos(toward) + s_all * np.sin(toward) >= bound)
    exact = np.abs(np.angle(np.exp(1j * (cones.heading[near] - toward)))) <= cone_all[near]
    facing = near[exact]
    if p.shape[0] == 0 or facing.size == 0:
        return reached, short
    xy, heading, cone = cones.xy[facing], cones.heading[facing], cone_all[facing]
    c, s = c_all[facing], s_all[facing]
    rng, view = cones.range_m[facing], cones.viewpoint[facing]
    screen = _square_bound(cone)
    per = max(1, _CHUNK // xy.shape[0])
    for k0 in range(0, p.shape[0], per):
        part = p[k0 : k0 + per]
        rx = part[:, 0, None] - xy[None, :, 0]
        ry = part[:, 1, None] - xy[None, :, 1]
        # the pairs whose beam may hold the point, screened without square roots or
        # angles (along |along| >= dist^2 cos(cone)^2, within margins far above the
        # rounding); the exact tests, as before, on the few left
        along = rx * c + ry * s
        ip, ir = np.nonzero(along * np.abs(along) >= (rx * rx + ry * ry) * screen)
        rx, ry = rx[ip, ir], ry[ip, ir]
        dist = np.hypot(rx, ry)
        off = np.abs(np.angle(np.exp(1j * (np.arctan2(ry, rx) - heading[ir]))))
        inside = off <= cone[ir]
        for out, hit in ((reached, rng[ir] >= dist - margin), (short, rng[ir] < dist - margin)):
            keep = np.flatnonzero(inside & hit)
            if keep.size:
                # the distinct (point, viewpoint) pairs, counted per point
                pt, vp = ip[keep], view[ir[keep]]
                order = np.lexsort((vp, pt))
                pt, vp = pt[order], vp[order]
                first = np.r_[True, (pt[1:] != pt[:-1]) | (vp[1:] != vp[:-1])]
                out[k0 : k0 + per] = np.bincount(pt[first], minlength=part.shape[0])
    return reached, short


def _square_bound(angle: FloatArray) -> FloatArray:
    """A bound under ``along |along| / dist^2`` of any offset within ``angle`` (rad) of an
    axis (``along`` its projection on the axis): the squared cosine less a relative
    :data:`_SCREEN_COS`; -2 (every offset) where the cosine is under :data:`_MIN_COS`."""
    cos = np.cos(np.minimum(angle, np.pi))
    return np.where(cos > _MIN_COS, cos * cos * (1.0 - _SCREEN_COS), -2.0)


def hidden_runs(
    s0: float, s1: float, a: FloatArray, t: FloatArray, normal: FloatArray, cones: FreeCones,
    margin: float,
) -> list[tuple[float, float]]:  # fmt: skip
    """The runs longer than :data:`MERGE_GAP_M` of hidden points strictly between ``s0``
    and ``s1`` along the line ``a + s t`` (``normal`` towards its sensors)."""
    n = int(np.ceil((s1 - s0) / SIGHT_STEP_M))
    if n < 2:
        return []
    grid = np.linspace(s0, s1, n + 1)  # the run's bounds are the points beside it
    s = grid[1:-1]
    reached, short = facing_views(a + s[:, None] * t, normal, cones, margin=margin)
    hidden = (short >= MIN_FREE_POSES) & (reached < MIN_FREE_POSES)
    edges = np.diff(np.r_[0, hidden.astype(np.int8), 0])
    first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    runs = [(float(grid[i]), float(grid[j + 2]))
            for i, j in zip(first.tolist(), last.tolist(), strict=True)]  # fmt: skip
    return [(lo, hi) for lo, hi in runs if hi - lo > MERGE_GAP_M]


def cut_unseen(
    fits: list[SurfaceFit],
    points: list[SurfaceCells],
    readings: list[IntArray],
    cones: FreeCones,
    *,
    margin: float,
    cell: float,
) -> tuple[list[SurfaceFit], list[SurfaceCells], list[IntArray]]:
    """Cut the straight surfaces through stretches hidden behind something (module notes).

    Parameters and returns as :func:`~sonarproc.surfaces.echoes.openings.cut_openings`.
    """
    if cones.size == 0:
        return list(fits), list(points), list(readings)
    out_f: list[SurfaceFit] = []
    out_p: list[SurfaceCells] = []
    out_r: list[IntArray] = []
    for f, p, r in zip(fits, points, readings, strict=True):
        if f.model != "line" or f.closed or len(f.polyline) < 2 or p.size == 0:
            out_f.append(f)
            out_p.append(p)
            out_r.append(r)
            continue
        a, b = np.asarray(f.polyline[0]), np.asarray(f.polyline[-1])
        length = float(np.hypot(*(b - a)))
        t = (b - a) / max(length, 1e-300)
        es = np.sort((np.stack((p.x, p.y), axis=1) - a) @ t)
        bounds = np.r_[0.0, es, length]
        wide = np.flatnonzero(np.diff(bounds) > MERGE_GAP_M)
        # the sensors' side: where the sensors of its echoes stand
        normal = np.array([-t[1], t[0]])
        side = (cones.xy[r] - a) @ normal
        normal = normal if float(np.median(side)) >= 0 else -normal
        cuts = [
            run
            for k in wide.tolist()
            for run in hidden_runs(bounds[k], bounds[k + 1], a, t, normal, cones, margin)
        ]
        if not cuts:
            out_f.append(f)
            out_p.append(p)
            out_r.append(r)
            continue
        ends = [0.0] + [x for run in cuts for x in run] + [length]
        stretches = list(zip(ends[::2], ends[1::2], strict=True))
        for piece, sub, rows in split_line(f, p, r, a, t, stretches, cell):
            out_f.append(piece)
            out_p.append(sub)
            out_r.append(rows)
    return out_f, out_p, out_r

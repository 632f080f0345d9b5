"""Planes that are a corner's echoes: a corner heard over a narrow spread of bearings.

A concave corner retro-reflects: every reading that holds it in its beam reads the
distance to it. Heard over a small spread of bearings (one sensor on a straight stretch
of track, seeing it through a doorway or from far along its bisector), its ranges are
explained as well by a plane through it, normal to the mean line of sight: the two
models' ranges differ by the sagitta of the track's span as seen from the corner (a few
millimetres for 0.8 m of track 4 m away), below the range steps' error. The ranges alone
cannot decide (:func:`~sonarproc.surfaces.reflectors.range_models.point_beats_plane`
rightly says no), the point is not found, and the refit fits a short plane through the
arcs: a diagonal phantom far from every true surface, and a missed corner.

The map decides (:func:`planes_as_corners`). A fitted plane ``P`` is a corner's echo at
``X`` when:

* ``X`` is where ``P`` crosses the line of another fitted plane ``W`` (a wall of the
  corner), on ``W``'s line at or past its end
  (:func:`~sonarproc.surfaces.reflectors.walls.on_wall_lines`: a wall's corner is where
  it ends) and inside ``P``, more than the range tolerance
  (:data:`~sonarproc.surfaces.reflectors.range_models.RANGE_TOL_M`) from ``P``'s ends
  (``P`` straddles ``W``'s line);
* ``P`` crosses ``W`` obliquely: more than the retro-reflection tolerance
  :data:`~sonarproc.surfaces.reflectors.point_echoes.CORNER_TOL_RAD` away from both
  parallel and perpendicular (a real wall meeting ``W`` at a corner meets it square,
  one continuing it is parallel; a plane through a corner normal to the line of sight
  into its opening lies across it, near 45 degrees);
* every reading of ``P`` passes through ``X`` but a few strays (at most
  :data:`~sonarproc.surfaces.reflectors.range_models.STRAY_SHARE` of them: the noise's
  tail): its range is within the range tolerance of its sensor's distance to ``X``, and
  ``X`` lies inside its beam (widened by
  :data:`~sonarproc.surfaces.reflectors.gathering.BEAM_SLACK`). A point fixed by the
  map, with no free parameter, explains the ranges: the arcs all meet where the walls
  end (a region of constant depth);
* the sensors lie on the side of ``W``'s line that ``W`` was seen from (inside the
  corner's opening).

A real plane crossing another wall's line obliquely, just where all of its readings' arcs
meet, and with half of it beyond that wall, would be a coincidence; a retro-reflecting
corner at the end of its wall is what a room is made of. ``P`` goes and a point at ``X``
takes its readings (its kind is then decided like every other point's).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry, SurfaceEchoes, echo_points
from sonarproc.surfaces.fitting.models import SurfaceFit
from sonarproc.surfaces.reflectors.gathering import BEAM_SLACK
from sonarproc.surfaces.reflectors.point_echoes import CORNER_TOL_RAD
from sonarproc.surfaces.reflectors.range_models import (
    RANGE_TOL_M,
    STRAY_SHARE,
    distinct_poses,
    plane_rms,
    sensor_span,
)
from sonarproc.surfaces.reflectors.rcd import MIN_POSES, MIN_READINGS, PointFeature
from sonarproc.surfaces.reflectors.walls import on_wall_lines, side_of_line

__all__ = ["oblique", "passes_through", "planes_as_corners"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
#: A plane's two ends.
Segment = tuple[FloatArray, FloatArray]


def _crossing(p: Segment, w: Segment) -> FloatArray | None:
    """Where the line of ``p`` crosses the line of ``w`` (None when they are parallel)."""
    (a, b), (c, d) = p, w
    u, v = b - a, d - c
    den = float(u[0] * v[1] - u[1] * v[0])
    if abs(den) < 1e-12:
        return None
    t = float((c[0] - a[0]) * v[1] - (c[1] - a[1]) * v[0]) / den
    return np.asarray(a + t * u, dtype=np.float64)


def oblique(u: FloatArray, v: FloatArray) -> bool:
    """Whether directions ``u`` and ``v`` differ by more than :data:`CORNER_TOL_RAD` from
    parallel and from square.

    Examples
    --------
    >>> oblique(np.array([1.0, 0.0]), np.array([1.0, 1.0])), oblique(np.array([1.0, 0.0]),
    ...                                                               np.array([0.0, 2.0]))
    (True, False)
    """
    cos = abs(float(u @ v)) / max(float(np.hypot(*u) * np.hypot(*v)), 1e-12)
    angle = math.acos(min(cos, 1.0))  # 0 .. pi/2
    return CORNER_TOL_RAD < angle < 0.5 * math.pi - CORNER_TOL_RAD


def passes_through(echoes: EchoGeometry, idx: IntArray, x: FloatArray) -> bool:
    """Whether the readings ``idx`` pass through ``x``, but a few strays (module notes):
    within :data:`RANGE_TOL_M` of their range and inside their beam (widened by
    :data:`BEAM_SLACK`), all but :data:`STRAY_SHARE` of them."""
    v = x - echoes.xy[idx]
    dist = np.hypot(v[:, 0], v[:, 1])
    off = np.abs((np.arctan2(v[:, 1], v[:, 0]) - echoes.heading[idx] + math.pi)
                 % (2 * math.pi) - math.pi)  # fmt: skip
    inside = off <= BEAM_SLACK * echoes.half_beam[idx]
    through = (np.abs(dist - echoes.range_m[idx]) <= RANGE_TOL_M) & inside
    return bool(np.count_nonzero(~through) <= STRAY_SHARE * idx.size)


def planes_as_corners(
    fits: list[SurfaceFit], echoes: EchoGeometry, *, got: list[SurfaceEchoes] | None = None
) -> tuple[list[int], list[PointFeature]]:
    """The fitted planes that are a corner's echoes, and their corners (module notes).

    Parameters
    ----------
    fits : list of SurfaceFit
        The fitted surfaces.
    echoes : EchoGeometry
        The readings they were fitted to.
    got : list of SurfaceEchoes, optional
        ``echo_points`` of the ``fits`` at :data:`RANGE_TOL_M`, when the caller has it.

    Returns
    -------
    gone : list of int
        The indices in ``fits`` of those planes, ascending.
    points : list of PointFeature
        One point per plane gone (in the same order), at its corner, with the plane's
        readings.

    Examples
    --------
    A wall along y = 0 from x = 1 to 4, seen from above, and a short diagonal plane
    through (0, 0) whose eight readings, from one sensor driving along y = 3.8 and looking
    back at 231 degrees, all read their distance to (0, 0): the plane is the corner's
    echo.

    >>> xs = np.linspace(2.5, 3.2, 8)
    >>> s = np.r_[np.c_[xs, np.full(8, 3.8)], np.c_[xs, np.ones(8)]]
    >>> heading = np.radians(np.r_[np.full(8, -129.0), np.full(8, -90.0)])
    >>> g = EchoGeometry(s, heading, np.full(16, np.radians(15.0)),
    ...                  np.r_[np.hypot(xs, 3.8), np.ones(8)])
    >>> wall = SurfaceFit("line", np.c_[np.linspace(1, 4, 301), np.zeros(301)], 3.0, 0.0, 8, 8)
    >>> u = np.array([0.8, -0.6]) * 0.4  # across the line of sight
    >>> diag = SurfaceFit("line", np.outer(np.linspace(-1, 1, 81), u), 0.8, 0.0, 8, 8)
    >>> gone, points = planes_as_corners([wall, diag], g)
    >>> gone, [np.round(p.xy, 3).tolist() for p in points]
    ([1], [[0.0, 0.0]])
    """
    lines = [k for k, s in enumerate(fits)
             if s.model == "line" and not s.closed and s.polyline.shape[0] >= 2]  # fmt: skip
    if len(lines) < 2:
        return [], []
    if got is None:
        got = echo_points([s.polyline for s in fits], [s.closed for s in fits], echoes,
                          tol=RANGE_TOL_M)  # fmt: skip
    ends = {k: (fits[k].polyline[0], fits[k].polyline[-1]) for k in lines}
    gone: set[int] = set()
    points: list[PointFeature] = []
    for k in lines:
        idx = got[k].readings
        if idx.size < MIN_READINGS or distinct_poses(echoes.xy[idx]) < MIN_POSES:
            continue
        a, b = ends[k]
        length = math.dist(a, b)
        best: tuple[float, FloatArray] | None = None
        for j in lines:
            if j == k or j in gone or not oblique(ends[k][1] - ends[k][0], ends[j][1] - ends[j][0]):
                continue
            x = _crossing(ends[k], ends[j])
            if x is None:
                continue
            along = float((x - a) @ (b - a)) / max(length, 1e-12)
            if not RANGE_TOL_M < along < length - RANGE_TOL_M:
                continue
            if not bool(on_wall_lines(x, [ends[j]])[0]) or not passes_through(echoes, idx, x):
                continue
            # the sensors inside the corner's opening: on the side W was seen from
            side = np.sign(side_of_line(*ends[j], echoes.xy[idx]))
            w_idx = got[j].readings
            if w_idx.size == 0:
                continue
            w_side = float(np.median(np.sign(side_of_line(*ends[j], echoes.xy[w_idx]))))
            if not bool(np.all(side == w_side)):
                continue
            res = np.hypot(*(echoes.xy[idx] - x).T) - echoes.range_m[idx]
            rms = float(np.sqrt(np.mean(res**2)))
            if best is None or rms < best[0]:
                best = (rms, x)
        if best is None:
            continue
        rms, x = best
        xy, rng = echoes.xy[idx], echoes.range_m[idx]
        gone.add(k)
        points.append(PointFeature(x, idx, distinct_poses(xy), rms, plane_rms(xy, rng),
                                   sensor_span(xy, x)))  # fmt: skip
    return sorted(gone), points

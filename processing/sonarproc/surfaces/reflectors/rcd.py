"""Point reflectors from regions of constant depth (Leonard & Durrant-Whyte 1991).

A concave corner retro-reflects and a convex edge diffracts: each answers a sonar from
one point, whatever the sensor's position, so its readings all lie on arcs through that
point (a *region of constant depth*: a sensor sweeping across it reads one range). A
plane answers from the foot of the perpendicular, a different point for each pose. So a
point reflector is a point ``p`` such that many readings from distinct poses have ranges
equal to their sensor's distance to ``p`` (within the range noise) and hold ``p`` inside
their beams, while no plane explains the same ranges.

:func:`find_point_features` looks for them:

1. **Candidates** are the local maxima of the arc count map (every arc through ``p``
   adds a vote at ``p``), strongest first, at least :data:`MIN_READINGS` votes.
2. **Gathering**: the readings whose range is within :data:`RANGE_TOL_M` of their
   sensor's distance to the candidate, and whose beam (its half-width times
   :data:`BEAM_SLACK`) holds it.
3. **Position**: ``p`` by least squares on those ranges
   (Levenberg-Marquardt, :func:`scipy.optimize.leastsq`), gathering again round the new
   ``p``, twice.
4. **Tests**, each with its physical reason:

   * at least :data:`MIN_READINGS` readings from at least :data:`MIN_POSES` distinct
     sensor positions (positions in one :data:`RANGE_TOL_M` cell give the same range to
     any point, so they add no geometry);
   * the best plane through the same readings (range = the distance to a line, for any
     line) explains them significantly worse than the point (a wall seen from near its
     normal also reads its distance to the foot): its RMS residual is above the range
     steps' own error :data:`RANGE_STEP_NOISE_M` (a plane that explains the ranges to
     within the ranging board's resolution leaves no evidence for anything else), and
     Vuong's (1989) likelihood-ratio test of the two non-nested models on the same
     readings (:func:`point_beats_plane`) prefers the point at the false-alarm rate
     :data:`POINT_FALSE_ALARM`. The test's threshold falls as the readings grow in
     number, so a corner seen from poses on one straight track, where point and plane
     differ by less than a centimetre, is told from a plane when enough readings agree;
   * no diffusely scattering wall through the point explains them either: such a wall
     answers each reading from where its beam's axis meets it, so every point of it is
     seen from many poses at its own distance, like a point reflector; the best line
     through ``p`` whose distances along the readings' axes match their ranges
     (:func:`diffuse_residuals`) must explain them significantly worse than the point, by
     the same test as the plane (a point reflector is heard off the axis too, anywhere
     in the beam, where those distances differ from its range);
   * a circle through them (range = distance to a centre minus a radius) has a radius
     under :data:`MAX_POINT_RADIUS_M`, within two standard errors of zero, or whose sag
     over the sensors' span is within the time walk (:data:`TIME_WALK_M`): a larger one
     is a cylinder, left to the arc fits.

   The readings of an accepted point are claimed by it (a reading has one first echo),
   so weaker candidates nearby are tested on the rest.

Which kind of point it is (a concave ``corner`` or a convex ``edge``) is decided against
the fitted planes by :mod:`sonarproc.surfaces.reflectors.classify`, after
:mod:`sonarproc.surfaces.reflectors.confirm` checked it against them.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain

import numpy as np
import numpy.typing as npt
from scipy import ndimage, special
from scipy.optimize import leastsq
from scipy.spatial import cKDTree

from sonarproc.grid import Grid
from sonarproc.surfaces.echoes.specular import EchoGeometry

__all__ = [
    "BEAM_SLACK",
    "MIN_POSES",
    "MIN_READINGS",
    "POINT_FALSE_ALARM",
    "RANGE_STEP_NOISE_M",
    "RANGE_TOL_M",
    "PointFeature",
    "diffuse_residuals",
    "distinct_poses",
    "find_point_features",
    "plane_residuals",
    "point_beats_plane",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: A reading passes through a point when its range is within this (m) of the distance
#: from its sensor: a robot's 1-inch range steps (+-1.27 cm), a few mm of noise and the
#: time walk of a weak echo (up to about 1.5 cm long, Kleeman & Kuc 1995) add up to it.
#: It is the last echo round's tolerance of the plane refits too
#: (:data:`sonarproc.surfaces.echoes.refine.ROUNDS_M`).
RANGE_TOL_M = 0.03
#: The range noise (m) a reading's residual is weighed by: the 1-inch quantisation's
#: uniform error alone is 2.54 cm / sqrt(12) = 7.3 mm; with a few mm of noise, 1 cm.
RANGE_NOISE_M = 0.01
#: A point echo is heard beyond the nominal half-width of the beam: the effective beam
#: of a Polaroid transducer widens close by (16 degrees at 0.5 m for a nominal 12.5,
#: Kuc & Siegel 1987), most for strong echoes such as a corner's.
BEAM_SLACK = 1.3
#: Fewest readings of a point: a sonar ring fires about eight times per 0.4 m of travel
#: at a reflector 2 m away within its beam; fewer are a chance crossing of arcs.
MIN_READINGS = 8
#: Fewest distinct sensor positions: a point has two unknowns, and so has a plane's
#: tangent line; five positions leave three ranges to tell them apart and outvote one
#: stray echo.
MIN_POSES = 5
#: The error (m) of the ranging board's 1-inch range steps alone (uniform over a step:
#: 2.54 cm / sqrt(12)). Residuals below it are no evidence: a plane that explains the
#: ranges to within it is not rejected, and a model's residual is floored at it in
#: :func:`point_beats_plane`.
RANGE_STEP_NOISE_M = 0.0254 / math.sqrt(12.0)
#: The point-versus-plane test's false-alarm rate: the chance that a plane's readings
#: prefer a point (one-sided, Vuong's statistic is standard normal when both models fit
#: equally well).
POINT_FALSE_ALARM = 0.01
#: A circle through the readings with a larger radius (m) than this, and more than two
#: standard errors from zero, is a cylinder: a pillar, not a point.
MAX_POINT_RADIUS_M = 0.05
#: The largest range bias (m) that varies across a beam: a weak echo off the beam's axis
#: crosses the receiver threshold late by up to about 1.5 cm (Kleeman & Kuc 1995). A
#: circle's radius ``R`` shows in the ranges only as the sag ``R (1 - cos(span / 2))``
#: across the sensors' span; a sag under this bias is no evidence of a radius.
TIME_WALK_M = 0.015
#: Local maxima of the counts closer than this (m) are one candidate: the arcs through a
#: point spread their votes over the range tolerance round it.
CANDIDATE_SPACING_M = 2 * RANGE_TOL_M
#: An accepted point's readings are gathered again this many times round the new
#: position.
GATHER_ROUNDS = 2
#: Most candidates tested, strongest first: a point reflector is among the strongest
#: local maxima of the map; the weakest are the many chance crossings of arcs.
MAX_CANDIDATES = 400

# The directions :func:`plane_rms` and :func:`diffuse_rms` try (every half degree), and
# the products of their cosines and sines, computed once.
_PLANE_A = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
_PLANE_CA, _PLANE_SA = np.cos(_PLANE_A), np.sin(_PLANE_A)
_PLANE_CC, _PLANE_CS2, _PLANE_SS = _PLANE_CA * _PLANE_CA, 2 * _PLANE_CA * _PLANE_SA, _PLANE_SA**2
_DIFFUSE_A = np.linspace(0.0, np.pi, 360, endpoint=False)
_DIFFUSE_N = np.column_stack((np.cos(_DIFFUSE_A), np.sin(_DIFFUSE_A)))
_GRAZING = math.sin(math.radians(3.0))
# the one-sided standard normal quantile of POINT_FALSE_ALARM
_POINT_Z = float(special.ndtri(1.0 - POINT_FALSE_ALARM))
#: A batched screening value within this (m) of its threshold is recomputed by the
#: candidate's own test: the batched sums round differently (by about 1e-15 m).
_SCREEN_MARGIN_M = 1e-9


@dataclass(frozen=True, eq=False)
class PointFeature:
    """A point reflector: its position, the readings that echo from it, their geometry.

    Attributes
    ----------
    xy : ndarray, shape (2,)
        Position (m).
    readings : ndarray of int
        The readings echoing from it (indices into the :class:`EchoGeometry` given).
    poses : int
        Distinct sensor positions among them.
    rms_m : float
        RMS range residual of the point (m).
    plane_rms_m : float
        RMS range residual of the best plane through the same readings (m).
    span_rad : float
        Angle the sensors span as seen from the point (rad).
    """

    xy: FloatArray
    readings: IntArray
    poses: int
    rms_m: float
    plane_rms_m: float
    span_rad: float

    @property
    def support(self) -> int:
        """Readings echoing from the point."""
        return int(self.readings.size)


def _as_index(found: list[int]) -> IntArray:
    """A k-d tree's list of point indices as an index array."""
    return np.fromiter(found, dtype=np.intp, count=len(found))


def _wrap(a: FloatArray) -> FloatArray:
    return np.asarray((a + np.pi) % (2 * np.pi) - np.pi, dtype=np.float64)


class _ArcIndex:
    """The readings whose arcs may pass near a point: k-d trees of the arcs' midpoints.

    Every point of a reading's arc (within :data:`BEAM_SLACK` times its half beam) lies
    within the arc's chord of its midpoint; readings are grouped by that reach (doubling
    classes), one tree per class, so a query asks each tree for its class's reach.
    """

    def __init__(self, echoes: EchoGeometry, free: npt.NDArray[np.bool_]) -> None:
        idx = np.flatnonzero(free)
        half = np.minimum(BEAM_SLACK * echoes.half_beam[idx], 0.5 * np.pi)
        rng = echoes.range_m[idx]
        h = echoes.heading[idx]
        mid = echoes.xy[idx] + rng[:, None] * np.column_stack((np.cos(h), np.sin(h)))
        reach = 2.0 * rng * np.sin(0.5 * half) + RANGE_TOL_M
        cls = np.ceil(np.log2(np.maximum(reach, 0.05) / 0.05)).astype(np.int64)
        self.groups: list[tuple[IntArray, cKDTree, float]] = []
        for k in np.unique(cls):
            sel = np.flatnonzero(cls == k)
            rows = idx[sel]
            self.groups.append((rows, cKDTree(mid[sel]), float(reach[sel].max())))

    def near(self, p: FloatArray) -> IntArray:
        """Readings whose arcs may pass within :data:`RANGE_TOL_M` of ``p``."""
        # the trees answer with lists; np.fromiter reads one about twice as fast as
        # indexing with it (a wall end of a long log is near thousands of readings)
        parts = [rows[_as_index(tree.query_ball_point(p, r))] for rows, tree, r in self.groups]
        return np.concatenate(parts).astype(np.intp) if parts else np.zeros(0, np.intp)

    def near_many(self, pts: FloatArray) -> tuple[IntArray, IntArray]:
        """:meth:`near` of every point of ``pts`` (C, 2) at once: (point, reading) pairs."""
        which, rows_near = [np.zeros(0, np.intp)], [np.zeros(0, np.intp)]
        for rows, tree, r in self.groups:
            hits = tree.query_ball_point(pts, r)
            counts = np.fromiter(map(len, hits), dtype=np.intp, count=len(hits))
            if counts.sum() == 0:
                continue
            which.append(np.repeat(np.arange(len(hits)), counts))
            flat = np.fromiter(chain.from_iterable(hits), dtype=np.intp, count=int(counts.sum()))
            rows_near.append(rows[flat])
        return np.concatenate(which), np.concatenate(rows_near)


def _passes(echoes: EchoGeometry, idx: IntArray, d: FloatArray) -> npt.NDArray[np.bool_]:
    """Whether readings ``idx``, ``d`` (N, 2) from the point to their sensors, pass through it.

    Through it: the range within :data:`RANGE_TOL_M` of the distance, the point inside
    the beam (its half-width times :data:`BEAM_SLACK`).
    """
    dist = np.hypot(d[:, 0], d[:, 1])
    ok = np.abs(dist - echoes.range_m[idx]) <= RANGE_TOL_M
    bearing = np.arctan2(-d[ok, 1], -d[ok, 0])
    off = np.abs(_wrap(bearing - echoes.heading[idx[ok]]))
    ok[ok] = off <= BEAM_SLACK * echoes.half_beam[idx[ok]]
    return ok


def _gather(
    echoes: EchoGeometry, free: npt.NDArray[np.bool_], p: FloatArray, index: _ArcIndex | None
) -> IntArray:
    """Free readings whose arcs pass within :data:`RANGE_TOL_M` of ``p`` inside their beams."""
    idx = np.flatnonzero(free) if index is None else np.sort(index.near(p))
    if index is not None:
        idx = idx[free[idx]]
    return idx[_passes(echoes, idx, echoes.xy[idx] - p)]


def _gather_all(
    echoes: EchoGeometry, free: npt.NDArray[np.bool_], starts: FloatArray, index: _ArcIndex
) -> list[IntArray]:
    """:func:`_gather` round every start at once (each list sorted, as :func:`_gather`'s).

    A reading passes or not whatever the other readings do, so a gather made now and
    restricted later to the readings still free is the gather made then.
    """
    which, idx = index.near_many(starts)
    keep = free[idx]
    which, idx = which[keep], idx[keep]
    keep = _passes(echoes, idx, echoes.xy[idx] - starts[which])
    which, idx = which[keep], idx[keep]
    order = np.lexsort((idx, which))
    which, idx = which[order], idx[order]
    return np.split(idx, np.searchsorted(which, np.arange(1, starts.shape[0])))


def _levenberg_marquardt(
    res: Callable[[FloatArray], FloatArray], jac: Callable[[FloatArray], FloatArray], x0: FloatArray
) -> FloatArray:
    """The least-squares solution from ``x0``: MINPACK's Levenberg-Marquardt (``lmder``).

    :func:`scipy.optimize.leastsq` runs the ``lmder`` that
    ``scipy.optimize.least_squares(method="lm")`` runs, with the same tolerances (1e-8),
    step bound factor (100), scaling (by the Jacobian's columns) and evaluation limit
    (100 per unknown), so the solution is the same to the last bit; it skips
    ``least_squares``' per-call set-up, about 3 times the solve for 2 or 3 unknowns and
    hundreds of candidate points per log. The full output keeps a solve that stops at
    its evaluation limit silent, as ``least_squares``' is.
    """
    x = leastsq(res, x0, Dfun=jac, full_output=True, ftol=1e-8, xtol=1e-8, gtol=1e-8,
                maxfev=100 * x0.size, factor=100.0)[0]  # fmt: skip
    return np.asarray(x, dtype=np.float64)


def _fit_point(xy: FloatArray, rng: FloatArray, p0: FloatArray) -> tuple[FloatArray, float]:
    """Least-squares point through the ranges, and its RMS residual (m).

    The readings were gathered within :data:`RANGE_TOL_M` of a first estimate, so no
    residual is wild: plain least squares (Levenberg-Marquardt) suffices.
    """

    def res(p: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(xy[:, 0] - p[0], xy[:, 1] - p[1]) - rng, dtype=np.float64)

    def jac(p: FloatArray) -> FloatArray:
        d = p - xy
        return np.asarray(d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None])

    p = _levenberg_marquardt(res, jac, p0)
    return p, float(np.sqrt(np.mean(res(p) ** 2)))


def plane_rms(xy: FloatArray, rng: FloatArray) -> float:
    """RMS residual (m) of the best plane's ranges: ``range = d - n . sensor`` for a unit ``n``.

    For a direction ``n`` the best ``d`` is the mean of ``range + n . sensor``, and the
    residual is that sum's spread; the spread is a quadratic form in ``(cos a, sin a)``,
    evaluated at every half degree.

    Examples
    --------
    >>> xy = np.c_[np.linspace(-1, 1, 9), np.zeros(9)]
    >>> plane_rms(xy, np.full(9, 2.0)) < 1e-6          # a wall parallel to the poses
    True
    >>> round(plane_rms(xy, np.hypot(xy[:, 0], 2.0)), 3)  # a point 2 m ahead
    0.086
    """
    m = np.column_stack((xy, rng))
    m = m - m.mean(axis=0)
    c = (m.T @ m) / m.shape[0]
    var = (c[2, 2] + 2 * (_PLANE_CA * c[0, 2] + _PLANE_SA * c[1, 2])
           + _PLANE_CC * c[0, 0] + _PLANE_CS2 * c[0, 1] + _PLANE_SS * c[1, 1])  # fmt: skip
    return float(math.sqrt(max(float(var.min()), 0.0)))


def plane_residuals(xy: FloatArray, rng: FloatArray) -> FloatArray:
    """Range residuals (m) of the best plane of :func:`plane_rms` (its direction, its offset).

    Examples
    --------
    >>> xy = np.c_[np.linspace(-1, 1, 9), np.zeros(9)]
    >>> bool(np.allclose(plane_residuals(xy, np.full(9, 2.0)), 0.0))
    True
    >>> r = plane_residuals(xy, np.hypot(xy[:, 0], 2.0))
    >>> round(float(np.sqrt(np.mean(r**2))), 3) == round(plane_rms(xy, np.hypot(xy[:, 0], 2.0)), 3)
    True
    """
    m = np.column_stack((xy, rng))
    m = m - m.mean(axis=0)
    c = (m.T @ m) / m.shape[0]
    var = (c[2, 2] + 2 * (_PLANE_CA * c[0, 2] + _PLANE_SA * c[1, 2])
           + _PLANE_CC * c[0, 0] + _PLANE_CS2 * c[0, 1] + _PLANE_SS * c[1, 1])  # fmt: skip
    k = int(np.argmin(var))
    return np.asarray(m[:, 2] + _PLANE_CA[k] * m[:, 0] + _PLANE_SA[k] * m[:, 1], dtype=np.float64)


def point_beats_plane(point_res: FloatArray, plane_res: FloatArray) -> bool:
    """Whether a point explains the same ranges significantly better than a plane.

    Vuong's (1989) test of two non-nested models (two unknowns each): per reading, the
    log-likelihood ratio ``l_i`` of Gaussian residuals with each model's own variance
    (floored at :data:`RANGE_STEP_NOISE_M` squared: below the range steps' error a
    residual says nothing); ``z = sqrt(N) mean(l) / std(l)`` is standard normal when both
    fit equally well, and the point wins when ``z`` exceeds its one-sided
    :data:`POINT_FALSE_ALARM` quantile. Unlike a fixed ratio of RMS residuals, its
    threshold falls as readings accumulate: a point and a plane a few millimetres apart
    are told apart by many readings, not by a few.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> noise = rng.normal(0.0, 0.008, 40)
    >>> point_beats_plane(noise, noise + rng.normal(0.0, 0.012, 40))
    True
    >>> point_beats_plane(noise, rng.normal(0.0, 0.008, 40))
    False
    """
    floor = RANGE_STEP_NOISE_M**2
    v_pt = max(float(np.mean(point_res**2)), floor)
    v_pl = max(float(np.mean(plane_res**2)), floor)
    ll = 0.5 * math.log(v_pl / v_pt) + plane_res**2 / (2 * v_pl) - point_res**2 / (2 * v_pt)
    mean, sd = float(ll.mean()), float(ll.std())
    if mean <= 0.0:
        return False
    if sd == 0.0:
        return True
    return math.sqrt(ll.size) * mean / sd >= _POINT_Z


def diffuse_residuals(
    xy: FloatArray, heading: FloatArray, rng: FloatArray, p: npt.ArrayLike
) -> FloatArray:
    """Range residuals (m) of the best diffusely scattering line through ``p``.

    For a line through ``p`` with unit normal ``n`` (every half degree), a reading's
    predicted range is the distance along its beam's axis to the line,
    ``n . (p - s) / n . h``; axes within 3 degrees of the line's direction, or meeting
    it behind the sensor, count as a 1 m miss (so do larger misses). The best line has
    the least RMS residual.

    Examples
    --------
    >>> s = np.c_[np.linspace(-1.0, 1.0, 9), np.zeros(9)]
    >>> h = np.full(9, np.pi / 2)                         # looking straight at y = 2
    >>> float(np.abs(diffuse_residuals(s, h, np.full(9, 2.0), [0.0, 2.0])).max()) < 1e-12
    True
    """
    q = np.asarray(p, dtype=np.float64)
    num = (q - xy) @ _DIFFUSE_N.T
    den = np.column_stack((np.cos(heading), np.sin(heading))) @ _DIFFUSE_N.T
    ok = np.abs(den) > _GRAZING
    t = np.where(ok, num / np.where(ok, den, 1.0), -1.0)
    miss = np.where(t > 0, np.clip(t - rng[:, None], -1.0, 1.0), 1.0)
    k = int(np.argmin(np.mean(miss * miss, axis=0)))
    return np.asarray(miss[:, k], dtype=np.float64)


def diffuse_rms(xy: FloatArray, heading: FloatArray, rng: FloatArray, p: npt.ArrayLike) -> float:
    """RMS residual (m) of the best diffusely scattering line through ``p``.

    The line of :func:`diffuse_residuals`.

    Examples
    --------
    >>> s = np.c_[np.linspace(-1.0, 1.0, 9), np.zeros(9)]
    >>> h = np.full(9, np.pi / 2)                         # looking straight at y = 2
    >>> round(diffuse_rms(s, h, np.full(9, 2.0), [0.0, 2.0]), 6)
    0.0
    """
    r = diffuse_residuals(xy, heading, rng, p)
    return float(np.sqrt(np.mean(r * r)))


def _radius_says_cylinder(xy: FloatArray, rng: FloatArray, p: FloatArray) -> bool:
    """Whether a circle (range = distance to a centre minus a radius) has a clear radius."""

    def res(q: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(xy[:, 0] - q[0], xy[:, 1] - q[1]) - q[2] - rng, np.float64)

    def jac(q: FloatArray) -> FloatArray:
        d = q[:2] - xy
        u = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
        return np.column_stack((u, -np.ones(xy.shape[0])))

    q = _levenberg_marquardt(res, jac, np.r_[p, 0.0])
    radius = float(q[2])
    if radius <= MAX_POINT_RADIUS_M:
        return False
    # seen from a narrow span a point and a small circle differ by less than the time walk
    # (a retro-reflecting corner seen from inside its right angle is no cylinder)
    if radius * (1.0 - math.cos(0.5 * _span(xy, q[:2]))) <= TIME_WALK_M:
        return False
    j = jac(q)
    jtj = j.T @ j
    try:
        cov = np.linalg.inv(jtj) * RANGE_NOISE_M**2
    except np.linalg.LinAlgError:
        return False
    return radius > 2.0 * math.sqrt(max(float(cov[2, 2]), 0.0))


def pose_keys(xy: FloatArray) -> npt.NDArray[np.int64]:
    """One integer per :data:`RANGE_TOL_M` cell of the sensor positions ``xy`` (N, 2).

    Positions in one cell give the same range to any point (they add no geometry); equal
    keys are equal cells (a cell index fits in 31 bits up to 64 000 km from the origin).
    """
    cells = np.floor(xy / RANGE_TOL_M).astype(np.int64)
    return np.asarray(cells[:, 0] * (1 << 32) + cells[:, 1], dtype=np.int64)


def distinct_poses(xy: FloatArray) -> int:
    """Distinct :data:`RANGE_TOL_M` cells the sensor positions ``xy`` fall in.

    >>> distinct_poses(np.array([[0.0, 0.0], [0.01, 0.0], [0.05, 0.0], [0.0, 0.05]]))
    3
    """
    return int(np.unique(pose_keys(xy)).size)


def _span(xy: FloatArray, p: FloatArray) -> float:
    """Angle (rad) the sensors span as seen from ``p`` (the complement of the largest gap)."""
    b = np.sort(np.arctan2(xy[:, 1] - p[1], xy[:, 0] - p[0]))
    if b.size < 2:
        return 0.0
    gaps = np.diff(np.r_[b, b[0] + 2 * np.pi])
    return float(2 * np.pi - gaps.max())


def candidates(
    counts: npt.ArrayLike, grid: Grid, *, around: FloatArray | None = None, reach: float = 0.0
) -> FloatArray:
    """Local maxima of the counts with at least :data:`MIN_READINGS` votes, strongest first.

    A plateau of equal maxima, or maxima closer than :data:`CANDIDATE_SPACING_M`, give
    their strongest (first) one. With ``around`` (P, 2), only the maxima within ``reach``
    (m) of one of those points are looked for (in windows of the map: a long log's map is
    millions of cells).

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=0.02, nx=20, ny=10)
    >>> c = np.zeros(g.shape, int); c[5, 7] = 12; c[5, 8] = 11; c[2, 15] = 3
    >>> candidates(c, g).round(3).tolist()
    [[0.14, 0.1]]
    >>> candidates(c, g, around=np.array([[0.3, 0.04]]), reach=0.05).tolist()
    []
    """
    c = np.asarray(counts)
    size = max(3, 2 * round(CANDIDATE_SPACING_M / grid.cell) + 1)
    if around is None:
        windows = [(slice(0, grid.ny), slice(0, grid.nx))]
    else:
        pad = math.ceil(reach / grid.cell) + size
        iy, ix = grid.to_index(around[:, 0], around[:, 1])
        windows = [(slice(max(0, y - pad), max(0, y + pad + 1)),
                    slice(max(0, x - pad), max(0, x + pad + 1)))
                   for y, x in zip(iy.tolist(), ix.tolist(), strict=True)]  # fmt: skip
    rows, cols, votes = [], [], []
    for wy, wx in windows:
        part = c[wy, wx]
        if part.size == 0:
            continue
        peak = (part == ndimage.maximum_filter(part, size=size, mode="constant")) & (
            part >= MIN_READINGS
        )
        py, px = np.nonzero(peak)
        rows.append(py + wy.start)
        cols.append(px + wx.start)
        votes.append(part[py, px])
    if not rows:
        return np.zeros((0, 2))
    iy_all, ix_all, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(votes)
    order = np.argsort(-v, kind="stable")
    x, y = grid.to_world(iy_all[order], ix_all[order])
    pts_xy = np.column_stack((x, y)).astype(np.float64)
    _, first = np.unique(pts_xy, axis=0, return_index=True)  # windows overlap
    pts_xy = pts_xy[np.sort(first)]
    if around is not None:
        gap = pts_xy[:, None, :] - around[None, :, :]
        pts_xy = pts_xy[np.hypot(gap[..., 0], gap[..., 1]).min(axis=1) <= reach]
    keep = np.ones(pts_xy.shape[0], dtype=bool)
    for i, near in enumerate(cKDTree(pts_xy).query_ball_point(pts_xy, CANDIDATE_SPACING_M)):
        if keep[i]:
            keep[[j for j in near if j > i]] = False
    return pts_xy[keep][:MAX_CANDIDATES]


def find_point_features(
    echoes: EchoGeometry,
    counts: npt.ArrayLike,
    grid: Grid,
    *,
    free: npt.NDArray[np.bool_] | None = None,
    skip: Callable[[FloatArray], npt.NDArray[np.bool_]] | None = None,
    around: FloatArray | None = None,
    reach: float = 0.0,
) -> list[PointFeature]:
    """Point reflectors of a log (see the module notes), strongest first.

    Parameters
    ----------
    echoes : EchoGeometry
        The readings.
    counts : array_like of int, shape grid.shape
        Arc counts per cell (any cell size; a 2 cm map is plenty).
    grid : Grid
        The counts' grid.
    free : ndarray of bool, optional
        The readings a point may take (default: all).
    skip : callable, optional
        Given the candidates (C, 2), true for those not to test (inside walls found
        already: :func:`sonarproc.surfaces.reflectors.walls.inside_walls`).
    around, reach : ndarray (P, 2) and float, optional
        Look only within ``reach`` (m) of these points (see :func:`candidates`).

    Returns
    -------
    list of PointFeature
        Each reading belongs to at most one of them.
    """
    free = np.ones(echoes.size, dtype=bool) if free is None else free.copy()
    found: list[PointFeature] = []
    starts = candidates(counts, grid, around=around, reach=reach)
    if skip is not None and starts.size:
        starts = starts[~skip(starts)]
    if not starts.size:
        return found
    index = _ArcIndex(echoes, free)
    # every candidate's first gather and cheap tests at once: most fail them (they lie
    # on walls); an accepted point's readings are taken out of the later gathers
    gathers = _gather_all(echoes, free, starts, index)
    verdicts = _enough_all(echoes, gathers)
    found_xy = np.zeros((0, 2))
    for c, idx, verdict in zip(starts, gathers, verdicts.tolist(), strict=True):
        if found and _near_found(c, found_xy, found):
            continue
        still = free[idx]
        first = (idx, verdict) if still.all() else (idx[still], -1)
        feature = _test_point(echoes, free, c, index, first)
        if feature is not None:
            free[feature.readings] = False
            found.append(feature)
            found_xy = np.vstack((found_xy, feature.xy))
    return found


def _near_found(c: FloatArray, found_xy: FloatArray, found: list[PointFeature]) -> bool:
    """Whether ``c`` lies within :data:`CANDIDATE_SPACING_M` of a point found already."""
    gap = float(np.hypot(found_xy[:, 0] - c[0], found_xy[:, 1] - c[1]).min())
    if abs(gap - CANDIDATE_SPACING_M) > _SCREEN_MARGIN_M:
        return gap < CANDIDATE_SPACING_M
    return min(math.dist(c, f.xy) for f in found) < CANDIDATE_SPACING_M


def _enough(echoes: EchoGeometry, idx: IntArray) -> bool:
    """The cheap tests: readings, distinct poses, and no plane within the range steps' error."""
    return _cheap_tests(echoes, idx) is not None


def _cheap_tests(echoes: EchoGeometry, idx: IntArray) -> tuple[int, float] | None:
    """:func:`_enough`'s tests; when they pass, the distinct poses and :func:`plane_rms`."""
    if idx.size < MIN_READINGS:
        return None
    poses = distinct_poses(echoes.xy[idx])
    if poses < MIN_POSES:
        return None
    prms = plane_rms(echoes.xy[idx], echoes.range_m[idx])
    return (poses, prms) if prms >= RANGE_STEP_NOISE_M else None


def _enough_all(echoes: EchoGeometry, gathers: list[IntArray]) -> npt.NDArray[np.int8]:
    """:func:`_enough` of every gather at once: 1 passes, 0 fails, -1 too close to tell.

    The readings and distinct poses are counted exactly; :func:`plane_rms` is evaluated
    for all gathers together (the same quadratic form, from per-gather sums that round
    differently), and a value within :data:`_SCREEN_MARGIN_M` of the threshold is left
    to :func:`_enough`.
    """
    sizes = np.fromiter(map(len, gathers), dtype=np.intp, count=len(gathers))
    verdict = np.zeros(len(gathers), dtype=np.int8)
    if not len(gathers) or sizes.max(initial=0) < MIN_READINGS:
        return verdict
    which = np.repeat(np.arange(len(gathers)), sizes)
    idx = np.concatenate(gathers)
    # distinct poses: distinct (gather, pose cell) pairs
    key = np.unique(np.column_stack((which, pose_keys(echoes.xy[idx]))), axis=0)[:, 0]
    poses = np.bincount(key, minlength=len(gathers))
    test = np.flatnonzero((sizes >= MIN_READINGS) & (poses >= MIN_POSES))
    if test.size == 0:
        return verdict
    rows = np.isin(which, test)
    which, idx = np.searchsorted(test, which[rows]), idx[rows]
    n = sizes[test].astype(np.float64)
    m = np.column_stack((echoes.xy[idx], echoes.range_m[idx]))
    mean = np.stack([np.bincount(which, m[:, j], test.size) for j in range(3)], axis=1) / n[:, None]
    m = m - mean[which]

    def cov(i: int, j: int) -> FloatArray:
        return np.bincount(which, m[:, i] * m[:, j], test.size)[:, None] / n[:, None]

    var = (cov(2, 2) + 2 * (_PLANE_CA * cov(0, 2) + _PLANE_SA * cov(1, 2))
           + _PLANE_CC * cov(0, 0) + _PLANE_CS2 * cov(0, 1) + _PLANE_SS * cov(1, 1))  # fmt: skip
    rms = np.sqrt(np.maximum(var.min(axis=1), 0.0))
    threshold = RANGE_STEP_NOISE_M
    verdict[test] = np.where(np.abs(rms - threshold) <= _SCREEN_MARGIN_M, -1, rms >= threshold)
    return verdict


def _test_point(
    echoes: EchoGeometry,
    free: npt.NDArray[np.bool_],
    start: FloatArray,
    index: _ArcIndex | None,
    first: tuple[IntArray, int] | None = None,
) -> PointFeature | None:
    """The point reflector the free readings make round ``start``, or None (module notes).

    ``first``: the gather round ``start`` and its :func:`_enough_all` verdict, when known.
    """
    p = start
    idx, verdict = (_gather(echoes, free, p, index), -1) if first is None else first
    # the cheap tests first: most candidates lie on walls, whose readings a plane explains
    for _ in range(GATHER_ROUNDS):
        if not (bool(verdict) if verdict >= 0 else _enough(echoes, idx)):
            return None
        verdict = -1
        p, _ = _fit_point(echoes.xy[idx], echoes.range_m[idx], p)
        idx = _gather(echoes, free, p, index)
    return point_feature(echoes, idx, p)


def point_feature(echoes: EchoGeometry, idx: IntArray, start: npt.ArrayLike) -> PointFeature | None:
    """The point through the readings ``idx`` if it passes every test (module notes), else None.

    Parameters
    ----------
    echoes : EchoGeometry
        The readings.
    idx : ndarray of int
        The readings to fit (indices into ``echoes``).
    start : array_like, shape (2,)
        Where the least squares start (m).

    Returns
    -------
    PointFeature or None
    """
    cheap = _cheap_tests(echoes, idx)
    if cheap is None:
        return None
    poses, prms = cheap
    xy, rng = echoes.xy[idx], echoes.range_m[idx]
    p, rms = _fit_point(xy, rng, np.asarray(start, dtype=np.float64))
    point_res = np.hypot(xy[:, 0] - p[0], xy[:, 1] - p[1]) - rng
    if not point_beats_plane(point_res, plane_residuals(xy, rng)):
        return None
    if not point_beats_plane(point_res, diffuse_residuals(xy, echoes.heading[idx], rng, p)):
        return None
    if _radius_says_cylinder(xy, rng, p):
        return None
    return PointFeature(p, idx, poses, rms, prms, _span(xy, p))

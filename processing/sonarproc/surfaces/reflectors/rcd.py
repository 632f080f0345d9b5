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
   ``p``, twice. An accepted point's position is fitted once more with the time walk of
   its echoes off the beams' axes (:mod:`sonarproc.surfaces.reflectors.time_walk`): seen
   from a narrow span the walk would shift it sideways.
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
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt
from scipy.optimize import leastsq

from sonarproc.grid import Grid
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.gathering import (
    BEAM_SLACK,
    CANDIDATE_SPACING_M,
    MIN_READINGS,
    candidates,
)
from sonarproc.surfaces.reflectors.gathering import ArcIndex as _ArcIndex
from sonarproc.surfaces.reflectors.gathering import gather as _gather
from sonarproc.surfaces.reflectors.gathering import gather_all as _gather_all
from sonarproc.surfaces.reflectors.head_on import head_on_split
from sonarproc.surfaces.reflectors.range_models import (
    POINT_FALSE_ALARM,
    RANGE_STEP_NOISE_M,
    RANGE_TOL_M,
    diffuse_residuals,
    distinct_poses,
    plane_residuals,
    plane_rms,
    plane_variances,
    point_beats_plane,
    pose_keys,
    sensor_span,
)
from sonarproc.surfaces.reflectors.time_walk import TIME_WALK_M, fit_point_with_walk, walk_shape

__all__ = [
    "BEAM_SLACK",
    "MIN_POSES",
    "MIN_READINGS",
    "POINT_FALSE_ALARM",
    "RANGE_STEP_NOISE_M",
    "RANGE_TOL_M",
    "PointFeature",
    "candidates",
    "clear_radius",
    "diffuse_residuals",
    "distinct_poses",
    "find_point_features",
    "fit_circle",
    "plane_residuals",
    "plane_rms",
    "point_beats_plane",
    "point_feature",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: The range noise (m) a reading's residual is weighed by: the 1-inch quantisation's
#: uniform error alone is 2.54 cm / sqrt(12) = 7.3 mm; with a few mm of noise, 1 cm.
RANGE_NOISE_M = 0.01
#: Fewest distinct sensor positions: a point has two unknowns, and so has a plane's
#: tangent line; five positions leave three ranges to tell them apart and outvote one
#: stray echo.
MIN_POSES = 5
#: A circle through the readings with a larger radius (m) than this, and more than two
#: standard errors from zero, is a cylinder: a pillar, not a point.
MAX_POINT_RADIUS_M = 0.05
#: An accepted point's readings are gathered again this many times round the new
#: position.
GATHER_ROUNDS = 2
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
    left : ndarray of int
        The head-on echoes of a plane it gathered and left to the plane (no other point
        takes them either).
    """

    xy: FloatArray
    readings: IntArray
    poses: int
    rms_m: float
    plane_rms_m: float
    span_rad: float
    left: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.intp))

    @property
    def support(self) -> int:
        """Readings echoing from the point."""
        return int(self.readings.size)


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


def _circle_jacobian(xy: FloatArray, q: FloatArray) -> FloatArray:
    """Jacobian of a circle's range residuals (:func:`fit_circle`) at ``q`` = (x, y, radius)."""
    d = q[:2] - xy
    u = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
    return np.column_stack((u, -np.ones(xy.shape[0])))


def fit_circle(xy: FloatArray, rng: FloatArray, start: npt.ArrayLike) -> FloatArray:
    """The least-squares circle through the ranges: (centre x, centre y, radius) in m.

    A cylinder answers from the point of it facing the sensor, so a reading's range is its
    distance to the centre less the radius.

    Parameters
    ----------
    xy : ndarray, shape (N, 2)
        Sensor positions (m).
    rng : ndarray, shape (N,)
        Their ranges (m).
    start : array_like, shape (2,)
        Where the centre's search starts (m); the radius starts at zero.

    Examples
    --------
    >>> s = np.array([[1.0, 0.0], [0.0, 1.5], [-2.0, 0.0], [0.0, -1.0]])
    >>> q = fit_circle(s, np.hypot(*s.T) - 0.2, [0.1, 0.1])
    >>> bool(np.hypot(*q[:2]) < 1e-6), round(float(q[2]), 6)
    (True, 0.2)
    """

    def res(q: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(xy[:, 0] - q[0], xy[:, 1] - q[1]) - q[2] - rng, np.float64)

    q0 = np.r_[np.asarray(start, dtype=np.float64).reshape(2), 0.0]
    return _levenberg_marquardt(res, lambda q: _circle_jacobian(xy, q), q0)


def clear_radius(xy: FloatArray, q: FloatArray) -> bool:
    """Whether a circle ``q`` = (x, y, radius) fitted to readings from ``xy`` has a clear radius.

    Clear: above :data:`MAX_POINT_RADIUS_M`; its sag over the span the sensors see it from
    above the time walk (seen from a narrow span a point and a small circle differ by less
    than that: a retro-reflecting corner seen from inside its right angle is no
    cylinder); and above two standard errors of the fit (range noise
    :data:`RANGE_NOISE_M`).

    Examples
    --------
    >>> s = np.c_[np.linspace(-1.5, 1.5, 16), np.zeros(16)]
    >>> clear_radius(s, np.array([0.0, 1.0, 0.2])), clear_radius(s, np.array([0.0, 1.0, 0.0]))
    (True, False)
    """
    radius = float(q[2])
    if not radius > MAX_POINT_RADIUS_M:
        return False
    if radius * (1.0 - math.cos(0.5 * sensor_span(xy, q[:2]))) <= TIME_WALK_M:
        return False
    j = _circle_jacobian(xy, q)
    try:
        cov = np.linalg.inv(j.T @ j) * RANGE_NOISE_M**2
    except np.linalg.LinAlgError:
        return False
    return radius > 2.0 * math.sqrt(max(float(cov[2, 2]), 0.0))


def _radius_says_cylinder(xy: FloatArray, rng: FloatArray, p: FloatArray) -> bool:
    """Whether a circle (range = distance to a centre minus a radius) fitted from the point
    ``p`` has a clear radius (:func:`clear_radius`)."""
    return clear_radius(xy, fit_circle(xy, rng, p))


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
            free[feature.left] = False
            found.append(feature)
            found_xy = np.vstack((found_xy, feature.xy))
    return found


def _near_found(c: FloatArray, found_xy: FloatArray, found: list[PointFeature]) -> bool:
    """Whether ``c`` lies within :data:`CANDIDATE_SPACING_M` of a point found already."""
    gap = float(np.hypot(found_xy[:, 0] - c[0], found_xy[:, 1] - c[1]).min())
    if abs(gap - CANDIDATE_SPACING_M) > _SCREEN_MARGIN_M:
        return gap < CANDIDATE_SPACING_M
    return min(math.dist(c, f.xy) for f in found) < CANDIDATE_SPACING_M


def _counted(echoes: EchoGeometry, idx: IntArray) -> bool:
    """At least :data:`MIN_READINGS` readings from :data:`MIN_POSES` distinct positions."""
    return idx.size >= MIN_READINGS and distinct_poses(echoes.xy[idx]) >= MIN_POSES


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

    var = plane_variances(cov)
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

    A point that passes must keep :data:`MIN_READINGS` readings from :data:`MIN_POSES`
    distinct positions without those of a pass whose ranges a plane facing it explains
    as well as the point, over which the point's range changes by the range tolerance or
    less (the second mask of :func:`~sonarproc.surfaces.reflectors.head_on.head_on_split`):
    they are no evidence for it. It is then tested once more without the head-on echoes
    of a plane among its readings
    (:func:`~sonarproc.surfaces.reflectors.head_on.head_on_echoes`: near its foot a
    plane's range is within the tolerance of the point's, judged on the plane's whole
    pass), which it leaves to the plane. Only a point found with them may leave them:
    readings a plane explains are no evidence for a point, so taking some away must not
    make a point of the rest.

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
    found = _tested_point(echoes, idx, start)
    if found is None:
        return None
    wall, level = head_on_split(echoes, found.readings, found.xy)
    # readings a plane facing their pass explains as well as the point are no evidence
    # for it: the others must be enough to locate a point (on a wall's middle, a long way
    # off, a pass's head-on echoes hold the point's range too, and a few stray echoes of
    # other reflectors at its distance would make a point of them)
    level &= ~wall
    if level.any() and not _counted(echoes, found.readings[~(wall | level)]):
        return None
    if not wall.any():
        return found
    kept = _tested_point(echoes, found.readings[~wall], found.xy)
    return None if kept is None else replace(kept, left=found.readings[wall])


def _tested_point(echoes: EchoGeometry, idx: IntArray, start: npt.ArrayLike) -> PointFeature | None:
    """:func:`point_feature`'s tests on the readings ``idx`` (module notes), else None."""
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
    # the position: the ranges less the time walk of the echoes off the beams' axes
    # (reads as a sideways shift of the point when it is seen from a narrow span)
    shape = walk_shape(xy, echoes.heading[idx], echoes.half_beam[idx], p)
    p = fit_point_with_walk(xy, rng, shape, p)[0]
    return PointFeature(p, idx, poses, rms, prms, sensor_span(xy, p))

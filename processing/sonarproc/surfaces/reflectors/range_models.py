"""The range models a point reflector's readings are weighed against, and their geometry.

A point reflector's readings have ranges equal to their sensors' distance to one point
(:mod:`sonarproc.surfaces.reflectors.rcd`). Two other surfaces explain such readings too,
and a point must explain them significantly better than both
(:func:`point_beats_plane`):

* a plane, answering from the foot of the perpendicular: ``range = d - n . sensor``
  (:func:`plane_rms`, :func:`plane_residuals`);
* a diffusely scattering wall through the point, answering from where each beam's axis
  meets it (:func:`diffuse_residuals`, :func:`diffuse_rms`).

The sensor positions' geometry: distinct poses (:func:`pose_keys`,
:func:`distinct_poses`: positions in one :data:`RANGE_TOL_M` cell give the same range to
any point) and the angle they span round a point (:func:`sensor_span`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import special

from sonarsim.transducer import PISTON_FIRST_NULL, TransducerParams

__all__ = [
    "POINT_FALSE_ALARM",
    "RANGE_STEP_NOISE_M",
    "RANGE_TOL_M",
    "STRAY_SHARE",
    "THRESHOLD_MARGIN",
    "diffuse_residuals",
    "diffuse_rms",
    "distinct_poses",
    "heard_plane",
    "place_on_line",
    "plane_beam_reach",
    "plane_residuals",
    "plane_rms",
    "plane_variances",
    "point_beats_plane",
    "pose_keys",
    "sensor_span",
]

FloatArray = npt.NDArray[np.float64]

#: A reading passes through a point when its range is within this (m) of the distance
#: from its sensor: a robot's 1-inch range steps (+-1.27 cm), a few mm of noise and the
#: time walk of a weak echo (up to about 1.5 cm long, Kleeman & Kuc 1995) add up to it.
#: It is the last echo round's tolerance of the plane refits too
#: (:data:`sonarproc.surfaces.echoes.refine.ROUNDS_M`).
RANGE_TOL_M = 0.03
#: The readings of one reflector pass through a point when all but this share of them
#: do (each within :data:`RANGE_TOL_M`). The tolerance bounds the range steps and the
#: time walk; a 1 cm Gaussian range noise on top of them (the noise the point fits
#: weigh residuals by) puts about 4.5 % of a point's readings beyond it (uniform steps
#: and walk), so demanding every reading rejects nine in ten points heard 50 times. One
#: in ten keeps a point heard 10 to 50 times with a probability of 93 to 98 %
#: (binomial); a plane crossing there misses the point with every reading whose echo
#: lies more than ``sqrt(2 r RANGE_TOL_M)`` (0.3 m at 1.5 m, 0.5 m at 4 m) from it.
STRAY_SHARE = 0.1
#: The error (m) of the ranging board's 1-inch range steps alone (uniform over a step:
#: 2.54 cm / sqrt(12)). Residuals below it are no evidence: a plane that explains the
#: ranges to within it is not rejected, and a model's residual is floored at it in
#: :func:`point_beats_plane`.
RANGE_STEP_NOISE_M = 0.0254 / math.sqrt(12.0)
#: The point-versus-plane test's false-alarm rate: the chance that a plane's readings
#: prefer a point (one-sided, Vuong's statistic is standard normal when both models fit
#: equally well).
POINT_FALSE_ALARM = 0.01
#: Whether a plane could have been heard is judged with a receiver threshold this many
#: times the transducer model's (6 dB more sensitive): the threshold and the beam pattern
#: of a real sensor are known to a few dB, and a plane wrongly called unheard would make
#: its readings a point (:func:`heard_plane`).
THRESHOLD_MARGIN = 0.5

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


def plane_variances(cov: Callable[[int, int], Any]) -> FloatArray:
    """Variance of ``range + n . sensor`` for every direction ``n`` tried (every half degree).

    ``cov(i, j)`` is the covariance of the columns ``i`` and ``j`` of ``(x, y, range)``:
    a number, or a column (G, 1) of them for G sets of readings at once (then the result
    is (G, 720)). The variance is a quadratic form in ``(cos a, sin a)``; the best plane's
    direction has the least.
    """
    return np.asarray(
        cov(2, 2) + 2 * (_PLANE_CA * cov(0, 2) + _PLANE_SA * cov(1, 2))
        + _PLANE_CC * cov(0, 0) + _PLANE_CS2 * cov(0, 1) + _PLANE_SS * cov(1, 1),
        dtype=np.float64,
    )  # fmt: skip


def _centred_variances(xy: FloatArray, rng: FloatArray) -> tuple[FloatArray, FloatArray]:
    """``(x, y, range)`` less its mean, and :func:`plane_variances` of it."""
    m = np.column_stack((xy, rng))
    m = m - m.mean(axis=0)
    c = (m.T @ m) / m.shape[0]
    return m, plane_variances(lambda i, j: c[i, j])


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
    _, var = _centred_variances(xy, rng)
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
    m, var = _centred_variances(xy, rng)
    k = int(np.argmin(var))
    return np.asarray(m[:, 2] + _PLANE_CA[k] * m[:, 0] + _PLANE_SA[k] * m[:, 1], dtype=np.float64)


def heard_plane(
    xy: FloatArray, rng: FloatArray, heading: FloatArray, half_beam: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """The best plane the readings could have heard: its unit normal and range residuals.

    The planes of :func:`plane_rms` (``range = d - n . sensor``, ``n`` every half degree,
    pointing from the sensors to the plane) whose echo every reading hears inside its
    effective beam (``n`` within :func:`plane_beam_reach` of each heading); of those, the
    one with the least RMS residual. None when no plane could be heard by all of them (a
    plane is heard only near normal incidence; a point reflector from anywhere in the
    beam).

    Examples
    --------
    Sensors along y = 0 looking up at a wall y = 2; the same ranges from sensors looking
    20 degrees to either side (no plane both could hear 2 m away):

    >>> xy = np.c_[np.linspace(-1, 1, 9), np.zeros(9)]
    >>> n, res = heard_plane(xy, np.full(9, 2.0), np.full(9, np.pi / 2), np.full(9, 0.22))
    >>> np.round(n, 6).tolist(), float(np.abs(res).max()) < 1e-9
    ([0.0, 1.0], True)
    >>> aside = np.radians(np.where(np.arange(9) % 2, 70.0, 110.0))
    >>> heard_plane(xy, np.full(9, 2.0), aside, np.full(9, 0.22)) is None
    True
    """
    m, var = _centred_variances(xy, rng)
    reach = plane_beam_reach(rng, half_beam)
    off = np.abs((_PLANE_A[None, :] - heading[:, None] + np.pi) % (2 * np.pi) - np.pi)
    heard = np.all(off <= reach[:, None], axis=0)
    if not bool(heard.any()):
        return None
    k = int(np.flatnonzero(heard)[np.argmin(var[heard])])
    n = np.array([_PLANE_CA[k], _PLANE_SA[k]])
    return n, np.asarray(m[:, 2] + n[0] * m[:, 0] + n[1] * m[:, 1], dtype=np.float64)


def plane_beam_reach(range_m: npt.ArrayLike, half_beam: npt.ArrayLike) -> FloatArray:
    """Widest angle (rad) off a beam's axis at which a plane ``range_m`` away is heard.

    A plane is heard only near normal incidence: its echo's amplitude, the Gaussian main
    lobe squared times the spreading loss, ``exp(-(ka sin theta)^2 / 4) (r_ref / r)^2``
    (:func:`sonarsim.transducer.main_lobe_amplitude` with the plane's reflectivity and
    spreading of :class:`sonarsim.transducer.TransducerParams`), must clear the receiver
    threshold, so ``ka sin theta <= 2 sqrt(ln((r_ref / r)^2 / threshold))``; ``ka`` from
    the nominal half-width as the piston's first null (``ka sin(half width) = 3.8317``,
    which puts the beam's edge where the sensor's own specification does), the threshold
    :data:`THRESHOLD_MARGIN` times the model's (a ranging board's threshold, and the
    transducer's beam, are known to a few dB only: a plane is called unheard only when a
    more sensitive sensor would not hear it either). The effective beam is wider than
    nominal close by and narrower far away; 0 where even head on the plane is too weak to
    hear.

    Examples
    --------
    A 15 degree nominal beam, at 1 m, 2.5 m and 4.8 m:

    >>> np.degrees(plane_beam_reach([1.0, 2.5, 4.8], np.radians(15.0))).round(1).tolist()
    [17.5, 13.8, 10.5]
    """
    tp = TransducerParams()
    r = np.maximum(np.asarray(range_m, dtype=np.float64), 1e-3)
    ka = PISTON_FIRST_NULL / np.sin(
        np.clip(np.asarray(half_beam, dtype=np.float64), 1e-3, 0.5 * np.pi)
    )
    head_on = tp.plane_reflectivity * (tp.reference_range / r) ** 2
    ratio = np.maximum(head_on / (THRESHOLD_MARGIN * tp.threshold), 1.0)
    sin_t = np.minimum(2.0 * np.sqrt(np.log(ratio)) / ka, 1.0)
    return np.asarray(np.arcsin(sin_t), dtype=np.float64)


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


def sensor_span(xy: FloatArray, p: FloatArray) -> float:
    """Angle (rad) the sensors span as seen from ``p`` (the complement of the largest gap)."""
    b = np.sort(np.arctan2(xy[:, 1] - p[1], xy[:, 0] - p[0]))
    if b.size < 2:
        return 0.0
    gaps = np.diff(np.r_[b, b[0] + 2 * np.pi])
    return float(2 * np.pi - gaps.max())


def place_on_line(xy: FloatArray, rng: FloatArray, a: FloatArray, u: FloatArray, t: float, *,
                  steps: int, settled: float = 0.0) -> float:  # fmt: skip
    """The place ``a + t u`` on a line whose distances to the sensors ``xy`` best match
    their ranges ``rng`` (least squares; Gauss-Newton from ``t``, one unknown).

    At most ``steps`` steps; it stops early once a step moves the place by less than
    ``settled`` (m), or when the distances do not change along the line.

    Examples
    --------
    Two sensors 1 m off the x axis, ranging the place (2, 0) on it:

    >>> xy = np.array([[0.0, 1.0], [0.5, 1.0]])
    >>> rng = np.hypot(2.0 - xy[:, 0], xy[:, 1])
    >>> round(place_on_line(xy, rng, np.zeros(2), np.array([1.0, 0.0]), 1.5, steps=10), 6)
    2.0
    """
    for _ in range(steps):
        d = a + t * u - xy
        dist = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        jac = (d @ u) / dist
        den = float(jac @ jac)
        if den <= 1e-12:
            break
        step = float(jac @ (dist - rng)) / den
        t -= step
        if abs(step) < settled:
            break
    return t

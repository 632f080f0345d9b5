"""A point reflector's position with the time walk of its weak echoes taken out.

A threshold receiver times an echo where its envelope crosses the threshold: a weak
echo crosses it late, so its range reads long by ``c t_rise thr / (2 a)``, inversely as
its amplitude ``a`` (Kleeman & Kuc 1995), up to :data:`TIME_WALK_M` for an echo just
heard. A point reflector's echo weakens off the beam's axis as the main lobe's
directivity, twice (out and back), and with range as the spreading, so the readings of
one point read long by an amount that grows towards the edge of each beam. Seen from a
narrow span of bearings (a corner seen through a doorway, or passed on one straight
track far away), the point's position across the bearing is set by how the range
changes along the track: the walk, growing steadily as the point leaves the beam,
reads as a shift of the point sideways, of ``walk / span``: 1.5 cm over 0.15 rad is
10 cm.

:func:`walk_shape` is each reading's walk relative to the weakest of the point's echoes,
from the beam model the simulator hears with
(:func:`sonarsim.transducer.main_lobe_amplitude`): the Gaussian main lobe
``D = exp(-(ka sin theta)^2 / 8)`` (Barshan & Kuc 1990), ``ka`` from the nominal
half-width taken as the piston's first null (``ka sin(half width) = 3.8317``), and
spreading as ``1 / r^2``.
:func:`fit_point_with_walk` fits the point and the walk of its weakest echo together,
that walk bounded by :data:`TIME_WALK_M` (an echo is heard only above the threshold,
where the walk is largest); :func:`place_on_line_with_walk` does the same for a point
known to lie on a line (a corner on a fitted wall's line: one unknown of place).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from sonarsim.transducer import PISTON_FIRST_NULL, main_lobe_amplitude

__all__ = [
    "PISTON_FIRST_NULL",
    "TIME_WALK_M",
    "fit_point_with_walk",
    "place_on_line_with_walk",
    "walk_shape",
]

FloatArray = npt.NDArray[np.float64]

#: The largest range bias (m) that varies across a beam: a weak echo off the beam's axis
#: crosses the receiver threshold late by up to about 1.5 cm (Kleeman & Kuc 1995). A
#: circle's radius ``R`` shows in the ranges only as the sag ``R (1 - cos(span / 2))``
#: across the sensors' span; a sag under this bias is no evidence of a radius.
TIME_WALK_M = 0.015
#: Rounds of :func:`place_on_line_with_walk`, each with the walk's shape at the place the
#: round before found: the shape changes by a few per cent over the centimetres a round
#: moves the place, so the third round moves it by well under a millimetre.
WALK_ROUNDS = 3
# J1's first zero to the 4 decimals a nominal half-width given to 0.1 degree warrants
_FIRST_NULL = round(PISTON_FIRST_NULL, 4)


def walk_shape(
    xy: FloatArray, heading: FloatArray, half_beam: FloatArray, p: FloatArray
) -> FloatArray:
    """Each reading's time walk relative to the largest among them (0..1].

    The walk is inversely as the echo's amplitude, ``D(theta)^2 / r^2`` for a point at
    distance ``r`` and angle ``theta`` off the beam's axis (module notes).

    Examples
    --------
    On the axis at 1 m and at 2 m, then 6 degrees off it at 2 m (12.5 degree half-width):

    >>> xy = np.array([[-1.0, 0.0], [-2.0, 0.0], [-2.0, 0.0]])
    >>> heading = np.array([0.0, 0.0, np.radians(6.0)])
    >>> walk_shape(xy, heading, np.full(3, np.radians(12.5)), np.zeros(2)).round(3).tolist()
    [0.106, 0.425, 1.0]
    """
    rel = p - xy
    r = np.hypot(rel[:, 0], rel[:, 1])
    off = np.abs(np.angle(np.exp(1j * (np.arctan2(rel[:, 1], rel[:, 0]) - heading))))
    # ka from the nominal half-width taken as the piston's first null
    null = np.clip(half_beam, 1e-3, 0.5 * np.pi)
    ka = _FIRST_NULL / np.sin(null)
    # past the first null the Gaussian keeps falling while no echo is heard there: the
    # weakest echo heard is one at the null, so the angle is capped at it
    theta = np.minimum(off, null)
    amp = main_lobe_amplitude(theta, theta, np.maximum(r, 1e-3), ka)
    # the walk is inversely as the amplitude: relative to the weakest echo's
    return np.asarray(amp.min() / amp, dtype=np.float64)


def fit_point_with_walk(
    xy: FloatArray, rng: FloatArray, shape: FloatArray, p0: FloatArray
) -> tuple[FloatArray, float]:
    """Point ``p`` and walk ``w``: ``range = |p - sensor| + w shape``, ``0 <= w <= TIME_WALK_M``.

    Returns the point and ``w`` (m). Bounded least squares (trust region reflective).

    Examples
    --------
    Ranges to the origin that read long by 1 cm times the shape: the origin comes back.

    >>> xy = np.array([[-3.0, -0.5], [-3.0, -0.2], [-3.0, 0.1], [-3.0, 0.4], [-3.0, 0.7]])
    >>> shape = np.array([0.2, 0.3, 0.5, 0.7, 1.0])
    >>> rng = np.hypot(*xy.T) + 0.01 * shape
    >>> p, w = fit_point_with_walk(xy, rng, shape, np.array([0.05, 0.05]))
    >>> np.abs(p).max() < 1e-4, round(w, 4)
    (np.True_, 0.01)
    """

    def res(q: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(xy[:, 0] - q[0], xy[:, 1] - q[1]) + q[2] * shape - rng)

    def jac(q: FloatArray) -> FloatArray:
        d = q[:2] - xy
        u = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)[:, None]
        return np.column_stack((u, shape))

    x0 = np.r_[p0, 0.5 * TIME_WALK_M]
    lo = np.array([-np.inf, -np.inf, 0.0])
    hi = np.array([np.inf, np.inf, TIME_WALK_M])
    scale = np.array([0.1, 0.1, 0.01])
    sol = least_squares(res, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale=scale)
    return np.asarray(sol.x[:2], dtype=np.float64), float(sol.x[2])


def place_on_line_with_walk(
    xy: FloatArray,
    rng: FloatArray,
    heading: FloatArray,
    half_beam: FloatArray,
    a: FloatArray,
    u: FloatArray,
    t: float,
) -> tuple[float, FloatArray]:
    """The place ``a + t u`` on a line and the walk of its weakest echo, fitted together.

    ``range = |a + t u - sensor| + w shape`` with ``0 <= w <= TIME_WALK_M``, the walk's
    :func:`walk_shape` taken at the place of the round before (:data:`WALK_ROUNDS`
    rounds from the place given: the shape changes little over the few centimetres a
    round moves the place). Returns ``t`` (m along the line from ``a``)
    and the range residuals (m) there.

    Examples
    --------
    Sensors on a row 4 m from the x axis ranging the place (2, 0) on it with a walk of
    1 cm times the shape: the place comes back.

    >>> xy = np.c_[np.linspace(4.0, 4.4, 9), np.full(9, 4.0)]
    >>> heading = np.full(9, np.radians(-120.0))
    >>> half = np.full(9, np.radians(12.5))
    >>> shape = walk_shape(xy, heading, half, np.array([2.0, 0.0]))
    >>> rng = np.hypot(2.0 - xy[:, 0], xy[:, 1]) + 0.01 * shape
    >>> t, res = place_on_line_with_walk(xy, rng, heading, half, np.zeros(2),
    ...                                  np.array([1.0, 0.0]), 1.9)
    >>> round(t, 3), float(np.abs(res).max()) < 1e-4
    (2.0, True)
    """
    q = np.array([t, 0.5 * TIME_WALK_M])
    bounds = (np.array([-np.inf, 0.0]), np.array([np.inf, TIME_WALK_M]))
    fun = np.zeros(0)
    for _ in range(WALK_ROUNDS):
        shape = walk_shape(xy, heading, half_beam, a + q[0] * u)

        def res(c: FloatArray, shape: FloatArray = shape) -> FloatArray:
            d = a + c[0] * u - xy
            return np.asarray(np.hypot(d[:, 0], d[:, 1]) + c[1] * shape - rng)

        def jac(c: FloatArray, shape: FloatArray = shape) -> FloatArray:
            d = a + c[0] * u - xy
            dist = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
            return np.column_stack(((d @ u) / dist, shape))

        sol = least_squares(res, q, jac=jac, bounds=bounds, method="trf",
                            x_scale=np.array([0.1, 0.01]))  # fmt: skip
        q, fun = np.asarray(sol.x, dtype=np.float64), sol.fun
    return float(q[0]), np.asarray(fun, dtype=np.float64)

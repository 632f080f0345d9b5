"""The echo refit's rounds: each reading's echo point on a profile, and the curve through them.

A reading's range says how far the surface is at the one point where it reflected: its
specular point, where the surface's normal bisects the directions to the transmitter
and the receiver. Every map method places the surface from the arcs' overlaps instead,
and each has its own bias (the crest of the counts lies on the sensors' side of the
surface, a median across the arcs between the arcs' ends). Given a profile close to
the surface, :func:`echo_points` finds each reading's specular point on it with the
first-echo model of :mod:`sonarproc.methods.echo_model` and moves it along the normal
until its path ``|TP| + |PR|`` equals the measured one (to first order: the path grows
by ``n . (u_T + u_R)`` per metre along the normal ``n``, ``u_T`` and ``u_R`` the unit
vectors from transmitter and receiver). The echo points lie on the surface whatever the
profile's bias; only where the profile is wrong in slope do they slide along it.

:func:`refit_profile` fits a curve (:class:`RefitSetting`: a smoothing spline or a
least-squares polynomial) to the echo points' column means, each at its points' mean x,
twice, with range tolerances :data:`ROUNDS_M`. Between echo points the curve
interpolates: the map's column means are used only beyond the first and the last echo
point, to carry the profile to the map's span. (Sensors see a surface only where its
normal points into their beams, so a wave seen from below echoes from its troughs and
crests but not its flanks; the map does hold cells on the flanks, but they lie where
the arcs overlap, centimetres off the wall, and filling the gaps with them made the
refit worse on every wave tried.) A later round searches only the readings that echoed
in the round before: its tolerance is narrower and its profile moved by less than that.

On a noisy log the rounds' tolerances follow the readings' range noise
(:func:`range_noise`, :func:`tolerances`). Each round drops the small clusters of echo
points cut off at the ends (:func:`main_body`): readings that find an echo point on the
map-carried end of the profile agree with its bias.

Which curve is taken, and whether it replaces the chosen candidate's, is
:mod:`sonarproc.auto.echo_refit`'s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from sonarproc.auto.candidates import ORDERS, SMOOTHING_LENGTHS, spline_lambda
from sonarproc.auto.holdout import predicted_path
from sonarproc.auto.score import HULL_CELLS
from sonarproc.fit import Fit, FitFailure, PolyFit, SplineFit, fit_polynomial, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods.echo_model import MIN_PATH_GAIN, curve_echo_points
from sonarproc.metrics import Bins, bin_stats
from sonarproc.pipeline.selection import Beams

__all__ = [
    "END_GAP_M", "END_SHARE", "HULL_NOISE_WIDTH", "MIN_PATH_GAIN", "NOISE_MAX",
    "NOISE_READINGS", "NOISE_WIDTHS", "REFIT_SETTINGS", "ROUNDS_M", "Profile",
    "RefitSetting", "Span", "agreement_tolerance", "believable_noise", "echo_points",
    "fit_points", "fitted_points", "hull_tolerance", "main_body", "range_noise",
    "refit_profile", "sample_curve", "tolerances",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: Range tolerances (m) of the two rounds: a reading further than this from the path the
#: profile predicts echoed from something else (another surface, a spurious echo).
ROUNDS_M = (0.08, 0.03)
#: On a noisy log each round's tolerance is at least this many times the range noise
#: (:func:`range_noise`): a tolerance of the order of the noise keeps only the readings
#: whose noise happens to be small, and those on one side of a profile that is off.
NOISE_WIDTHS = (5.0, 2.0)
#: A range noise estimate above this (m) says that the profile misses most readings (a
#: room's other walls), or is far off, not that they are noisy: the tolerances stay
#: :data:`ROUNDS_M` (:mod:`sonarproc.auto.echo_refit` then estimates the noise again about
#: the best refit). (A Polaroid ranger's noise is about a centimetre; the paper's noisiest
#: log, Fig. 13, has 5 cm, and the estimate includes the profile's own error.)
NOISE_MAX = 0.10
#: On a noisy log a refit may leave its points' local hull by this many times the range
#: noise (at least :data:`~sonarproc.auto.score.HULL_CELLS` cells): echo points scatter
#: by the noise about the surface, so a smooth refit passes outside a few of them by
#: about that much (the second round keeps points within 2 sigma).
HULL_NOISE_WIDTH = 2.0
#: Readings the noise estimate looks at, at most (its median is then good to a few %).
NOISE_READINGS = 1500

#: A cluster of echo points at an end of the profile, cut from the rest by a gap wider than
#: this (m) and holding less than :data:`END_SHARE` of them, is dropped (see
#: :func:`main_body`).
END_GAP_M = 0.10
END_SHARE = 0.02

Span = tuple[float, float]
Profile = PolyFit | SplineFit


@dataclass(frozen=True, order=True)
class RefitSetting:
    """A refit's curve: a smoothing spline of length ``value`` (m), or a least-squares
    polynomial of order ``value``.

    Examples
    --------
    >>> RefitSetting("spline", 0.4).short, RefitSetting("poly", 6).short
    ('spline L=0.4 m', 'poly m=6')
    >>> sorted([RefitSetting("spline", 0.1), RefitSetting("poly", 9), RefitSetting("poly", 2)])[0]
    RefitSetting(family='poly', value=2)
    """

    family: Literal["poly", "spline"]
    value: float

    @property
    def short(self) -> str:
        """The setting in a few words, as the record names it."""
        if self.family == "poly":
            return f"poly m={int(self.value)}"
        return f"spline L={self.value:g} m"


#: The refits tried: splines of the candidates' smoothing lengths, then polynomials of the
#: candidates' orders.
REFIT_SETTINGS = tuple(RefitSetting("spline", k) for k in SMOOTHING_LENGTHS) + tuple(
    RefitSetting("poly", m) for m in ORDERS
)


def sample_curve(fit: Profile, span: Span, step: float) -> FloatArray:
    xs = np.arange(span[0], span[1] + 0.5 * step, step)
    return np.column_stack((xs, np.asarray(fit(xs), dtype=np.float64)))


def range_noise(fit: Profile, beams: Beams, step: float) -> float:
    """A robust estimate (m) of the readings' range noise about the profile ``fit``.

    1.4826 times the median absolute range residual (half the path) of the readings whose
    beams the profile crosses: the standard deviation for Gaussian noise, whatever a
    minority of spurious echoes and echoes off other surfaces add. It includes the
    profile's own error, so it is an upper bound on a clean log. A larger log is
    estimated on :data:`NOISE_READINGS` of its readings (seeded).

    Examples
    --------
    >>> from sonarproc.methods.testing import beams_facing
    >>> from sonarproc.fit import PolyFit
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> beams, _ = beams_facing([[x, 0.0] for x in np.linspace(-0.5, 0.5, 11)],
    ...                         [np.pi / 2] * 11, wall)
    >>> beams.path[:] += 2 * np.array([0.02, -0.02] * 5 + [0.0])
    >>> flat = PolyFit(0, np.array([1.0]), (-1.0, 1.0))
    >>> round(range_noise(flat, beams, 0.01) / 1.4826, 4)
    0.02
    """
    rows = np.arange(len(beams.path))
    if rows.size > NOISE_READINGS:
        rows = np.sort(np.random.default_rng(0).choice(rows, NOISE_READINGS, replace=False))
    residual = np.abs(beams.path[rows] - predicted_path(fit, beams, rows, step)) / 2
    residual = residual[np.isfinite(residual)]
    return float(1.4826 * np.median(residual)) if residual.size else 0.0


def tolerances(noise: float) -> tuple[float, ...]:
    """The rounds' range tolerances (m) for a log with range noise ``noise`` (m).

    At most :data:`NOISE_MAX` of noise widens them; beyond it they are :data:`ROUNDS_M`.

    Examples
    --------
    >>> tolerances(0.005), tolerances(0.04), tolerances(2.0)
    ((0.08, 0.03), (0.2, 0.08), (0.08, 0.03))
    """
    noise = believable_noise(noise)
    return tuple(max(t, k * noise) for t, k in zip(ROUNDS_M, NOISE_WIDTHS, strict=True))


def believable_noise(noise: float) -> float:
    """The noise estimate, or 0 above :data:`NOISE_MAX` (a profile missing the readings)."""
    return noise if noise <= NOISE_MAX else 0.0


def agreement_tolerance(noise: float, cell: float) -> float:
    """How far (m) two refits may differ and still be the same curve to the readings.

    The map's cell, or the range noise if larger (and believable, :data:`NOISE_MAX`).

    Examples
    --------
    >>> agreement_tolerance(0.004, 0.01), agreement_tolerance(0.03, 0.01)
    (0.01, 0.03)
    """
    return max(cell, believable_noise(noise))


def hull_tolerance(noise: float, cell: float) -> float:
    """How far (m) a refit may leave its points' local hull, for range noise ``noise``.

    Examples
    --------
    >>> hull_tolerance(0.005, 0.01), hull_tolerance(0.04, 0.01), hull_tolerance(2.0, 0.01)
    (0.03, 0.08, 0.03)
    """
    return max(HULL_CELLS * cell, HULL_NOISE_WIDTH * believable_noise(noise))


def echo_points(
    fit: Profile,
    beams: Beams,
    span: Span,
    *,
    step: float,
    tol: float,
    among: IntArray | None = None,
) -> tuple[IntArray, FloatArray]:
    """Each reading's echo point on the surface near the profile ``fit`` (module notes).

    Parameters
    ----------
    fit : PolyFit or SplineFit
        A profile y(x) near the surface.
    beams : Beams
        The readings.
    span : (float, float)
        The x range of the profile to search (its ends are never specular).
    step : float
        Spacing (m) of the profile's samples.
    tol : float
        Largest range residual (m, half the path) of a reading kept, and largest distance
        of its echo point from the profile.
    among : ndarray of int, optional
        Search only these readings (indices into ``beams``); all of them by default.

    Returns
    -------
    rows : ndarray of int, (E,)
        The readings (indices into ``beams``) that echo from the profile.
    points : ndarray, (E, 2)
        Their echo points.

    Examples
    --------
    A wall along y = 1 and a sensor looking up at it from (0.1, 0), range 1 m; the
    profile is 2 cm short of the wall and tilted, the echo point is on the wall.

    >>> from sonarproc.methods.testing import beams_facing
    >>> from sonarproc.fit import PolyFit
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> beams, _ = beams_facing([[0.1, 0.0]], [np.pi / 2], wall)
    >>> near = PolyFit(1, np.array([0.98, 0.01]), (-1.0, 1.0))
    >>> rows, pts = echo_points(near, beams, (-1.0, 1.0), step=0.01, tol=0.05)
    >>> rows.tolist(), np.round(pts[:, 1], 3).tolist()
    ([0], [1.0])
    """
    p = beams.poses
    ids = np.arange(len(beams.path)) if among is None else among
    hit, points = curve_echo_points(
        p.tx_xy[ids], p.tx_heading[ids], p.tx_half_beamwidth[ids], p.rx_xy[ids],
        p.rx_heading[ids], p.rx_half_beamwidth[ids], beams.path[ids],
        sample_curve(fit, span, step), tol=tol, rank=beams.readings["echo"][ids],
    )  # fmt: skip
    return ids[hit], points


def main_body(x: FloatArray) -> npt.NDArray[np.bool_]:
    """Which echo points (by their x) are not in a small cluster cut off at an end.

    Beyond the outermost echo points the profile is carried by the map, with its bias;
    a few readings (a surface's end, a spurious echo) then find echo points on that
    biased stretch, consistent with it, a gap away from the rest. Clusters at either end
    beyond a gap wider than :data:`END_GAP_M` holding less than :data:`END_SHARE` of the
    points together are dropped, from the outside in.

    Examples
    --------
    >>> x = np.r_[0.30, 0.31, np.linspace(0.5, 5.5, 200), 5.9]
    >>> keep = main_body(x)
    >>> int(keep.sum()), bool(keep[:2].any()), bool(keep[-1])
    (200, False, False)
    """
    keep = np.ones(x.size, dtype=bool)
    if x.size < 2:
        return keep
    order = np.argsort(x, kind="stable")
    xs = x[order]
    cuts = np.flatnonzero(np.diff(xs) > END_GAP_M) + 1
    limit = END_SHARE * x.size
    # the outermost cut on each side that leaves few enough points beyond it
    left = cuts[cuts <= limit]
    lo = int(left[-1]) if left.size else 0
    right = cuts[(x.size - cuts <= limit) & (cuts > lo)]
    hi = int(right[0]) if right.size else x.size
    keep[order[:lo]] = False
    keep[order[hi:]] = False
    return keep


def _columns(points: FloatArray, map_bins: Bins, grid: Grid) -> tuple[Bins, BoolArray, FloatArray]:
    """The echo points per column, the map's columns beyond the echo points' ends, and
    each column's abscissa (its echo points' mean x, else its centre)."""
    ix = np.floor((points[:, 0] - grid.x0) / grid.cell).astype(np.intp)
    inside = (ix >= 0) & (ix < grid.nx)
    order = np.argsort(ix[inside], kind="stable")
    echo = bin_stats(ix[inside][order], points[inside][order, 1], grid.centres_x(), presorted=True)
    beyond = np.ones(grid.nx, dtype=bool)
    echoed = np.flatnonzero(echo.count > 0)
    if echoed.size:
        beyond[echoed[0] : echoed[-1] + 1] = False
    # an echo column's mean height belongs at its points' mean x, not at the column's
    # centre: on a slope the difference is the slope times the offset
    sum_x = np.bincount(ix[inside], points[inside, 0], minlength=grid.nx)
    xs = np.where(echo.count > 0, sum_x / np.maximum(echo.count, 1), echo.centres)
    return echo, (map_bins.count > 0) & beyond, xs


def fitted_points(points: FloatArray, map_bins: Bins, grid: Grid) -> FloatArray:
    """The points a refit fits: the echo points, and the map's column means beyond them."""
    _, from_map, _ = _columns(points, map_bins, grid)
    return np.concatenate(
        (points, np.column_stack((map_bins.centres[from_map], map_bins.mean[from_map])))
    )


def fit_points(points: FloatArray, map_bins: Bins, grid: Grid, setting: RefitSetting) -> Fit:
    """The ``setting``'s curve through the echo points' column means (module notes)."""
    echo, from_map, xs = _columns(points, map_bins, grid)
    mean = np.where(from_map, np.nan_to_num(map_bins.mean), np.nan_to_num(echo.mean))
    count = np.where(from_map, map_bins.count, echo.count).astype(np.float64)
    if not np.any(count > 0):
        return FitFailure(setting.family, "no echo point and no map point to fit")
    if setting.family == "poly":
        return fit_polynomial(xs, mean, count, order=int(setting.value))
    lam = spline_lambda(setting.value, float(count[count > 0].mean()), grid.cell)
    return fit_spline(xs, mean, count, lam=lam)


def refit_profile(
    fit: Profile,
    map_bins: Bins,
    beams: Beams,
    grid: Grid,
    span: Span,
    setting: RefitSetting,
    *,
    first: tuple[IntArray, FloatArray] | None = None,
    tols: tuple[float, ...] = ROUNDS_M,
) -> tuple[Fit, IntArray, FloatArray]:
    """The profile refitted through the readings' echo points, one round per tolerance.

    ``setting``: the refit's curve. ``first``: the first round's echo points on ``fit``,
    if already found (they do not depend on ``setting``). ``tols``: the rounds' range
    tolerances (m; :func:`tolerances`).
    Returns the new fit and the last round's echoing readings and echo points.
    """
    rows = np.zeros(0, np.intp)
    points = np.zeros((0, 2))
    for r, tol in enumerate(tols):
        if r == 0 and first is not None:
            rows, points = first
        else:
            # a later round's tolerance is narrower and its profile moved by less than the
            # earlier one's: only the readings that echoed then can echo now
            among = None if r == 0 else rows
            rows, points = echo_points(fit, beams, span, step=grid.cell, tol=tol, among=among)
        body = main_body(points[:, 0])
        rows, points = rows[body], points[body]
        new = fit_points(points, map_bins, grid, setting)
        if not isinstance(new, (PolyFit, SplineFit)):
            return new, rows, points
        fit = new
    return fit, rows, points

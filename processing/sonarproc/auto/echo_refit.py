"""``--auto``'s last step: the chosen profile refitted through the readings' echo points.

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

:func:`refit_profile` fits a smoothing spline to the echo points' column means, each at
its points' mean x, twice, with range tolerances :data:`ROUNDS_M`. Between echo points
the spline interpolates: the map's column means are used only beyond the first and the
last echo point, to carry the profile to the map's span. (Sensors see a surface only
where its normal points into their beams, so a wave seen from below echoes from its
troughs and crests but not its flanks; the map does hold cells on the flanks, but they
lie where the arcs overlap, centimetres off the wall, and filling the gaps with them
made the refit worse on every wave tried.) A later round searches only the readings
that echoed in the round before: its tolerance is narrower and its profile moved by
less than that. Its smoothing length is chosen by the
criterion of ``--auto`` itself (:func:`choose_refit`): each length's fit to the echo
points of the training folds predicts the held-out readings, and the lowest trimmed
mean range residual wins; the lengths within :data:`TIE_SE` paired standard errors of
it cannot be told apart by the readings, and their refits are averaged. The refit
replaces the chosen fit unless its residual is above the chosen candidate's own by more
than :data:`TIE_SE` paired standard errors.

Least-squares polynomials of the candidates' orders are refitted and scored the same way
(:class:`RefitSetting`). When a polynomial is tied with the best refit, it is preferred
over the splines if it agrees with the most flexible tied refit within
:func:`agreement_tolerance` (the map's cell, or the range noise) on every column where
readings echo (:func:`simplest_agreeing`). Where the readings see the surface the two
are then the same curve; across a stretch that echoes nothing (a flank facing away
from the sensors) the spline draws the straightest curve and the polynomial carries the
curvature on either side through it. A polynomial that misses a local feature the
readings do see (a dent, a hump) disagrees there and is not taken. A polynomial that
predicts better than every spline is kept even when no tied spline agrees with it
(:func:`references`): the splines' average is for a spline that predicts best.

On a noisy log the rounds' tolerances follow the readings' range noise
(:func:`range_noise`, :func:`tolerances`), estimated about the starting profile. An
estimate above :data:`NOISE_MAX` says that the profile misses most readings (a room's
other walls), or that the start is far off on a very noisy log; the noise is then
estimated again about the best refit, and if that is believable the refits are made
again with its tolerances.

Each round drops the small clusters of echo points cut off at the ends
(:func:`main_body`): readings that find an echo point on the map-carried end of the
profile agree with its bias. The refitted profile is then reported only between its
outermost echo points (:attr:`RefitChoice.echo_span`; :mod:`sonarproc.auto.select`):
beyond them the map's bias carries it, centimetres to a decimetre off at a wave's ends.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from sonarproc.auto.candidates import ORDERS, SMOOTHING_LENGTHS, spline_lambda
from sonarproc.auto.holdout import (
    Split,
    curve_path,
    heldout_splits,
    hull_excess,
    predicted_path,
    range_loss,
    subset_beams,
)
from sonarproc.auto.score import HULL_CELLS, paired_se, robust_residual
from sonarproc.fit import Fit, FitFailure, PolyFit, SplineFit, fit_polynomial, fit_spline
from sonarproc.grid import Grid
from sonarproc.methods.echo_model import first_echo
from sonarproc.metrics import Bins, bin_stats
from sonarproc.pipeline.selection import Beams

__all__ = [
    "HULL_NOISE_WIDTH", "MIN_ECHO_POINTS", "NOISE_MAX", "NOISE_READINGS", "NOISE_WIDTHS",
    "REFIT_SETTINGS", "ROUNDS_M", "TIE_SE", "RefitChoice", "RefitSetting",
    "agreement_tolerance", "choose_refit", "echo_points", "hull_tolerance", "main_body",
    "range_noise", "references", "refit_profile", "simplest_agreeing", "tolerances",
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
#: room's other walls), not that they are noisy: the tolerances stay :data:`ROUNDS_M`.
#: (A Polaroid ranger's noise is about a centimetre; the paper's noisiest log, Fig. 13,
#: has 5 cm, and the estimate includes the profile's own error.)
NOISE_MAX = 0.10
#: On a noisy log a refit may leave its points' local hull by this many times the range
#: noise (at least :data:`~sonarproc.auto.score.HULL_CELLS` cells): echo points scatter
#: by the noise about the surface, so a smooth refit passes outside a few of them by
#: about that much (the second round keeps points within 2 sigma).
HULL_NOISE_WIDTH = 2.0
#: Readings the noise estimate looks at, at most (its median is then good to a few %).
NOISE_READINGS = 1500
#: A refit needs at least this many echo points in its first round: fewer say that the
#: profile is not the surface the readings see (a room's log, one wall's y(x)).
MIN_ECHO_POINTS = 10
#: The echo points are searched for on at most this many (reading, profile sample) pairs:
#: a longer log's readings are subsampled (seeded) so that the refit stays a few runs.
MAX_PAIRS = 5_000_000
#: A reading whose path changes by less than this per metre along the normal (grazing
#: geometry, far off the bisector) says too little about the surface's distance.
MIN_PATH_GAIN = 0.5

#: A cluster of echo points at an end of the profile, cut from the rest by a gap wider than
#: this (m) and holding less than :data:`END_SHARE` of them, is dropped (see
#: :func:`main_body`).
END_GAP_M = 0.10
END_SHARE = 0.02
#: Smoothing lengths whose held-out residuals are within this many paired standard errors
#: of the lowest are tied (their refits are averaged); a refit within this many of the
#: chosen candidate's residual, or below it, is applied.
TIE_SE = 2.0

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


def _curve(fit: Profile, span: Span, step: float) -> FloatArray:
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
    noise = _believable(noise)
    return tuple(max(t, k * noise) for t, k in zip(ROUNDS_M, NOISE_WIDTHS, strict=True))


def _believable(noise: float) -> float:
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
    return max(cell, _believable(noise))


def hull_tolerance(noise: float, cell: float) -> float:
    """How far (m) a refit may leave its points' local hull, for range noise ``noise``.

    Examples
    --------
    >>> hull_tolerance(0.005, 0.01), hull_tolerance(0.04, 0.01), hull_tolerance(2.0, 0.01)
    (0.03, 0.08, 0.03)
    """
    return max(HULL_CELLS * cell, HULL_NOISE_WIDTH * _believable(noise))


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
    curve = _curve(fit, span, step)
    p = beams.poses
    ids = np.arange(len(beams.path)) if among is None else among
    measured = beams.path[ids]
    path, at = first_echo(
        p.tx_xy[ids], p.tx_heading[ids], p.tx_half_beamwidth[ids], p.rx_xy[ids],
        p.rx_heading[ids], p.rx_half_beamwidth[ids], curve, beams.readings["echo"][ids],
    )  # fmt: skip
    ok = (at > 0) & (at < curve.shape[0] - 1) & (np.abs(measured - path) <= 2.0 * tol)
    hit = np.flatnonzero(ok)
    k = at[hit]
    foot = curve[k]
    tangent = curve[k + 1] - curve[k - 1]
    normal = np.column_stack((-tangent[:, 1], tangent[:, 0]))
    normal /= np.hypot(*normal.T)[:, None]
    to_tx = foot - p.tx_xy[ids[hit]]
    to_rx = foot - p.rx_xy[ids[hit]]
    gain = np.einsum(
        "ij,ij->i",
        normal,
        to_tx / np.hypot(*to_tx.T)[:, None] + to_rx / np.hypot(*to_rx.T)[:, None],
    )
    shift = (measured[hit] - path[hit]) / np.where(gain == 0.0, np.nan, gain)
    # a small gain magnifies the path's error: the echo point must lie within the
    # tolerance of the profile too, not only its path
    good = (np.abs(gain) >= MIN_PATH_GAIN) & (np.abs(shift) <= tol)
    hit, foot, normal, shift = hit[good], foot[good], normal[good], shift[good]
    return ids[hit], foot + shift[:, None] * normal


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


def _fitted_points(points: FloatArray, map_bins: Bins, grid: Grid) -> FloatArray:
    """The points a refit fits: the echo points, and the map's column means beyond them."""
    _, from_map, _ = _columns(points, map_bins, grid)
    return np.concatenate(
        (points, np.column_stack((map_bins.centres[from_map], map_bins.mean[from_map])))
    )


def _fit_points(points: FloatArray, map_bins: Bins, grid: Grid, setting: RefitSetting) -> Fit:
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
        new = _fit_points(points, map_bins, grid, setting)
        if not isinstance(new, (PolyFit, SplineFit)):
            return new, rows, points
        fit = new
    return fit, rows, points


@dataclass
class RefitChoice:
    """The echo refit's settings, their held-out residuals, and the verdict."""

    criterion: str
    residuals: dict[RefitSetting, float] = field(default_factory=dict)
    excluded: dict[RefitSetting, str] = field(default_factory=dict)
    #: the setting with the lowest held-out residual
    best: RefitSetting | None = None
    applied: bool = False
    reason: str = ""
    fit: Fit | None = None
    #: x (m) of the outermost echo points of the chosen refit
    echo_span: tuple[float, float] | None = None
    #: every setting's refit on all the readings, its echo span, the x (m) of its echo
    #: columns and its held-out losses (for studies)
    fits: dict[RefitSetting, Profile] = field(default_factory=dict)
    spans: dict[RefitSetting, tuple[float, float]] = field(default_factory=dict)
    echo_x: dict[RefitSetting, FloatArray] = field(default_factory=dict)
    losses: dict[RefitSetting, FloatArray] = field(default_factory=dict)
    #: the settings tied with the best
    tied: tuple[RefitSetting, ...] = ()
    #: the tied splines averaged into ``fit`` (one setting: that refit alone)
    averaged: tuple[RefitSetting, ...] = ()
    #: why a polynomial was taken over the tied splines (:func:`simplest_agreeing`)
    simpler: str = ""
    #: held-out residual (m) of ``fit``: the setting's, or the average's
    residual: float | None = None
    #: the readings' range noise about the starting profile (m; :func:`range_noise`) and
    #: the rounds' range tolerances (m) it set
    noise: float | None = None
    tolerances: tuple[float, ...] = ()
    #: the noise estimate about the starting profile, when it was above
    #: :data:`NOISE_MAX` and ``noise`` was estimated again about the best refit
    noise_start: float | None = None
    #: held-out losses of ``fit``, in the order of the folds (for comparing refits)
    heldout: FloatArray | None = None

    @property
    def setting(self) -> RefitSetting | None:
        """The refit's setting (of the averaged splines, the one with the lowest held-out
        residual); None if no refit was scored."""
        if not self.averaged:
            return None
        return min(self.averaged, key=lambda k: self.residuals[k])

    @property
    def fit_short(self) -> str | None:
        """The refit in a few words: ``spline L=0.2 m``, ``poly m=6``, or the splines
        averaged."""
        if len(self.averaged) > 1:
            return "mean of splines L=" + ", ".join(f"{k.value:g}" for k in self.averaged) + " m"
        return None if self.setting is None else self.setting.short

    def to_json(self) -> dict[str, Any]:
        """JSON-ready mapping for the ``--auto`` record's ``echo_refit``.

        ``smoothing_length_m`` and ``averaged_lengths_m`` name the spline refit (None and
        empty when a polynomial is chosen); ``polynomial_order`` names a polynomial's.
        """
        setting = self.setting
        return {
            "criterion": self.criterion,
            "residuals_m": {k.short: _finite(v) for k, v in self.residuals.items()},
            "excluded": {k.short: v for k, v in self.excluded.items()},
            "setting": None if setting is None else setting.short,
            "smoothing_length_m": _value_of(setting, "spline"),
            "polynomial_order": _value_of(setting, "poly"),
            "tied": [k.short for k in self.tied],
            "averaged_lengths_m": [k.value for k in self.averaged if k.family == "spline"],
            "simpler": self.simpler,
            "residual_m": None if self.residual is None else _finite(self.residual),
            "fit_short": self.fit_short,
            "applied": self.applied,
            "reason": self.reason,
            "echo_span_m": None if self.echo_span is None else list(self.echo_span),
            "range_noise_m": None if self.noise is None else _finite(self.noise),
            "range_noise_start_m": None if self.noise_start is None else _finite(self.noise_start),
            "tolerances_m": list(self.tolerances),
        }


def _value_of(setting: RefitSetting | None, family: str) -> float | int | None:
    if setting is None or setting.family != family:
        return None
    return int(setting.value) if family == "poly" else setting.value


def _finite(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def references(tied: tuple[RefitSetting, ...], best: RefitSetting) -> list[RefitSetting]:
    """The refits a tied polynomial is compared with, in turn (:func:`simplest_agreeing`).

    First the tied spline of the shortest smoothing length (the one that follows the echo
    points most closely); then, if the best refit is a polynomial, that polynomial: a
    polynomial that predicts better than every spline is kept even if no spline agrees
    with it (the splines' average is for when a spline is best).

    Examples
    --------
    >>> s1, s4 = RefitSetting("spline", 0.1), RefitSetting("spline", 0.4)
    >>> p6 = RefitSetting("poly", 6)
    >>> [k.short for k in references((p6, s1, s4), s4)]
    ['spline L=0.1 m']
    >>> [k.short for k in references((p6, s4), p6)]
    ['spline L=0.4 m', 'poly m=6']
    """
    splines = [k for k in tied if k.family == "spline"]
    out = [min(splines)] if splines else []
    return out + ([best] if best.family == "poly" else [])


def simplest_agreeing(
    tied: tuple[RefitSetting, ...],
    reference: RefitSetting,
    fits: dict[RefitSetting, Profile],
    echo_x: dict[RefitSetting, FloatArray],
    spans: dict[RefitSetting, Span],
    tolerance: float,
) -> tuple[RefitSetting, float] | None:
    """The lowest-order tied polynomial that agrees with the ``reference`` refit.

    A polynomial agrees if it is within ``tolerance`` (m) of the reference at every
    column where the reference's readings echo (``echo_x``), between the polynomial's
    own outermost echo points (``spans``; beyond them it is not reported), and there is
    at least one such column. A polynomial that misses a feature the readings see loses
    that feature's echo points, but not the reference's.

    Returns
    -------
    (RefitSetting, float) or None
        The polynomial and its largest difference (m) from the reference; None if no
        tied polynomial agrees.

    Examples
    --------
    A quadratic's samples: the spline through them and the quadratic agree, a line does
    not.

    >>> from sonarproc.fit import fit_polynomial, fit_spline
    >>> x = np.linspace(0.0, 4.0, 41)
    >>> y = 2.0 + 0.05 * (x - 2.0) ** 2
    >>> s, p2, p1 = RefitSetting("spline", 0.1), RefitSetting("poly", 2), RefitSetting("poly", 1)
    >>> fits = {s: fit_spline(x, y, np.ones(41), lam=1e-6),
    ...         p2: fit_polynomial(x, y, np.ones(41), order=2),
    ...         p1: fit_polynomial(x, y, np.ones(41), order=1)}
    >>> spans = dict.fromkeys(fits, (0.0, 4.0))
    >>> simplest_agreeing((p1, p2, s), s, fits, {s: x}, spans, 0.01)[0].short
    'poly m=2'
    >>> simplest_agreeing((p1, s), s, fits, {s: x}, spans, 0.01) is None
    True
    """
    xs = echo_x[reference]
    for k in sorted(k for k in tied if k.family == "poly"):
        lo, hi = spans[k]
        at = xs[(xs >= lo) & (xs <= hi)]
        if not at.size:
            continue  # no column to compare on: no evidence that they agree
        gap = float(np.max(np.abs(fits[k](at) - fits[reference](at))))
        if gap <= tolerance:
            return k, gap
    return None


def choose_refit(
    fit: Fit,
    map_bins: Bins,
    beams: Beams,
    grid: Grid,
    *,
    chosen_residual: float,
    chosen_losses: FloatArray | None = None,
    folds: int = 4,
    repeats: int = 1,
    heldout_per_fold: int = 300,
    cap: float,
    seed: int = 0,
    settings: tuple[RefitSetting, ...] = REFIT_SETTINGS,
    noise: float | None = None,
) -> RefitChoice:
    """Choose the echo refit's curve by the held-out range residual.

    The settings whose residuals are within :data:`TIE_SE` paired standard errors of the
    lowest cannot be told apart by the readings. Among them the lowest-order polynomial
    that agrees with the most flexible tied refit wherever readings echo is taken
    (:func:`simplest_agreeing`); failing one, the tied splines' refits are averaged. The
    refit is applied when its residual is below the chosen candidate's, or above it by
    less than :data:`TIE_SE` paired standard errors (it removes the map's bias, which the
    readings alone may not show).

    Parameters
    ----------
    fit : Fit
        The chosen candidate's profile on every scored reading.
    map_bins : Bins
        Its map's points per column (they fill the columns no reading echoes from).
    beams : Beams
        The scored readings (the same folds as the candidates' are drawn from ``seed``).
    grid : Grid
        The map's grid.
    chosen_residual : float
        The chosen candidate's held-out residual (m): the refit must beat it.
    chosen_losses : ndarray, optional
        The chosen candidate's held-out losses, in the order of the folds: with them a
        refit within :data:`TIE_SE` paired standard errors of the candidate is applied.
    folds, repeats, heldout_per_fold, cap, seed
        As :func:`sonarproc.auto.choose`.
    settings : tuple of RefitSetting
        The refits tried (:data:`REFIT_SETTINGS`).
    noise : float, optional
        The readings' range noise (m) that sets the rounds' tolerances
        (:func:`tolerances`); by default :func:`range_noise` about ``fit``.

    Returns
    -------
    RefitChoice
    """
    criterion = (
        "the chosen profile refitted through the readings' echo points (smoothing splines "
        "and polynomials, scored by the same held-out range residual; among those within "
        f"{TIE_SE:g} paired standard errors of the best, the lowest-order polynomial that "
        "agrees wherever readings echo with the most flexible tied spline, or with the "
        "best refit if that is a polynomial, else the tied splines averaged); applied "
        "unless its residual is above the chosen candidate's by more than "
        f"{TIE_SE:g} paired standard errors"
    )
    out = RefitChoice(criterion)
    occupied = np.flatnonzero(map_bins.count > 0)
    if not isinstance(fit, (PolyFit, SplineFit)) or occupied.size < 2:
        out.reason = "no profile y(x) to refit"
        return out
    span = (float(map_bins.centres[occupied[0]]), float(map_bins.centres[occupied[-1]]))
    # the held-out readings of the candidates' folds (same seeds, same order of draws)
    splits = heldout_splits(beams.readings, folds, repeats, heldout_per_fold, seed=seed)
    samples = int((span[1] - span[0]) / grid.cell) + 1
    echoing = beams
    if len(beams.path) * samples > MAX_PAIRS:
        keep = np.random.default_rng(seed + 3).random(len(beams.path)) < MAX_PAIRS / (
            len(beams.path) * samples
        )
        echoing = subset_beams(beams, keep)
        # the folds are the readings' own: carry them over to the subset
        splits = [(train[keep], held) for train, held in splits]
    out.noise = range_noise(fit, echoing, grid.cell) if noise is None else noise
    fold_curves = _score_settings(
        out, fit, map_bins, beams, echoing, grid, span, splits, settings, cap
    )
    if fold_curves is None:
        return out
    if out.residuals and out.noise > NOISE_MAX:
        # Above NOISE_MAX the estimate says that the profile misses most readings (a
        # room's other walls), or that the start is far off on a noisy log: about the
        # best refit the second comes down to the noise, the first does not.
        best = min(out.residuals, key=lambda k: out.residuals[k])
        again = range_noise(out.fits[best], echoing, grid.cell)
        if _believable(again) and tolerances(again) != out.tolerances:
            retry = RefitChoice(criterion, noise=again, noise_start=out.noise)
            curves = _score_settings(
                retry, fit, map_bins, beams, echoing, grid, span, splits, settings, cap
            )
            if curves is not None and retry.residuals:
                out, fold_curves = retry, curves
    fits, spans = out.fits, out.spans
    if not out.residuals:
        out.reason = (
            "every refit leaves its points' hull" if out.excluded
            else "no reading echoes from the chosen profile"
        )  # fmt: skip
        return out
    _settle_ties(out, echoing, grid.cell)
    if len(out.averaged) == 1:
        one = out.averaged[0]
        refit, losses, out.echo_span = fits[one], out.losses[one], spans[one]
    else:
        refit = _mean_profile([fits[k] for k in out.averaged], span, grid.cell)
        mean_curves = [
            _mean_curve([fold_curves[k][i] for k in out.averaged]) for i in range(len(splits))
        ]
        losses = _heldout_losses(mean_curves, splits, beams, cap)
        # where every averaged refit is carried by echo points
        out.echo_span = (
            max(spans[k][0] for k in out.averaged),
            min(spans[k][1] for k in out.averaged),
        )
    out.residual, out.heldout = robust_residual(losses), losses
    close = chosen_losses is not None and out.residual - chosen_residual <= TIE_SE * np.nan_to_num(
        paired_se(chosen_losses, losses)
    )
    verdict = f"held-out residual {100 * out.residual:.3g} cm"
    theirs = f"the chosen candidate's {100 * chosen_residual:.3g} cm"
    within = f"{TIE_SE:g} paired standard errors of"
    if out.residual < chosen_residual:
        out.applied, out.fit, out.reason = True, refit, f"{verdict} below {theirs}"
    elif close:
        out.applied, out.fit, out.reason = True, refit, f"{verdict} within {within} {theirs}"
    else:
        out.reason = f"{verdict} not below {theirs}" + (
            "" if chosen_losses is None else f", nor within {within} it"
        )
    if out.simpler:
        out.reason += "; " + out.simpler
    return out


def _settle_ties(out: RefitChoice, beams: Beams, cell: float) -> None:
    """Set ``out``'s best setting, the settings tied with it, and the refit taken: the
    lowest-order tied polynomial that agrees with a reference (:func:`references`,
    :func:`simplest_agreeing`), else the tied splines (averaged)."""
    best = min(out.residuals, key=lambda k: out.residuals[k])
    out.best = best
    out.tied = tuple(
        k for k in sorted(out.residuals)
        if k == best or out.residuals[k] - out.residuals[best]
        <= TIE_SE * np.nan_to_num(paired_se(out.losses[best], out.losses[k]))
    )  # fmt: skip
    for reference in references(out.tied, best):
        # the noise about the refit, not about the start: a start's bias is no noise
        tolerance = agreement_tolerance(range_noise(out.fits[reference], beams, cell), cell)
        simplest = simplest_agreeing(
            out.tied, reference, out.fits, out.echo_x, out.spans, tolerance
        )
        if simplest is None:
            continue
        poly, gap = simplest
        out.averaged = (poly,)
        if poly != reference:
            out.simpler = (
                f"{poly.short}: the lowest-order polynomial among the {len(out.tied)} tied "
                f"refits, within {100 * gap:.2g} cm (at most {100 * tolerance:.2g}) of "
                f"{reference.short} wherever readings echo"
            )
        elif len(out.tied) > 1:
            out.simpler = (
                f"{poly.short}: the best of the {len(out.tied)} tied refits; no tied spline "
                "agrees with it, nor a polynomial of a lower order, wherever readings echo"
            )
        return
    out.averaged = tuple(k for k in out.tied if k.family == "spline")


def _column_of(x: FloatArray, grid: Grid) -> IntArray:
    """The grid column of each abscissa, clipped to the grid."""
    return np.clip(np.floor((x - grid.x0) / grid.cell).astype(np.intp), 0, grid.nx - 1)


def _score_settings(
    out: RefitChoice,
    fit: Profile,
    map_bins: Bins,
    beams: Beams,
    echoing: Beams,
    grid: Grid,
    span: Span,
    splits: list[Split],
    settings: tuple[RefitSetting, ...],
    cap: float,
) -> dict[RefitSetting, list[FloatArray | None]] | None:
    """Refit every setting from ``fit`` with the tolerances of ``out.noise`` and score it on
    the folds, into ``out``; returns each setting's fold curves (None, with ``out.reason``,
    when too few readings echo from ``fit``)."""
    out.tolerances = tols = tolerances(out.noise or 0.0)
    # the first round starts from the chosen fit whatever the setting: search it once
    first = echo_points(fit, echoing, span, step=grid.cell, tol=tols[0])
    if first[0].size < MIN_ECHO_POINTS:
        out.reason = (
            f"{first[0].size} readings echo from the chosen profile "
            f"(at least {MIN_ECHO_POINTS} needed)"
        )
        return None
    fold_curves: dict[RefitSetting, list[FloatArray | None]] = {}
    for setting in settings:
        whole, rows, points = refit_profile(
            fit, map_bins, echoing, grid, span, setting, first=first, tols=tols
        )
        if not isinstance(whole, (PolyFit, SplineFit)) or rows.size == 0:
            continue
        hull = _fitted_points(points, map_bins, grid)
        excess = hull_excess(whole.sample(grid.cell), hull[:, 0], hull[:, 1], window=10 * grid.cell)
        if excess > hull_tolerance(out.noise or 0.0, grid.cell):
            out.excluded[setting] = f"leaves its points' hull by {100 * excess:.3g} cm"
            continue
        curves: list[FloatArray | None] = []
        for train, _ in splits:
            part = _fit_points(points[train[rows]], map_bins, grid, setting)
            ok = isinstance(part, (PolyFit, SplineFit))
            curves.append(_curve(part, span, grid.cell) if ok else None)  # type: ignore[arg-type]
        if splits:
            fold_curves[setting] = curves
            out.losses[setting] = _heldout_losses(curves, splits, beams, cap)
            out.residuals[setting] = robust_residual(out.losses[setting])
            out.fits[setting] = whole
            out.spans[setting] = (float(points[:, 0].min()), float(points[:, 0].max()))
            out.echo_x[setting] = grid.centres_x()[np.unique(_column_of(points[:, 0], grid))]
    return fold_curves


def _heldout_losses(
    curves: list[FloatArray | None],
    splits: list[Split],
    beams: Beams,
    cap: float,
) -> FloatArray:
    """Each fold's held-out readings' losses against its curve (the cap for a failed fit)."""
    losses = [
        np.full(held.size, cap) if curve is None
        else range_loss(beams.path[held], curve_path(curve, beams, held), cap)
        for curve, (_, held) in zip(curves, splits, strict=True)
    ]  # fmt: skip
    return np.concatenate(losses) if losses else np.zeros(0)


def _mean_curve(curves: list[FloatArray | None]) -> FloatArray | None:
    """The pointwise mean of sampled curves on the same abscissae (None if one is missing)."""
    present = [c for c in curves if c is not None]
    if not present or len(present) < len(curves):
        return None
    return np.column_stack((present[0][:, 0], np.mean([c[:, 1] for c in present], axis=0)))


def _mean_profile(fits: list[Profile], span: Span, step: float) -> SplineFit:
    """The pointwise mean of profiles, as a cubic spline through it every ``step``."""
    from scipy.interpolate import make_interp_spline

    mean = _mean_curve([_curve(f, span, step) for f in fits])
    assert mean is not None
    xs, ys = mean[:, 0], mean[:, 1]
    degree = min(3, xs.size - 1)
    spl = make_interp_spline(xs, ys, k=degree)
    return SplineFit(
        knots=np.asarray(spl.t, dtype=np.float64), coef=np.asarray(spl.c, dtype=np.float64),
        degree=degree, domain=(float(xs[0]), float(xs[-1])), lam=None,
    )  # fmt: skip

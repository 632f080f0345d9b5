"""The beam-range guard: sound does not pass through walls.

A first echo (echo rank 0) of path ``P``, from transmitter T to receiver R, says that
nothing inside both main lobes echoed on a shorter path: had it, that echo would have
come back first. A fitted profile is judged by the first echoes whose lobes hold it. It
echoes where its path ``|T - p| + |p - R|`` is stationary, inside both lobes (the
first-echo model, :mod:`sonarproc.methods.echo_model`); when its first echo for a
reading is shorter than ``P`` by more than :data:`GUARD_SIGMAS` range-noise sigmas
(twice that on the path), the reading contradicts each of the profile's points that
lie in its lobes nearer than the range it measured, ``(P - |TR|) / 2`` less the same
margin. (A profile point merely inside a lobe nearer than the range is no
contradiction: an oblique stretch with no specular point in the lobe sends the sound
away, and at a concave corner the sound bounces twice, beyond a surface crossing the
whole lobe.)

Each point of the profile is judged by the first echoes whose lobes hold it
(:func:`beam_contradictions`): it is *contradicted* when more than
:data:`GUARD_MAJORITY` of them contradict it, from at least :data:`GUARD_FIRINGS`
firings. A spurious or multipath echo contradicts a surface where it is, but such echoes
are a few per cent of a log and never the majority of the readings looking at a point;
one firing's readings share a pose and an error. A fit with more than
:data:`GUARD_LENGTH_CELLS` cells of its profile contradicted is excluded
(:func:`fit_guard_excess`). A point's share counts every first echo whose lobes hold
it, whether the fit predicts an echo for it or not; a fit that predicts nothing for a
reading is charged the cap for it by the held-out residual instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.auto.holdout import curve_path, firing_index
from sonarproc.auto.refit_rounds import believable_noise
from sonarproc.fit import Fit, FitFailure
from sonarproc.pipeline.selection import Beams

__all__ = [
    "GUARD_FIRINGS",
    "GUARD_LENGTH_CELLS",
    "GUARD_MAJORITY",
    "GUARD_READINGS",
    "GUARD_SIGMAS",
    "Contradictions",
    "beam_contradictions",
    "first_echoes",
    "fit_guard_excess",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: A fit's echo is too early when its path is shorter than the measured one by more than
#: this many range-noise sigmas each way (twice that on the path): 3 sigma leaves about
#: one Gaussian reading in 700 wrongly contradicting the true surface.
GUARD_SIGMAS = 3.0
#: A point of a profile is contradicted when more than this share of the first echoes
#: whose lobes hold it contradict it: most of the readings looking at it. Spurious
#: echoes and echoes off other surfaces, a quarter of a log at most
#: (:data:`~sonarproc.auto.score.TRIM`), are never most of them.
GUARD_MAJORITY = 0.5
#: ... from at least this many firings: one firing's readings (every receiver of a pair
#: listening) share its pose, its time and any error of them.
GUARD_FIRINGS = 2
#: A fit is excluded when more than this many cells of its profile are contradicted:
#: the profile is sampled once per cell, and one sample may sit across a lobe's edge.
GUARD_LENGTH_CELLS = 1.0
#: At most this many first echoes (evenly spread through the log) are asked: a few
#: hundred per metre of surface are plenty to judge every cell of it.
GUARD_READINGS = 1500

#: Work per chunk: readings x curve points.
_CHUNK = 1 << 21


@dataclass(frozen=True)
class Contradictions:
    """What the first echoes say about each point of a sampled profile.

    Attributes
    ----------
    holding : ndarray of int, (K,)
        First echoes whose lobes (the transmitter's or the receiver's) hold each point.
    against : ndarray of int, (K,)
        Of those, the ones that contradict it.
    against_firings : ndarray of int, (K,)
        The distinct firings among ``against``.
    """

    holding: IntArray
    against: IntArray
    against_firings: IntArray

    @property
    def contradicted(self) -> BoolArray:
        """The points more than :data:`GUARD_MAJORITY` of their readings contradict, from
        at least :data:`GUARD_FIRINGS` firings."""
        return (self.against > GUARD_MAJORITY * self.holding) & (
            self.against_firings >= GUARD_FIRINGS
        )


def first_echoes(beams: Beams) -> IntArray:
    """At most :data:`GUARD_READINGS` of the first echoes (echo rank 0), evenly spread."""
    first = np.flatnonzero(beams.readings["echo"] == 0)
    if first.size > GUARD_READINGS:
        first = first[np.linspace(0, first.size - 1, GUARD_READINGS).astype(np.intp)]
    return first


def _lobe(
    dx: FloatArray, dy: FloatArray, heading: FloatArray, half: FloatArray, reach: FloatArray
) -> tuple[BoolArray, BoolArray]:
    """For each apex (row) and point (column): whether the point lies in the lobe, and
    whether it does so nearer than ``reach``."""
    bearing = np.arctan2(dy, dx) - heading[:, None]
    bearing = (bearing + np.pi) % (2.0 * np.pi) - np.pi
    in_lobe = np.abs(bearing) <= half[:, None]
    return in_lobe, in_lobe & (np.hypot(dx, dy) < reach[:, None])


def beam_contradictions(
    curve: FloatArray, beams: Beams, noise: float, rows: IntArray, early: BoolArray
) -> Contradictions:
    """Each point of a sampled profile judged by the first echoes (module notes).

    Parameters
    ----------
    curve : ndarray, (K, 2)
        The profile's samples (m).
    beams : Beams
        The readings.
    noise : float
        The range noise sigma-hat (m).
    rows : ndarray of int
        The first echoes asked (indices into ``beams``; :func:`first_echoes`).
    early : ndarray of bool
        For each of ``rows``: whether the profile's first echo is too early for it.

    Returns
    -------
    Contradictions

    Examples
    --------
    A wall along y = 1 seen by sensors below it, each firing once; a profile 10 cm in
    front of it echoes too early for every reading whose lobes it lies in.

    >>> from sonarproc.methods.testing import beams_facing
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> beams, _ = beams_facing([[x, 0.0] for x in np.linspace(0, 1, 11)],
    ...                         [np.pi / 2] * 11, wall)
    >>> beams.readings["t"] = np.arange(11.0)
    >>> px = np.linspace(0, 1, 101)
    >>> front = np.column_stack((px, 0.9 + 0 * px))
    >>> c = beam_contradictions(front, beams, 0.005, np.arange(11), np.ones(11, bool))
    >>> int(c.contradicted.sum()), int(c.holding[50]), int(c.against[50])
    (101, 5, 5)
    """
    k = curve.shape[0]
    holding = np.zeros(k, np.intp)
    against = np.zeros(k, np.intp)
    firings = np.zeros(k, np.intp)
    if rows.size == 0 or k == 0:
        return Contradictions(holding, against, firings)
    firing = firing_index(beams.readings)[rows]
    order = np.argsort(firing, kind="stable")
    rows, firing, early = rows[order], firing[order], early[order]
    p = beams.poses
    baseline = np.hypot(*(p.tx_xy[rows] - p.rx_xy[rows]).T)
    # E, the echo's point, is at least (P - |TR|) / 2 from either end of the path
    reach = 0.5 * (beams.path[rows] - baseline) - GUARD_SIGMAS * noise
    # chunks of whole firings, so that each firing is counted once per point
    starts = np.r_[0, np.flatnonzero(np.diff(firing)) + 1, rows.size]
    per = max(1, _CHUNK // k)
    a = 0
    while a < rows.size:
        b = int(starts[min(np.searchsorted(starts, a + per), starts.size - 1)])
        r = rows[a:b]
        held = np.zeros((r.size, k), dtype=bool)
        bad = np.zeros((r.size, k), dtype=bool)
        for xy, heading, half in (
            (p.tx_xy, p.tx_heading, p.tx_half_beamwidth),
            (p.rx_xy, p.rx_heading, p.rx_half_beamwidth),
        ):
            dx = curve[None, :, 0] - xy[r, 0, None]
            dy = curve[None, :, 1] - xy[r, 1, None]
            in_lobe, nearer = _lobe(dx, dy, heading[r], half[r], reach[a:b])
            held |= in_lobe
            bad |= nearer & early[a:b, None]
        holding += held.sum(axis=0)
        against += bad.sum(axis=0)
        local = starts[(starts >= a) & (starts < b)] - a
        firings += np.logical_or.reduceat(bad, local, axis=0).sum(axis=0)
        a = b
    return Contradictions(holding, against, firings)


def fit_guard_excess(fit: Fit, beams: Beams | None, cell: float) -> float:
    """The length (m) of a fit's profile (sampled once per ``cell``) that the first
    echoes contradict (:func:`beam_contradictions`); 0 without readings.

    The range noise sigma-hat is that of :func:`~sonarproc.auto.refit_rounds.range_noise`
    (1.4826 times the median range residual), on the first echoes asked and about the
    fit itself; 0 when not believable (:func:`~sonarproc.auto.refit_rounds.believable_noise`:
    the fit misses most readings, and the guard is strictest). A fit is excluded above
    :data:`GUARD_LENGTH_CELLS` cells.

    Examples
    --------
    >>> from sonarproc.fit import PolyFit
    >>> from sonarproc.methods.testing import beams_facing
    >>> xs = np.linspace(-2, 2, 401)
    >>> wall = np.column_stack((xs, np.ones_like(xs)))
    >>> beams, _ = beams_facing([[x, 0.0] for x in np.linspace(0, 1, 11)],
    ...                         [np.pi / 2] * 11, wall)
    >>> beams.readings["t"] = np.arange(11.0)
    >>> on, front = (PolyFit(0, np.array([y]), (0.0, 1.0)) for y in (1.0, 0.9))
    >>> fit_guard_excess(on, beams, 0.01), round(fit_guard_excess(front, beams, 0.01), 2)
    (0.0, 1.01)
    """
    if beams is None or isinstance(fit, FitFailure) or not hasattr(fit, "domain"):
        return 0.0
    rows = first_echoes(beams)
    curve = fit.sample(cell)
    if rows.size == 0 or curve.shape[0] == 0:
        return 0.0
    measured = beams.path[rows]
    predicted = curve_path(curve, beams, rows)
    residual = np.abs(measured - predicted) / 2
    residual = residual[np.isfinite(residual)]
    noise = believable_noise(float(1.4826 * np.median(residual)) if residual.size else 0.0)
    early = predicted < measured - 2.0 * GUARD_SIGMAS * noise
    return float(beam_contradictions(curve, beams, noise, rows, early).contradicted.sum()) * cell

"""The physical criterion of ``--auto``: predict held-out readings from a fitted profile.

Firings (one transmitter burst: every reading sharing a time and a transmitter) are
split into ``k`` folds. For each fold a candidate maps the other folds' readings, fits
its profile, and predicts each held-out reading's path length with the first-echo model
(:func:`sonarproc.methods.echo_model.first_echo_path`: the nearest point of the fitted
curve inside the reading's beams, the ellipse path for a bistatic pair). The loss of a
reading is its absolute range residual ``|measured - predicted| / 2``, capped at
``cap`` (spurious echoes and echoes off other surfaces cost every candidate the same);
a reading whose beams the curve does not cross costs the cap (a profile that explains
less of the log is worse). No ground truth is used.
"""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import numpy.typing as npt

from sonarlog import TransducerPoses
from sonarproc.fit import Fit, FitFailure
from sonarproc.methods.base import Beams
from sonarproc.methods.echo_model import first_echo_path

#: Points of a fitted curve the echo model looks at, at most.
MAX_SAMPLES = 500

__all__ = [
    "MAX_SAMPLES",
    "Split",
    "curve_path",
    "firing_folds",
    "firing_index",
    "heldout_splits",
    "hull_excess",
    "local_hull",
    "predicted_path",
    "range_loss",
    "subset_beams",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]


def firing_folds(readings: np.ndarray, k: int, *, seed: int = 0) -> npt.NDArray[np.intp]:
    """Fold (0 .. k-1) of each reading; all readings of one firing share a fold.

    Examples
    --------
    >>> from sonarlog.schema import empty_readings
    >>> r = empty_readings(6)
    >>> r["t"] = [0, 0, 1, 1, 2, 2]
    >>> f = firing_folds(r, 3)
    >>> bool(f[0] == f[1] and f[2] == f[3] and len(set(f.tolist())) == 3)
    True
    """
    firing = firing_index(readings)
    rng = np.random.default_rng(seed)
    n = int(firing.max()) + 1 if firing.size else 0
    fold_of_firing = rng.permutation(n) % k
    return fold_of_firing[firing].astype(np.intp)


def firing_index(readings: np.ndarray) -> npt.NDArray[np.intp]:
    """Index of each reading's firing (its time and transmitter), firings numbered in
    time order."""
    t = np.asarray(readings["t"], dtype=np.float64)
    tx = np.asarray(readings["tx"], dtype=np.float64)
    # the rank of each (t, tx) among the distinct ones: np.unique(..., axis=0)'s inverse,
    # without its row-by-row comparisons (10x faster on a 90 000-reading log)
    order = np.lexsort((tx, t))
    ts, xs = t[order], tx[order]
    new = np.ones(t.size, dtype=bool)
    new[1:] = (ts[1:] != ts[:-1]) | (xs[1:] != xs[:-1])
    firing = np.empty(t.size, dtype=np.intp)
    firing[order] = np.cumsum(new) - 1
    return firing


#: One fold's split: the training readings (a mask) and the held-out ones predicted.
Split = tuple[BoolArray, npt.NDArray[np.intp]]


def heldout_splits(
    readings: np.ndarray,
    folds: int,
    repeats: int,
    heldout_per_fold: int,
    *,
    seed: int = 0,
) -> list[Split]:
    """Every fold's split, the folds drawn ``repeats`` times (seeds ``seed + 1000 * rep``),
    each fold's held-out readings a random subset of at most ``heldout_per_fold``.

    The candidates and the echo refit draw the same splits from the same ``seed``, so
    their held-out losses pair up reading by reading.

    Examples
    --------
    >>> from sonarlog.schema import empty_readings
    >>> r = empty_readings(40)
    >>> r["t"] = np.arange(40)
    >>> splits = heldout_splits(r, 4, 2, 5)
    >>> len(splits), {int(held.size) for _, held in splits}
    (8, {5})
    >>> all(not train[held].any() for train, held in splits)
    True
    """
    rng = np.random.default_rng(seed + 2)
    splits: list[Split] = []
    for rep in range(repeats):
        fold = firing_folds(readings, folds, seed=seed + 1000 * rep)
        for f in range(folds):
            test = np.flatnonzero(fold == f)
            if test.size:
                splits.append((fold != f, np.sort(rng.permutation(test)[:heldout_per_fold])))
    return splits


def subset_beams(beams: Beams, keep: BoolArray) -> Beams:
    """The readings ``keep`` of ``beams``, with their arcs (renumbered)."""
    p = beams.poses
    poses = TransducerPoses(**{f.name: getattr(p, f.name)[keep] for f in fields(p)})
    new_index = np.cumsum(keep) - 1
    arcs = beams.arcs[keep[beams.arcs.arc]]  # type: ignore[index]
    arcs = replace(arcs, arc=new_index[arcs.arc].astype(np.intp))
    return Beams(beams.readings[keep], poses, beams.path[keep], arcs)


def predicted_path(fit: Fit, beams: Beams, rows: npt.NDArray[np.intp], step: float) -> FloatArray:
    """Path length the fitted curve predicts for readings ``rows`` (NaN: not in the beams)."""
    if isinstance(fit, FitFailure) or not hasattr(fit, "domain"):
        return np.full(rows.size, np.nan)
    lo, hi = fit.domain
    # at most MAX_SAMPLES points: a long profile is sampled more coarsely
    return curve_path(fit.sample(max(step, (hi - lo) / MAX_SAMPLES)), beams, rows)


def curve_path(curve: FloatArray, beams: Beams, rows: npt.NDArray[np.intp]) -> FloatArray:
    """Path length a sampled curve ``(K, 2)`` predicts for readings ``rows`` (NaN: none)."""
    p = beams.poses
    return first_echo_path(
        p.tx_xy[rows], p.tx_heading[rows], p.tx_half_beamwidth[rows],
        p.rx_xy[rows], p.rx_heading[rows], p.rx_half_beamwidth[rows], curve,
        beams.readings["echo"][rows],
    )  # fmt: skip


def range_loss(measured: FloatArray, predicted: FloatArray, cap: float) -> FloatArray:
    """Capped absolute range residual of each reading (the cap where there is no prediction).

    Examples
    --------
    >>> range_loss(np.array([2.0, 2.0, 2.0]), np.array([2.02, np.nan, 3.0]), 0.1).round(3)
    array([0.01, 0.1 , 0.1 ])
    """
    r = 0.5 * np.abs(measured - predicted)
    return np.where(np.isfinite(r), np.minimum(r, cap), cap)


def local_hull(
    x: FloatArray, px: FloatArray, py: FloatArray, *, window: float
) -> tuple[FloatArray, FloatArray]:
    """The points' local vertical hull at each ``x``: the lowest and highest y (m).

    The hull at x is the range of the points' y within ``window`` of x (widened to the
    nearest points where there is a gap, and to the neighbouring windows').

    Examples
    --------
    >>> lo, hi = local_hull(np.array([0.05, 0.5]), np.array([0.0, 0.1, 0.9]),
    ...                     np.array([1.0, 1.2, 1.1]), window=0.1)
    >>> lo.tolist(), hi.tolist()
    ([1.0, 1.1], [1.2, 1.2])
    """
    lo_x = float(px.min())
    nb = max(1, int(np.ceil((float(px.max()) - lo_x) / window)) + 1)
    b = np.minimum(((px - lo_x) / window).astype(np.intp), nb - 1)
    lo = np.full(nb, np.inf)
    hi = np.full(nb, -np.inf)
    np.minimum.at(lo, b, py)
    np.maximum.at(hi, b, py)
    idx = np.flatnonzero(np.isfinite(lo))
    # an empty bin takes the hull of both nearest bins with points
    left = idx[np.clip(np.searchsorted(idx, np.arange(nb), side="right") - 1, 0, idx.size - 1)]
    right = idx[np.clip(np.searchsorted(idx, np.arange(nb)), 0, idx.size - 1)]
    lo = np.minimum(lo[left], lo[right])
    hi = np.maximum(hi[left], hi[right])
    # and every bin the hull of its neighbours too (a slope crossing a bin edge)
    lo = np.minimum(lo, np.minimum(np.r_[lo[:1], lo[:-1]], np.r_[lo[1:], lo[-1:]]))
    hi = np.maximum(hi, np.maximum(np.r_[hi[:1], hi[:-1]], np.r_[hi[1:], hi[-1:]]))
    cb = np.clip(((x - lo_x) / window).astype(np.intp), 0, nb - 1)
    return lo[cb], hi[cb]


def hull_excess(
    curve: FloatArray, px: FloatArray, py: FloatArray, *, window: float, side: int = 0
) -> float:
    """How far (m) a fitted curve leaves the points' hull.

    ``side`` 0: the local hull (:func:`local_hull`) on both sides. ``side`` +1 (the
    sensors below the curve, at lower y) or -1 (above): the local hull on the sensors'
    side, and on the far side only the highest (lowest) of all the points. A reading's
    first echo comes from the nearest part of the surface in its beam, so the points
    are thin where the surface recedes from the sensors (a crest seen from below, with
    its flanks in every beam), and a curve that follows the surface there leaves their
    local hull; towards the sensors, a curve that leaves it would be heard first.

    Examples
    --------
    >>> px = np.array([0.0, 0.1, 0.9, 1.0]); py = np.array([1.0, 1.0, 1.0, 1.1])
    >>> crest = np.array([[0.5, 1.08]])
    >>> round(hull_excess(crest, px, py, window=0.1), 3)
    0.08
    >>> hull_excess(crest, px, py, window=0.1, side=1)
    0.0
    >>> round(hull_excess(np.array([[0.5, 0.9]]), px, py, window=0.1, side=1), 3)
    0.1
    """
    if curve.shape[0] == 0 or px.size == 0:
        return 0.0
    y = curve[:, 1]
    lo, hi = local_hull(curve[:, 0], px, py, window=window)
    if side > 0:
        hi = np.full_like(hi, float(py.max()))
    elif side < 0:
        lo = np.full_like(lo, float(py.min()))
    excess = np.maximum(y - hi, lo - y)
    return float(max(0.0, np.nanmax(excess)))

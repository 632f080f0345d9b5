"""Truth with several surfaces: what the sonars saw, and how well the fits match it.

``/truth/profile`` may hold several polylines separated by a NaN row. Two measures:

* ``precision_m``: the mean distance (m) from the fitted surfaces (their polylines, sampled
  at the cell size) to the nearest truth polyline;
* ``completeness``: the fraction of the truth *the sonars saw* that lies within
  ``within`` (default 5 cm) of a fitted surface.

Which truth points the sonars saw is :func:`seen_truth` (module
:mod:`sonarproc.surfaces.evaluation.seen`, re-exported here).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.evaluation.seen import SEEN_TOLERANCE_M, seen_truth
from sonarproc.surfaces.planar.polylines import distance_to_polylines, resample, split_polylines

__all__ = [
    "COMPLETENESS_WITHIN_M",
    "SEEN_TOLERANCE_M",
    "SurfaceMetrics",
    "seen_truth",
    "surface_metrics",
    "truth_is_function",
    "truth_points",
]

FloatArray = npt.NDArray[np.float64]

#: A seen truth point counts as found when a fitted surface passes this close (m).
COMPLETENESS_WITHIN_M = 0.05
#: Spacing (m) of the truth points the measures use.
TRUTH_STEP_M = 0.01


def truth_is_function(truth: npt.ArrayLike) -> bool:
    """Whether a truth profile is one curve y = f(x) (then the paper's E1 and E2 apply).

    True for a single polyline (no NaN row) whose x is strictly monotonic.

    Examples
    --------
    >>> truth_is_function([[0, 1], [1, 2], [2, 1]])
    True
    >>> truth_is_function([[0, 0], [1, 0], [np.nan, np.nan], [0, 1], [1, 1]])
    False
    >>> truth_is_function([[0, 0], [0, 1]])
    False
    """
    parts = split_polylines(truth)
    if len(parts) != 1 or len(parts[0]) < 2:
        return False
    dx = np.diff(parts[0][:, 0])
    return bool(np.all(dx > 0) or np.all(dx < 0))


def truth_points(truth: npt.ArrayLike, step: float = TRUTH_STEP_M) -> list[FloatArray]:
    """The truth polylines resampled every ``step`` metres."""
    return [resample(p, step) for p in split_polylines(truth)]


@dataclass(frozen=True)
class SurfaceMetrics:
    """Precision and completeness of fitted surfaces against a multi-surface truth."""

    precision_m: float | None
    completeness: float | None
    truth_points: int
    seen_points: int
    found_points: int
    within_m: float

    def to_json(self) -> dict[str, Any]:
        """JSON-ready mapping (NaN-free)."""
        return {
            "precision_m": self.precision_m,
            "completeness": self.completeness,
            "truth_points": self.truth_points,
            "seen_points": self.seen_points,
            "found_points": self.found_points,
            "completeness_within_m": self.within_m,
        }


def surface_metrics(
    fitted: list[FloatArray],
    truth: npt.ArrayLike,
    *,
    seen: npt.ArrayLike | None = None,
    within: float = COMPLETENESS_WITHIN_M,
    step: float = TRUTH_STEP_M,
) -> SurfaceMetrics:
    """``precision_m`` and ``completeness`` of fitted polylines against the truth.

    Parameters
    ----------
    fitted : list of ndarray, shape (K_i, 2)
        The fitted surfaces' polylines.
    truth : array_like, shape (N, 2)
        Truth polylines separated by NaN rows.
    seen : array_like of bool, optional
        Over the points of :func:`truth_points` (same ``step``), concatenated: which ones
        the sonars saw (:func:`seen_truth`); default all.
    within : float
        Distance (m) under which a truth point counts as found.
    step : float
        Spacing (m) of the truth points.

    Returns
    -------
    SurfaceMetrics
        ``precision_m`` is None without a fitted surface, ``completeness`` None when no
        truth point was seen.

    Examples
    --------
    >>> truth = np.array([[0.0, 0.0], [1.0, 0.0], [np.nan, np.nan], [0.0, 1.0], [1.0, 1.0]])
    >>> m = surface_metrics([np.array([[0.0, 0.01], [1.0, 0.01]])], truth)
    >>> round(m.precision_m, 6), round(m.completeness, 3)
    (0.01, 0.5)
    """
    tp = truth_points(truth, step)
    pts = np.concatenate(tp) if tp else np.zeros((0, 2))
    mask = np.ones(len(pts), dtype=bool) if seen is None else np.asarray(seen, dtype=bool)
    if mask.shape != (len(pts),):
        raise ValueError(f"seen must have one flag per truth point ({len(pts)}), got {mask.shape}")
    polys = [np.asarray(f, dtype=np.float64).reshape(-1, 2) for f in fitted if len(f)]
    precision = None
    if polys and tp:
        samples = np.concatenate(polys)
        precision = float(np.mean(distance_to_polylines(samples, tp)))
    n_seen = int(mask.sum())
    found = 0
    if polys and n_seen:
        found = int(np.count_nonzero(distance_to_polylines(pts[mask], polys) <= within))
    completeness = found / n_seen if n_seen else None
    return SurfaceMetrics(precision, completeness, len(pts), n_seen, found, within)

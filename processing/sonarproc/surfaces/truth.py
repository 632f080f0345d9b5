"""Truth with several surfaces: what the sonars saw, and how well the fits match it.

``/truth/profile`` may hold several polylines separated by a NaN row. Two measures:

* ``precision_m``: the mean distance (m) from the fitted surfaces (their polylines, sampled
  at the cell size) to the nearest truth polyline;
* ``completeness``: the fraction of the truth *the sonars saw* that lies within
  ``within`` (default 5 cm) of a fitted surface.

The truth a reading could have produced: a truth point ``p`` is seen by a reading when it
lies in the transmitter's beam (``|angle(p - tx) - tx_heading| <= tx half beam width``),
in the receiver's beam likewise, and on the reading's ellipse,
``| |p - tx| + |p - rx| - path | <= 2 tol`` (for a sensor's own echo: its range circle
within ``tol``). Candidates come from a KD-tree of the truth points queried with a ball
around each reading's beam sector (readings sorted by ball size and taken in chunks), and
only the candidate pairs are tested exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

from sonarproc.surfaces.polylines import distance_to_polylines, resample, split_polylines

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
#: Range tolerance (m) of "a reading could have produced this truth point".
SEEN_TOLERANCE_M = 0.02
#: Spacing (m) of the truth points the measures use.
TRUTH_STEP_M = 0.01
#: Candidate (reading, truth point) pairs tested at once.
_PAIRS_PER_CHUNK = 4_000_000


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


def _wrap(a: FloatArray) -> FloatArray:
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def seen_truth(
    points: npt.ArrayLike,
    tx_xy: npt.ArrayLike,
    tx_heading: npt.ArrayLike,
    rx_xy: npt.ArrayLike,
    rx_heading: npt.ArrayLike,
    path: npt.ArrayLike,
    *,
    tx_half_beamwidth: npt.ArrayLike,
    rx_half_beamwidth: npt.ArrayLike,
    tol: float = SEEN_TOLERANCE_M,
) -> npt.NDArray[np.bool_]:
    """Which truth points some reading could have produced (see the module docstring).

    Parameters
    ----------
    points : array_like, shape (T, 2)
        Truth points (m), e.g. from :func:`truth_points`.
    tx_xy, rx_xy : array_like, shape (N, 2)
        Transmitter and receiver positions of each reading (m).
    tx_heading, rx_heading : array_like, shape (N,)
        Their headings (rad).
    path : array_like, shape (N,)
        Path length ``tof * c`` (m): twice the range for a sensor's own echo.
    tx_half_beamwidth, rx_half_beamwidth : array_like, shape (N,) or scalar
        Half beam widths (rad).
    tol : float
        Range tolerance (m).

    Returns
    -------
    ndarray of bool, shape (T,)

    Examples
    --------
    A sensor at the origin looking up, range 1 m: the wall point straight ahead is seen,
    the one 0.5 m to the side (1.118 m away) is not.

    >>> seen_truth([[0.0, 1.0], [0.5, 1.0]], [[0.0, 0.0]], [np.pi / 2], [[0.0, 0.0]],
    ...            [np.pi / 2], [2.0], tx_half_beamwidth=0.22, rx_half_beamwidth=0.22).tolist()
    [True, False]
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    txy = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
    rxy = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
    n = txy.shape[0]
    th = np.broadcast_to(np.asarray(tx_heading, dtype=np.float64), (n,))
    rh = np.broadcast_to(np.asarray(rx_heading, dtype=np.float64), (n,))
    L = np.broadcast_to(np.asarray(path, dtype=np.float64), (n,))
    tb = np.broadcast_to(np.asarray(tx_half_beamwidth, dtype=np.float64), (n,))
    rb = np.broadcast_to(np.asarray(rx_half_beamwidth, dtype=np.float64), (n,))
    seen = np.zeros(pts.shape[0], dtype=bool)
    if pts.shape[0] == 0 or n == 0:
        return seen
    # the reading's points lie in the tx beam at a range between (L - d) / 2 and (L + d) / 2
    d = np.hypot(*(rxy - txy).T)
    a0 = np.maximum(0.5 * (L - d) - tol, 0.0)
    a1 = 0.5 * (L + d) + tol
    m = 0.5 * (a0 + a1)
    beta = np.minimum(tb, np.pi)

    def corner(a: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(a * np.cos(beta) - m, a * np.sin(beta)), dtype=np.float64)

    radius = np.maximum(corner(a0), corner(a1)) + 1e-9
    centre = txy + m[:, None] * np.stack((np.cos(th), np.sin(th)), axis=1)
    ok = np.all(np.isfinite(centre), axis=1) & np.isfinite(radius)
    order = np.flatnonzero(ok)[np.argsort(radius[ok], kind="stable")]
    tree = cKDTree(pts)
    density = pts.shape[0] / max(float(np.ptp(pts[:, 0]) * np.ptp(pts[:, 1])), 1e-6)
    c0 = 0
    while c0 < order.size:
        # chunk so that the candidate pairs stay bounded (a ball holds at most ~ the
        # truth points on a line through it: 2 R / step, plus area density)
        r_est = radius[order[min(order.size - 1, c0 + 64)]]
        per = 2.0 * r_est / TRUTH_STEP_M + density * np.pi * r_est**2 + 1.0
        size = int(max(64, min(order.size - c0, _PAIRS_PER_CHUNK // per)))
        idx = order[c0 : c0 + size]
        c0 += size
        near = cKDTree(centre[idx]).sparse_distance_matrix(
            tree, float(radius[idx].max()), output_type="ndarray"
        )
        k = idx[near["i"]]
        j = near["j"]
        inside = near["v"] <= radius[k]
        k, j = k[inside], j[inside]
        p = pts[j]
        vt = p - txy[k]
        vr = p - rxy[k]
        dt, dr = np.hypot(*vt.T), np.hypot(*vr.T)
        hit = (
            (np.abs(_wrap(np.arctan2(vt[:, 1], vt[:, 0]) - th[k])) <= tb[k])
            & (np.abs(_wrap(np.arctan2(vr[:, 1], vr[:, 0]) - rh[k])) <= rb[k])
            & (np.abs(dt + dr - L[k]) <= 2.0 * tol)
        )
        seen[j[hit]] = True
    return seen


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

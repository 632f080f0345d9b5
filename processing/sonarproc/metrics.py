"""Success measures of the paper: e (Eq. 1), f_c, E1 (Eq. 3) and E2 (Eq. 4).

The map's points are grouped into *bins*: the grid's columns for a profile y = f(x), or
equal angular sectors about a centre for a profile r(phi) around the robot. Each bin
holds ``M_i`` points with a mean and a median (the paper's ``m_i``) ordinate. All
functions here are pure and vectorised; nothing loops per point or per bin.

Definitions (``N`` bins spanned by the truth within the map, ``N_k`` of them with points):

* ``e   = sqrt(mean_{N_k} (m_i - y_i)**2) / sigma_y``
* ``f_c = N_k / N``; without a truth profile ``N`` counts the bins that hold at least one
  cell of the unprocessed arc map instead, so f_c is the fraction the processing kept.
* ``E1  = sqrt(mean_N (p(x_i) - y_i)**2)`` (m) and ``E2 = E1 / sigma_y``, the fit
  evaluated at every truth bin (extrapolating where the points stop, as the paper does).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

__all__ = [
    "Bins",
    "Metrics",
    "bin_stats",
    "polar_bins",
    "profile_metrics",
    "truth_on_columns",
    "truth_on_polar_bins",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]


@dataclass(frozen=True)
class Bins:
    """Points grouped into ``K`` bins: position, count, mean and median of each bin.

    ``mean`` and ``median`` are NaN where ``count`` is 0.
    """

    centres: FloatArray
    count: IntArray
    mean: FloatArray
    median: FloatArray

    @property
    def occupied(self) -> npt.NDArray[np.bool_]:
        """Boolean mask of the bins holding at least one point."""
        return self.count > 0


def bin_stats(
    index: npt.ArrayLike,
    values: npt.ArrayLike,
    centres: npt.ArrayLike,
    *,
    presorted: bool = False,
) -> Bins:
    """Count, mean and median of ``values`` grouped by integer bin ``index``.

    Parameters
    ----------
    index : array_like of int, shape (P,)
        Bin of each point, ``0 <= index < len(centres)``.
    values : array_like, shape (P,)
        Ordinate of each point.
    centres : array_like, shape (K,)
        Position of each bin.
    presorted : bool
        True when the points are already sorted by ``(index, values)``, as
        ``np.nonzero(binary.T)`` returns the cells of a map; skips the sort.

    Returns
    -------
    Bins

    Examples
    --------
    >>> b = bin_stats([0, 0, 0, 2], [1.0, 2.0, 6.0, 5.0], [0.0, 1.0, 2.0])
    >>> b.count.tolist(), b.median.tolist()[0], b.mean.tolist()[0]
    ([3, 0, 1], 2.0, 3.0)
    """
    idx = np.asarray(index, dtype=np.int64)
    val = np.asarray(values, dtype=np.float64)
    cen = np.asarray(centres, dtype=np.float64)
    if not presorted and idx.size:
        # one float sort on "bin + fraction of the value range" orders by (bin, value)
        # about twice as fast as np.lexsort; the value enters only within its bin
        vmin, span = float(val.min()), float(np.ptp(val))
        key = idx + (0.5 * (val - vmin) / span if span > 0 else 0.0)
        order = np.argsort(key)
        idx, val = idx[order], val[order]
    k = cen.size
    count = np.bincount(idx, minlength=k).astype(np.int64)
    sums = np.bincount(idx, weights=val, minlength=k)
    mean = np.full(k, np.nan)
    median = np.full(k, np.nan)
    occ = count > 0
    mean[occ] = sums[occ] / count[occ]
    if idx.size:
        start = np.concatenate(([0], np.cumsum(count)[:-1]))[occ]
        c = count[occ]
        lo = start + (c - 1) // 2
        hi = start + c // 2
        median[occ] = 0.5 * (val[lo] + val[hi])
    return Bins(centres=cen, count=count, mean=mean, median=median)


def polar_bins(
    px: npt.ArrayLike, py: npt.ArrayLike, *, centre: tuple[float, float], nbins: int
) -> Bins:
    """Group world points into ``nbins`` equal angular sectors about ``centre`` (by radius).

    Bin ``k`` covers ``[-pi + k w, -pi + (k + 1) w)`` with ``w = 2 pi / nbins``.
    """
    if nbins < 1:
        raise ValueError(f"nbins must be >= 1, got {nbins}")
    dx = np.asarray(px, dtype=np.float64) - centre[0]
    dy = np.asarray(py, dtype=np.float64) - centre[1]
    phi = np.arctan2(dy, dx)
    r = np.hypot(dx, dy)
    width = 2.0 * np.pi / nbins
    idx = np.clip(((phi + np.pi) / width).astype(np.int64), 0, nbins - 1)
    centres = -np.pi + width * (np.arange(nbins) + 0.5)
    return bin_stats(idx, r, centres)


def truth_on_columns(truth: npt.ArrayLike, centres: npt.ArrayLike) -> FloatArray:
    """Interpolate a truth profile y(x) onto column centres; NaN outside its x-range.

    Parameters
    ----------
    truth : array_like, shape (T, 2)
        Points ``(x, y)`` of the true surface.
    centres : array_like, shape (K,)
        Column centres (m).
    """
    t = np.asarray(truth, dtype=np.float64)
    x = np.asarray(centres, dtype=np.float64)
    if t.ndim != 2 or t.shape[1] != 2 or t.shape[0] < 2:
        raise ValueError("truth profile must be an (N, 2) array with N >= 2")
    order = np.argsort(t[:, 0], kind="stable")
    tx, ty = t[order, 0], t[order, 1]
    out = np.interp(x, tx, ty)
    out[(x < tx[0]) | (x > tx[-1])] = np.nan
    return out


def truth_on_polar_bins(
    truth: npt.ArrayLike, *, centre: tuple[float, float], nbins: int, step: float
) -> FloatArray:
    """Radius of the truth polyline seen from ``centre`` in each angular bin (NaN if none).

    The polyline is resampled every ``step`` metres; where several truth points share a
    bin (a surface behind another), the nearest one counts, as seen from the centre.
    """
    t = np.asarray(truth, dtype=np.float64)
    if t.ndim != 2 or t.shape[1] != 2 or t.shape[0] < 2:
        raise ValueError("truth profile must be an (N, 2) array with N >= 2")
    seg = np.diff(t, axis=0)
    pieces = np.maximum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / step).astype(np.int64), 1)
    owner = np.repeat(np.arange(seg.shape[0]), pieces)
    frac = (np.arange(owner.size) - np.repeat(np.cumsum(pieces) - pieces, pieces)) / np.repeat(
        pieces, pieces
    )
    pts = np.vstack((t[owner] + seg[owner] * frac[:, None], t[-1:]))
    dx, dy = pts[:, 0] - centre[0], pts[:, 1] - centre[1]
    width = 2.0 * np.pi / nbins
    idx = np.clip(((np.arctan2(dy, dx) + np.pi) / width).astype(np.int64), 0, nbins - 1)
    out = np.full(nbins, np.inf)
    np.minimum.at(out, idx, np.hypot(dx, dy))
    out[np.isinf(out)] = np.nan
    return out


@dataclass(frozen=True)
class Metrics:
    """The paper's measures; ``None`` where undefined (no truth, no points, no fit)."""

    e: float | None
    f_c: float
    E1_m: float | None
    E2: float | None
    N: int
    N_k: int
    sigma_y_m: float | None

    def to_json(self) -> dict[str, Any]:
        """Return a JSON-ready mapping (NaN-free)."""
        return {
            "e": self.e,
            "f_c": self.f_c,
            "E1_m": self.E1_m,
            "E2": self.E2,
            "N": self.N,
            "N_k": self.N_k,
            "sigma_y_m": self.sigma_y_m,
        }


def _finite_or_none(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def profile_metrics(
    bins: Bins,
    *,
    truth: npt.ArrayLike | None,
    fit: Callable[[FloatArray], FloatArray] | None,
    spanned: npt.ArrayLike | None = None,
) -> Metrics:
    """Compute e, f_c, E1 and E2 for points in ``bins`` against ``truth``.

    Parameters
    ----------
    bins : Bins
        The processed map's points per bin.
    truth : array_like, shape (K,), optional
        True ordinate at each bin centre, NaN outside the truth (see
        :func:`truth_on_columns`). ``None`` when the log has no truth profile.
    fit : callable, optional
        The fitted profile, evaluated at bin centres; ``None`` when the fit failed.
    spanned : array_like of bool, shape (K,), optional
        Without truth: the bins that count towards ``N`` (e.g. those of the raw arc map).

    Returns
    -------
    Metrics
    """
    occ = bins.occupied
    if truth is None:
        span = np.ones_like(occ) if spanned is None else np.asarray(spanned, dtype=bool)
        n = int(np.count_nonzero(span))
        n_k = int(np.count_nonzero(span & occ))
        return Metrics(None, n_k / n if n else 0.0, None, None, n, n_k, None)
    y = np.asarray(truth, dtype=np.float64)
    if y.shape != bins.centres.shape:
        raise ValueError("truth must have one value per bin")
    span = np.isfinite(y)
    n = int(np.count_nonzero(span))
    if n == 0:
        return Metrics(None, 0.0, None, None, 0, 0, None)
    both = span & occ
    n_k = int(np.count_nonzero(both))
    sigma = float(np.std(y[span]))
    e: float | None = None
    if n_k and sigma > 0:
        e = _finite_or_none(float(np.sqrt(np.mean((bins.median[both] - y[both]) ** 2))) / sigma)
    e1: float | None = None
    e2: float | None = None
    if fit is not None:
        resid = fit(bins.centres[span]) - y[span]
        e1 = _finite_or_none(float(np.sqrt(np.mean(resid**2))))
        if e1 is not None and sigma > 0:
            e2 = _finite_or_none(e1 / sigma)
    return Metrics(e, n_k / n, e1, e2, n, n_k, sigma if sigma > 0 else None)

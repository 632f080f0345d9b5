"""The ends of ``--auto``'s profile: the x-span its evidence supports.

A fitted profile reaches every column its map has points in, but the columns at the ends
are often held by few cells of one method's map, seen only by oblique beams, and the fit
there follows them or extrapolates. These rules find, without ground truth, the x-span
the evidence supports (:class:`EndCut`); :mod:`sonarproc.studies.auto_ends` cuts the
winner's map to it (:func:`sonarproc.auto.select.evaluate_candidate`) and judges the
refitted profile by the truth. ``--auto`` does not cut its map (the study found no rule
that helps on scenarios it was not made on; see docs/methods.md); it reports its echo
refit between the refit's own outermost echo points instead
(:mod:`sonarproc.auto.echo_refit`). These rules live with the study:

``support``
    The columns from the first to the last whose map support (cells per column, a
    running mean over :data:`SUPPORT_WINDOW` cells) is at least ``frac`` of the median
    support of the columns with points.
``echoes``
    The span of the echo points (the specular points of the first-echo model) of the
    readings the fitted curve explains (range residual at most ``tol``), from the
    ``q``-th to the ``(100 - q)``-th percentile.
``ends``
    Split the explained and unexplained readings' echo points into slices of about
    :data:`SLICE_READINGS` readings along x and drop end slices, from each end inwards,
    while their median range residual is above the median of all by more than ``k``
    MADs.

A cut never keeps less than :data:`COVERAGE_FLOOR` of the winner's columns with points
(a profile that wins by reporting almost nothing is no better): below it nothing is cut.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.fit import Fit, FitFailure
from sonarproc.methods.base import Beams
from sonarproc.methods.echo_model import first_echo
from sonarproc.metrics import Bins

__all__ = [
    "COVERAGE_FLOOR",
    "SLICE_READINGS",
    "SUPPORT_WINDOW",
    "EndCut",
    "echo_points",
    "span_by_echoes",
    "span_by_end_residuals",
    "span_by_support",
]

FloatArray = npt.NDArray[np.float64]

#: A cut keeps at least this fraction of the winner's columns with points, or none is made.
COVERAGE_FLOOR = 0.7
#: Running mean (cells) of the column support of the ``support`` rule.
SUPPORT_WINDOW = 11
#: Readings per slice of the ``ends`` rule (about).
SLICE_READINGS = 40


@dataclass(frozen=True)
class EndCut:
    """The x-span kept of a profile, and why.

    Attributes
    ----------
    rule : str
        The rule that set the span.
    x0, x1 : float
        The span kept (m).
    columns : int
        The profile's columns with points before the cut.
    kept : int
        Those inside ``[x0, x1]``.
    reason : str
        One line for people.
    """

    rule: str
    x0: float
    x1: float
    columns: int
    kept: int
    reason: str

    @property
    def fraction(self) -> float:
        """Fraction of the columns with points kept."""
        return self.kept / self.columns if self.columns else 1.0

    @property
    def cuts(self) -> bool:
        """Whether anything was cut."""
        return self.kept < self.columns

    def to_json(self) -> dict[str, Any]:
        """JSON-ready record (``auto.cut`` of report.json)."""
        return {
            "rule": self.rule,
            "x_range_m": [round(self.x0, 4), round(self.x1, 4)],
            "columns": self.columns,
            "columns_kept": self.kept,
            "reason": self.reason,
        }


def make_cut(rule: str, bins: Bins, span: tuple[float, float] | None, why: str) -> EndCut:
    """The :class:`EndCut` of ``span`` on the columns of ``bins`` (None or under the
    coverage floor: the whole span of the columns with points, nothing cut).

    Examples
    --------
    >>> b = Bins(np.arange(10.0), np.ones(10, int), np.zeros(10), np.zeros(10))
    >>> c = make_cut("support", b, (1.5, 9.0), "thin ends")
    >>> (c.x0, c.x1, c.kept, c.columns)
    (1.5, 9.0, 8, 10)
    >>> make_cut("support", b, (4.0, 6.0), "thin ends").cuts
    False
    """
    occ = np.flatnonzero(bins.occupied)
    if occ.size == 0:
        return EndCut(rule, 0.0, 0.0, 0, 0, "no columns with points")
    x = bins.centres[occ]
    whole = EndCut(rule, float(x[0]), float(x[-1]), occ.size, occ.size, "nothing cut")
    if span is None:
        return whole
    x0, x1 = max(span[0], float(x[0])), min(span[1], float(x[-1]))
    kept = int(np.count_nonzero((x >= x0) & (x <= x1)))
    if kept >= occ.size:
        return whole
    if kept < COVERAGE_FLOOR * occ.size:
        return EndCut(
            rule, whole.x0, whole.x1, occ.size, occ.size,
            f"nothing cut: {why} would keep {kept / occ.size:.0%} of the columns "
            f"(at least {COVERAGE_FLOOR:.0%})",
        )  # fmt: skip
    return EndCut(rule, x0, x1, occ.size, kept, why)


def span_by_support(bins: Bins, frac: float) -> tuple[float, float] | None:
    """Columns whose running-mean support is at least ``frac`` of the median (first to last).

    Examples
    --------
    >>> count = np.r_[np.ones(20, int), np.full(60, 10), np.ones(20, int)]
    >>> b = Bins(np.arange(100.0), count, np.zeros(100), np.zeros(100))
    >>> lo, hi = span_by_support(b, 0.5)
    >>> bool(14 <= lo <= 20 and 79 <= hi <= 85)
    True
    """
    c = bins.count.astype(np.float64)
    if not (c > 0).any():
        return None
    w = np.ones(SUPPORT_WINDOW) / SUPPORT_WINDOW
    smooth = np.convolve(c, w, mode="same")
    good = np.flatnonzero((smooth >= frac * float(np.median(smooth[c > 0]))) & (c > 0))
    if good.size == 0:
        return None
    return float(bins.centres[good[0]]), float(bins.centres[good[-1]])


def echo_points(
    fit: Fit, beams: Beams, rows: npt.NDArray[np.intp], step: float, *, max_samples: int = 500
) -> tuple[FloatArray, FloatArray]:
    """Each reading's predicted path and the x of its echo point on the fitted curve.

    The first-echo model of :func:`sonarproc.methods.echo_model.first_echo_path` (the
    ``k``-th shortest stationary path inside both beams, for echo rank ``k``), keeping
    where on the curve the echo comes from. NaN where the curve misses the beams.
    """
    nan = np.full(rows.size, np.nan)
    if isinstance(fit, FitFailure) or not hasattr(fit, "domain") or rows.size == 0:
        return nan, nan.copy()
    lo, hi = fit.domain
    pts = fit.sample(max(step, (hi - lo) / max_samples))
    if pts.shape[0] < 3:
        return nan, nan.copy()
    p = beams.poses
    path, at = first_echo(
        p.tx_xy[rows], p.tx_heading[rows], p.tx_half_beamwidth[rows],
        p.rx_xy[rows], p.rx_heading[rows], p.rx_half_beamwidth[rows],
        pts, np.asarray(beams.readings["echo"][rows], dtype=np.intp),
    )  # fmt: skip
    return path, np.where(at >= 0, pts[np.maximum(at, 0), 0], np.nan)


def span_by_echoes(
    echo_x: FloatArray, loss: FloatArray, tol: float, q: float
) -> tuple[float, float] | None:
    """The ``q``-th to ``(100 - q)``-th percentile of the echo x of readings with loss <= tol.

    Examples
    --------
    >>> x = np.linspace(0.0, 10.0, 101)
    >>> loss = np.where(x > 8.0, 0.05, 0.002)
    >>> span_by_echoes(x, loss, 0.01, 0.0)
    (0.0, 8.0)
    """
    good = np.isfinite(echo_x) & (loss <= tol)
    if np.count_nonzero(good) < 3:
        return None
    lo, hi = np.percentile(echo_x[good], [q, 100.0 - q])
    return float(lo), float(hi)


def span_by_end_residuals(
    echo_x: FloatArray, loss: FloatArray, k: float, per_slice: int = SLICE_READINGS
) -> tuple[float, float] | None:
    """Drop end slices (of about ``per_slice`` readings along x) whose median loss is above
    the median of all by more than ``k`` MADs; the span of the slices left.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = np.sort(rng.uniform(0.0, 10.0, 400))
    >>> loss = np.where(x > 9.0, 0.04, 0.0) + rng.uniform(0.0, 0.004, 400)
    >>> lo, hi = span_by_end_residuals(x, loss, 3.0)
    >>> bool(lo < 0.5 and 8.5 < hi < 9.5)
    True
    """
    have = np.isfinite(echo_x)
    x, r = echo_x[have], loss[have]
    n = x.size
    slices = n // per_slice
    if slices < 3:
        return None
    order = np.argsort(x)
    x, r = x[order], r[order]
    edges = np.linspace(0, n, slices + 1).astype(np.intp)
    med = np.array([np.median(r[a:b]) for a, b in itertools.pairwise(edges)])
    centre = float(np.median(r))
    mad = float(np.median(np.abs(r - centre))) * 1.4826
    bad = med > centre + k * max(mad, 1e-12)
    first = int(np.argmin(bad)) if not bad.all() else slices
    last = slices - 1 - int(np.argmin(bad[::-1])) if not bad.all() else -1
    if first > last:
        return None
    return float(x[edges[first]]), float(x[edges[last + 1] - 1])

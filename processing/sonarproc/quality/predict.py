"""Which path length the run's map predicts for a reading, and which surface gives it.

The map is the run's fitted surfaces (one polyline each) or, for a profile fit, the one
fitted curve. Every reading is predicted with the first-echo model of ``--auto``
(:func:`sonarproc.methods.echo_model.first_echo_path`: the nearest specular point inside
both beams, the ellipse path for a bistatic pair). With several surfaces, each gives its
own first echo; a reading of echo rank ``k`` is the ``k``-th shortest of them, and the
surface that gives it is the reading's surface.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from sonarproc.fit import Fit, FitFailure
from sonarproc.methods.echo_model import beam_x_bounds, first_echo_path
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams

if TYPE_CHECKING:
    from sonarproc.surfaces import SurfaceSet

__all__ = ["MapCurves", "curves_of", "map_curves", "monotone_pieces", "predict_paths", "resample"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Spacing of the points a curve is sampled at for the prediction (m), at least. The
#: nearest sample to a specular point lies within half a spacing of it, so the path errs
#: by about ``spacing**2 / (4 r)``: 0.3 mm at a range of 0.3 m, well below the 5 cm
#: a reading must be explained within.
SAMPLE_SPACING = 0.02
#: Most samples of one curve: a longer curve is sampled more coarsely (bounds the cost).
MAX_SAMPLES = 4000


@dataclass(frozen=True, eq=False)
class MapCurves:
    """The curves a run's map predicts readings from.

    Attributes
    ----------
    curves : list of ndarray (K, 2)
        Points in order along each curve (m).
    surface : list of int
        Each curve's surface id in ``report.json`` (``0`` for a profile fit).
    single : bool
        The map is one curve that may give a reading several echoes (a profile fit):
        a reading's echo rank then picks among that curve's specular points.
    """

    curves: list[FloatArray]
    surface: list[int]
    single: bool

    @property
    def empty(self) -> bool:
        """The map has no curve to predict from (a failed fit, no surface)."""
        return not self.curves


def resample(line: FloatArray, spacing: float) -> FloatArray:
    """``line`` with points every ``spacing`` (m) or closer, at most :data:`MAX_SAMPLES`.

    Examples
    --------
    >>> resample(np.array([[0.0, 0.0], [1.0, 0.0]]), 0.25)[:, 0].tolist()
    [0.0, 0.25, 0.5, 0.75, 1.0]
    """
    seg = np.hypot(*np.diff(line, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    if s[-1] <= 0:
        return line
    n = min(MAX_SAMPLES, max(3, int(np.ceil(s[-1] / spacing)) + 1))
    t = np.linspace(0.0, s[-1], n)
    return np.column_stack((np.interp(t, s, line[:, 0]), np.interp(t, s, line[:, 1])))


def map_curves(result: RunResult) -> MapCurves:
    """The run's map as curves: its fitted surfaces, or its profile (none if it failed).

    Point features (a corner or an edge: one point) and failed surfaces predict nothing.
    """
    return curves_of(result.surfaces, result.fit, result.grid.cell)


def curves_of(surfaces: SurfaceSet | None, fit: Fit, cell: float) -> MapCurves:
    """:func:`map_curves` of a fit's parts: its surfaces (if any, they are the map) or its
    profile ``fit``, sampled at :data:`SAMPLE_SPACING` or the cell size ``cell``."""
    spacing = max(SAMPLE_SPACING, cell)
    if surfaces is not None:
        curves, ids = [], []
        for k, s in enumerate(surfaces.surfaces):
            line = np.asarray(s.polyline, dtype=np.float64).reshape(-1, 2)
            if s.ok and line.shape[0] >= 2:
                curves.append(resample(line, spacing))
                ids.append(k)
        return MapCurves(curves, ids, single=False)
    if isinstance(fit, FitFailure):
        return MapCurves([], [], single=True)
    curve = np.asarray(fit.sample(spacing), dtype=np.float64).reshape(-1, 2)
    if curve.shape[0] < 3:
        return MapCurves([], [], single=True)
    return MapCurves([resample(curve, spacing)], [0], single=True)


#: Most turn (rad) of a piece's direction from its first segment's: below 90 degrees, the
#: piece runs forward along that direction, so in a frame turned onto it the piece is a
#: profile y(x) and :func:`~sonarproc.methods.echo_model.first_echo` looks only at the
#: samples within each reading's beams.
PIECE_TURN = np.radians(60.0)


def monotone_pieces(curve: FloatArray) -> list[tuple[float, int, int]]:
    """``curve`` cut into pieces that each run forward along their first segment.

    Returns each piece's direction (rad) and its first and last sample; consecutive
    pieces share the sample at their cut.

    Examples
    --------
    >>> square = np.array([[0, 0], [1, 0], [2, 0], [2, 1], [2, 2]], dtype=float)
    >>> [(round(float(np.degrees(a))), i, j) for a, i, j in monotone_pieces(square)]
    [(0, 0, 2), (90, 2, 4)]
    """
    seg = np.diff(curve, axis=0)
    heading = np.arctan2(seg[:, 1], seg[:, 0])
    out: list[tuple[float, int, int]] = []
    start, m = 0, seg.shape[0]
    while start < m:
        turn = np.abs((heading[start:] - heading[start] + np.pi) % (2.0 * np.pi) - np.pi)
        bad = np.flatnonzero(turn >= PIECE_TURN)
        stop = start + int(bad[0]) if bad.size else m
        out.append((float(heading[start]), start, stop))
        start = stop
    return out


def _first_echo_pieces(ends: tuple[FloatArray, ...], curve: FloatArray) -> FloatArray:
    """The first-echo path off ``curve`` (inf where none): piece by piece, each in a frame
    turned onto it (:func:`monotone_pieces`), and each cut's sample with its two
    neighbours (a piece's end samples are never specular); the shortest of them.

    A piece is offered only the readings whose beams meet its band (:func:`_facing`):
    the others have no sample of it inside both beams, so no echo off it."""
    txy, th, thalf, rxy, rh, rhalf = ends
    best = np.full(th.shape, np.inf)
    pieces = monotone_pieces(curve)
    for angle, i, j in pieces:
        c, s = np.cos(angle), np.sin(angle)
        turn = np.array([[c, -s], [s, c]])  # row vectors times this: turned by -angle
        piece = curve[i : j + 1] @ turn
        t_xy, r_xy = txy @ turn, rxy @ turn
        rows = _facing(piece, (t_xy, th - angle, thalf), (r_xy, rh - angle, rhalf))
        if rows.size == 0:
            continue
        got = first_echo_path(t_xy[rows], th[rows] - angle, thalf[rows], r_xy[rows],
                              rh[rows] - angle, rhalf[rows], piece)  # fmt: skip
        best[rows] = np.fmin(best[rows], np.where(np.isfinite(got), got, np.inf))
    for _, i, _ in pieces[1:]:
        got = first_echo_path(txy, th, thalf, rxy, rh, rhalf, curve[i - 1 : i + 2])
        best = np.fmin(best, np.where(np.isfinite(got), got, np.inf))
    return best


def _facing(
    piece: FloatArray,
    tx: tuple[FloatArray, FloatArray, FloatArray],
    rx: tuple[FloatArray, FloatArray, FloatArray],
) -> IntArray:
    """The readings whose two beams can both hold a sample of ``piece`` (x increasing).

    Each beam's wedge is cut to the piece's band of y (:func:`beam_x_bounds`); a reading
    whose two x ranges share no stretch of the piece's x (widened by a sample spacing
    each side, for rounding at the wedges' edges) has no sample inside both beams."""
    ymin, ymax = float(piece[:, 1].min()), float(piece[:, 1].max())
    lo_t, hi_t = beam_x_bounds(*tx, ymin, ymax)
    lo_r, hi_r = beam_x_bounds(*rx, ymin, ymax)
    lo, hi = np.maximum(lo_t, lo_r), np.minimum(hi_t, hi_r)
    margin = float(np.max(np.diff(piece[:, 0]), initial=0.0))
    meet = (lo <= hi) & (hi >= piece[0, 0] - margin) & (lo <= piece[-1, 0] + margin)
    return np.flatnonzero(meet).astype(np.intp)


def predict_paths(curves: MapCurves, beams: Beams, rows: IntArray) -> tuple[FloatArray, IntArray]:
    """Path length the map predicts for readings ``rows``, and the surface that gives it.

    Returns
    -------
    path : ndarray, (n,)
        Predicted path length (m); NaN where no curve lies inside the reading's beams,
        or where the echo would come from beyond the receiver's maximum range.
    surface : ndarray of int, (n,)
        The surface id (:attr:`MapCurves.surface`) of each prediction; -1 where none.

    Examples
    --------
    >>> from sonarproc.methods.testing import flat_wall_beams
    >>> beams, _ = flat_wall_beams(10)
    >>> wall = np.array([[-1.0, 1.0], [3.0, 1.0]])
    >>> far = np.array([[-1.0, 3.0], [3.0, 3.0]])
    >>> mc = MapCurves([resample(far, 0.01), resample(wall, 0.01)], [4, 7], single=False)
    >>> path, surface = predict_paths(mc, beams, np.arange(3))
    >>> bool(np.allclose(path, beams.path[:3], atol=1e-3)), surface.tolist()
    (True, [7, 7, 7])
    """
    n = rows.size
    if curves.empty or n == 0:
        return np.full(n, np.nan), np.full(n, -1, dtype=np.intp)
    path, surface = _predict(curves, beams, rows)
    # the sonar reports no range beyond its maximum: an echo predicted from further away
    # is no echo, not a range to compare with the one measured
    heard = path <= 2.0 * np.asarray(beams.poses.max_range[rows], dtype=np.float64)
    return np.where(heard, path, np.nan), np.where(heard, surface, -1).astype(np.intp)


def _predict(curves: MapCurves, beams: Beams, rows: IntArray) -> tuple[FloatArray, IntArray]:
    n = rows.size
    p = beams.poses
    rank = np.asarray(beams.readings["echo"][rows], dtype=np.intp)
    ends = (p.tx_xy[rows], p.tx_heading[rows], p.tx_half_beamwidth[rows],
            p.rx_xy[rows], p.rx_heading[rows], p.rx_half_beamwidth[rows])  # fmt: skip
    if curves.single:
        path = first_echo_path(*ends, curves.curves[0], rank)
        found = np.isfinite(path)
        return np.where(found, path, np.nan), np.where(found, curves.surface[0], -1)
    paths = np.full((len(curves.curves), n), np.inf)
    for k, curve in enumerate(curves.curves):  # a handful of surfaces, each vectorised
        paths[k] = _first_echo_pieces(ends, curve)
    order = np.argsort(paths, axis=0, kind="stable")
    pick = order[np.clip(rank, 0, len(curves.curves) - 1), np.arange(n)]
    path = paths[pick, np.arange(n)]
    found = np.isfinite(path)
    ids = np.asarray(curves.surface, dtype=np.intp)[pick]
    return np.where(found, path, np.nan), np.where(found, ids, -1).astype(np.intp)

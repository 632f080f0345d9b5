"""Where each reading reflected: the specular echo points of readings on surfaces.

This is the package's one implementation of echo points: the surface refits use it, and
so can ``--auto`` with a profile sampled as a polyline, its readings as
:meth:`EchoGeometry.of_poses` (``rows`` maps the echoes back to the readings).

A sonar's range arc is tangent to the surface that reflected it, at the one point where
the surface's normal points at the sensor. For a surface and a reading:

* the *foot* of the reading on the surface is the surface point nearest its sensor (the
  perpendicular from the sensor, so the surface normal there points at the sensor);
* the reading *echoes* from the surface when its foot lies inside the surface (not at
  an end), inside the sensor's beam, and the foot's distance is within ``tol`` of the
  measured range; a reading echoing from several surfaces is given to the nearest match
  (a first echo comes from one surface);
* its *echo point* is the point at the measured range along the direction of the foot;
* the reading *sees through* the surface when its foot is inside the surface and inside
  its beam but its range reaches beyond every point of the surface in the beam (beyond
  ``d / cos(half beam) + tol`` for a foot at distance ``d``): a first echo from a surface
  standing there would have come back sooner. :func:`echo_points` counts only the
  readings its search finds (arcs ending near the surface, see below), a lower bound;
  :func:`count_seen_through` tests every reading.

All surfaces are tested at once. Candidate pairs come from radius searches (k-d trees,
:func:`sonarproc.surfaces.planar.search.pairs_within`) between the surfaces'
centres and the readings' arc midpoints (every point of an arc lies within its chord's
reach of the midpoint), surfaces and readings taken in
classes of similar size; cheap range and bearing tests go next; the feet on straight
surfaces are one closed-form projection for all pairs, those on curved ones a search of
the polyline per surface (:mod:`sonarproc.surfaces.planar.feet`).

Bistatic readings are taken at the midpoint of transmitter and receiver with the
ellipse's half minor axis as the range (exact for a surface parallel to the baseline).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.feet import (
    feet_on_polyline,
    feet_on_polylines,
    feet_on_segments,
    median_steps,
    straight_polylines,
)
from sonarproc.surfaces.planar.search import pairs_within

if TYPE_CHECKING:
    from sonarlog import TransducerPoses

__all__ = ["EchoGeometry", "SurfaceEchoes", "count_seen_through", "echo_points"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Straight surfaces are tested against every reading when surfaces x readings is at most
#: this (a long log's few walls); more go through the radius search.
DENSE_PAIRS = 1_000_000


@dataclass(frozen=True)
class EchoGeometry:
    """Each reading as one sensor: position, heading, half beam width, range (SI)."""

    xy: FloatArray
    heading: FloatArray
    half_beam: FloatArray
    range_m: FloatArray
    #: row of each reading in the arrays it was made from (:meth:`from_beams` drops the
    #: readings without a finite geometry); None when made directly
    rows: IntArray | None = None

    @classmethod
    def from_beams(
        cls,
        tx_xy: npt.ArrayLike,
        tx_heading: npt.ArrayLike,
        rx_xy: npt.ArrayLike,
        rx_heading: npt.ArrayLike,
        path: npt.ArrayLike,
        *,
        tx_half_beamwidth: npt.ArrayLike,
        rx_half_beamwidth: npt.ArrayLike,
    ) -> EchoGeometry:
        """From transmitter and receiver poses and path lengths (see the module notes).

        Examples
        --------
        >>> g = EchoGeometry.from_beams([[0.0, 0.0]], [0.0], [[0.0, 0.0]], [0.0], [2.0],
        ...                             tx_half_beamwidth=0.2, rx_half_beamwidth=0.2)
        >>> g.range_m.tolist(), g.xy.tolist()
        ([1.0], [[0.0, 0.0]])
        """
        t = np.asarray(tx_xy, dtype=np.float64).reshape(-1, 2)
        r = np.asarray(rx_xy, dtype=np.float64).reshape(-1, 2)
        n = t.shape[0]
        path_m = np.broadcast_to(np.asarray(path, dtype=np.float64), (n,))
        th = np.broadcast_to(np.asarray(tx_heading, dtype=np.float64), (n,))
        rh = np.broadcast_to(np.asarray(rx_heading, dtype=np.float64), (n,))
        if np.array_equal(t, r) and np.array_equal(th, rh):
            # every sensor hears its own echo (most logs): half the path, its own heading
            rng = 0.5 * path_m
            heading = np.arctan2(np.sin(th), np.cos(th))
        else:
            half_d = 0.5 * np.hypot(*(r - t).T)
            rng = np.sqrt(np.maximum((0.5 * path_m) ** 2 - half_d**2, 0.0))
            heading = np.arctan2(np.sin(th) + np.sin(rh), np.cos(th) + np.cos(rh))
        tb = np.broadcast_to(np.asarray(tx_half_beamwidth, dtype=np.float64), (n,))
        rb = np.broadcast_to(np.asarray(rx_half_beamwidth, dtype=np.float64), (n,))
        ok = np.isfinite(rng) & np.all(np.isfinite(t), axis=1) & np.all(np.isfinite(r), axis=1)
        return cls(0.5 * (t + r)[ok], heading[ok], np.minimum(tb, rb)[ok], rng[ok],
                   np.flatnonzero(ok))  # fmt: skip

    @classmethod
    def of_poses(cls, poses: TransducerPoses, path: npt.ArrayLike) -> EchoGeometry:
        """From a log's transducer poses and path lengths, as the pipeline and ``--auto`` hold them.

        Its ``rows`` are the rows of ``poses`` (readings without a finite geometry dropped).

        Examples
        --------
        >>> from sonarlog import TransducerPoses
        >>> xy, one = np.array([[0.0, 0.0], [np.nan, 0.0]]), np.full(2, 0.2)
        >>> poses = TransducerPoses(xy, np.zeros(2), xy, np.zeros(2), one, one,
        ...                         np.zeros(2), np.full(2, 5.0))
        >>> g = EchoGeometry.of_poses(poses, [2.0, 2.0])
        >>> g.range_m.tolist(), g.rows.tolist()
        ([1.0], [0])
        """
        return cls.from_beams(
            poses.tx_xy, poses.tx_heading, poses.rx_xy, poses.rx_heading, path,
            tx_half_beamwidth=poses.tx_half_beamwidth, rx_half_beamwidth=poses.rx_half_beamwidth,
        )  # fmt: skip

    @property
    def size(self) -> int:
        """Number of readings."""
        return int(self.range_m.size)

    @cached_property
    def axes(self) -> tuple[FloatArray, FloatArray]:
        """The cosine and the sine of every heading, computed once: screens by dot
        products ask them of every reading, many times a run."""
        return np.cos(self.heading), np.sin(self.heading)

    @cached_property
    def arcs(self) -> tuple[FloatArray, FloatArray]:
        """Each reading's arc: the chord of its beam (m; ``2 r sin(half / 2)``, the half
        beam at most a half turn) and its midpoint on the axis (N, 2), computed once
        (:func:`echo_points` asks them of every reading, many times a run)."""
        chord = 2.0 * self.range_m * np.sin(0.5 * np.minimum(self.half_beam, math.pi))
        mid = self.xy + self.range_m[:, None] * np.stack(self.axes, axis=1)
        return chord, mid

    def subset(self, keep: npt.NDArray[np.bool_]) -> EchoGeometry:
        """The readings where ``keep`` is true."""
        rows = None if self.rows is None else self.rows[keep]
        return EchoGeometry(self.xy[keep], self.heading[keep], self.half_beam[keep],
                            self.range_m[keep], rows)  # fmt: skip


class SurfaceEchoes(NamedTuple):
    """The readings that echo from one surface (see the module notes)."""

    #: indices into the :class:`EchoGeometry`, sorted by ``along``
    readings: IntArray
    #: their echo points, shape (E, 2)
    points: FloatArray
    #: arc length (m) of each foot along the surface's polyline
    along: FloatArray
    #: how many readings see through the surface
    seen_through: int


def echo_points(
    polylines: list[FloatArray],
    closed: list[bool],
    echoes: EchoGeometry,
    *,
    tol: float,
    spanned_from: int | None = None,
    spanned_over: float = 0.0,
) -> list[SurfaceEchoes]:
    """The readings that echo from each surface, their echo points and the feet's arc length.

    Parameters
    ----------
    polylines : list of ndarray, shape (K_i, 2)
        Surfaces sampled finely (every cell).
    closed : list of bool
        Whether each surface closes on itself.
    echoes : EchoGeometry
        The readings.
    tol : float
        Range tolerance (m).
    spanned_from : int, optional
        An open surface that at least this many readings echo from (before each goes to
        its best match) is seen through only by readings whose feet lie between the
        feet of its outermost echoes (default: anywhere on it). A fit runs on past the
        echoes over its ridge, and sound passing the end of a wall that many readings
        heard says where the wall ends (:mod:`sonarproc.surfaces.echoes.openings` cuts
        it there), not that it is not there; a phantom has few echoes.
    spanned_over : float
        ... and whose echoes' feet span at least this (m): echoes at one spot span no
        stretch to be seen through, and the readings beside it are then the only test
        of a surface there (default: any span).

    Returns
    -------
    list of SurfaceEchoes
        Per surface: indices into ``echoes``, echo points ``(E, 2)``, the arc length of
        each foot along the polyline (sorted by it), and how many readings see through it.

    Examples
    --------
    A wall along y = 1 and a sensor below it looking up, range 1.02 m: the echo point is
    on the wall although the range is 2 cm long.

    >>> wall = np.column_stack((np.linspace(-1, 1, 201), np.ones(201)))
    >>> g = EchoGeometry(np.zeros((1, 2)), np.array([np.pi / 2]), np.array([0.2]),
    ...                  np.array([1.02]))
    >>> (idx, pts, s, through), = echo_points([wall], [False], g, tol=0.05)
    >>> idx.tolist(), np.round(pts, 3).tolist(), through
    ([0], [[0.0, 1.02]], 0)
    """
    n, m = echoes.size, len(polylines)
    empty = SurfaceEchoes(np.zeros(0, np.intp), np.zeros((0, 2)), np.zeros(0), 0)
    polys = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in polylines]
    usable = np.array([p.shape[0] >= 2 for p in polys], dtype=bool)
    if n == 0 or not usable.any():
        return [empty for _ in range(m)]
    straight = straight_polylines(polys, usable)
    surf, read = _candidate_pairs(polys, usable, echoes, tol, straight)
    d = np.empty(surf.size)
    foot = np.empty((surf.size, 2))
    along = np.empty(surf.size)
    inside = np.empty(surf.size, dtype=bool)
    line = straight[surf]
    if line.any():
        d[line], foot[line], along[line], inside[line] = feet_on_segments(
            echoes.xy[read[line]], polys, surf[line]
        )
    if not line.all():
        d[~line], foot[~line], along[~line], inside[~line] = feet_on_polylines(
            echoes.xy[read[~line]], polys, surf[~line], list(closed)
        )
    v = foot - echoes.xy[read]
    off = np.abs(
        (np.arctan2(v[:, 1], v[:, 0]) - echoes.heading[read] + math.pi) % (2 * math.pi) - math.pi
    )
    rng = echoes.range_m[read]
    facing = inside & (off <= echoes.half_beam[read])
    ok = facing & (np.abs(d - rng) <= tol)
    beyond = facing & (rng > d / np.cos(echoes.half_beam[read]) + tol)
    if spanned_from is not None:
        # a surface many readings echo from is seen through only between its outermost
        # echoes' feet (module notes)
        count = np.bincount(surf[ok], minlength=m)
        lo, hi = np.full(m, np.inf), np.full(m, -np.inf)
        np.minimum.at(lo, surf[ok], along[ok])
        np.maximum.at(hi, surf[ok], along[ok])
        whole = (count[surf] < spanned_from) | np.asarray(closed, dtype=bool)[surf]
        whole |= (hi - lo < spanned_over)[surf]
        beyond &= whole | ((along >= lo[surf]) & (along <= hi[surf]))
    through = np.bincount(surf[beyond], minlength=m)
    resid = np.abs(d - rng)
    surf, read, resid, foot, along = surf[ok], read[ok], resid[ok], foot[ok], along[ok]
    # A first echo comes from one surface: each reading goes to its best match (the
    # lowest residual; ties to the lower surface index, as the stable sort keeps them).
    order = np.lexsort((surf, resid, read))
    first = np.ones(order.size, dtype=bool)
    first[1:] = read[order][1:] != read[order][:-1]
    best = order[first]
    surf, read, foot, along = surf[best], read[best], foot[best], along[best]
    v = foot - echoes.xy[read]
    unit = v / np.maximum(np.hypot(*v.T), 1e-12)[:, None]
    pts = echoes.xy[read] + unit * echoes.range_m[read][:, None]
    o = np.lexsort((read, along, surf))
    surf, read, pts, along = surf[o], read[o], pts[o], along[o]
    bounds = np.searchsorted(surf, np.arange(m + 1))
    return [
        SurfaceEchoes(read[bounds[i] : bounds[i + 1]], pts[bounds[i] : bounds[i + 1]],
                      along[bounds[i] : bounds[i + 1]], int(through[i]))
        for i in range(m)
    ]  # fmt: skip


def count_seen_through(
    polylines: list[FloatArray],
    closed: list[bool],
    echoes: EchoGeometry,
    *,
    tol: float,
    confirmed: list[FloatArray] | None = None,
) -> npt.NDArray[np.int64]:
    """How many readings see through each surface, every reading tested (module notes).

    Parameters
    ----------
    polylines : list of ndarray, shape (K_i, 2)
        Surfaces sampled finely (every cell).
    closed : list of bool
        Whether each surface closes on itself.
    echoes : EchoGeometry
        The readings.
    tol : float
        Range tolerance (m).
    confirmed : list of ndarray, shape (E_i, 2), optional
        Points known to lie on each surface (its echo points). An open surface is then
        tested only between the feet of its outermost confirmed points: a fit's ends
        are stretched beyond them, and sound passing the end of a box is not seen
        through it.

    Returns
    -------
    ndarray of int, shape (len(polylines),)

    Examples
    --------
    A sensor 1 m below a wall, looking at it, whose range is 3 m: it saw through.

    >>> wall = np.column_stack((np.linspace(-1, 1, 201), np.ones(201)))
    >>> g = EchoGeometry(np.zeros((1, 2)), np.array([np.pi / 2]), np.array([0.2]),
    ...                  np.array([3.0]))
    >>> count_seen_through([wall], [False], g, tol=0.05).tolist()
    [1]
    """
    out = np.zeros(len(polylines), dtype=np.int64)
    if echoes.size == 0:
        return out
    limit = echoes.range_m * np.cos(echoes.half_beam)  # range > d / cos + tol, without a division
    slack = tol * np.cos(echoes.half_beam)
    for i, (poly, cl) in enumerate(zip(polylines, closed, strict=True)):
        p = np.asarray(poly, dtype=np.float64).reshape(-1, 2)
        if p.shape[0] < 2:
            continue
        # only readings whose range reaches past the surface's nearest point can see through
        lo, hi = p.min(axis=0), p.max(axis=0)
        gap = np.hypot(*np.maximum(np.maximum(lo - echoes.xy, echoes.xy - hi), 0.0).T)
        cand = np.flatnonzero(limit - slack > gap)
        if cand.size == 0:
            continue
        q = echoes.xy[cand]
        d, foot, along, inside = _feet_on(q, p, bool(cl))
        if confirmed is not None and not cl and len(confirmed[i]):
            ends = _feet_on(np.asarray(confirmed[i], dtype=np.float64).reshape(-1, 2), p, cl)[2]
            inside &= (along >= ends.min()) & (along <= ends.max())
        v = foot - q
        off = np.abs(
            (np.arctan2(v[:, 1], v[:, 0]) - echoes.heading[cand] + math.pi) % (2 * math.pi)
            - math.pi
        )
        facing = inside & (off <= echoes.half_beam[cand])
        out[i] = int(np.count_nonzero(facing & (limit[cand] > d + slack[cand])))
    return out


def _feet_on(
    q: FloatArray, p: FloatArray, closed: bool
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_]]:
    """The feet of ``q`` on one polyline, straight or not."""
    if straight_polylines([p], np.ones(1, dtype=bool))[0]:
        return feet_on_segments(q, [p], np.zeros(q.shape[0], dtype=np.intp))
    return feet_on_polyline(q, p, closed)


def _candidate_pairs(
    polys: list[FloatArray],
    usable: npt.NDArray[np.bool_],
    echoes: EchoGeometry,
    tol: float,
    straight: npt.NDArray[np.bool_],
) -> tuple[IntArray, IntArray]:
    """(surface, reading) pairs that may echo, grouped by surface (cheap tests only)."""
    # Every point of a reading's arc band lies within ``reach`` of the arc's midpoint, so
    # a surface (a box of half-diagonal h round c) can only echo readings whose midpoint
    # is within h + reach of c: one ball query per surface instead of a test of every
    # reading (rooms logged for an hour hold 10^5 readings).
    chord, mid = echoes.arcs
    reach = chord + tol
    idx = np.flatnonzero(usable)
    lo = np.array([polys[i].min(axis=0) for i in idx]).reshape(-1, 2)
    hi = np.array([polys[i].max(axis=0) for i in idx]).reshape(-1, 2)
    c, h = 0.5 * (lo + hi), 0.5 * np.hypot(*(hi - lo).T)
    lines = straight[idx]
    if np.count_nonzero(lines) * echoes.size <= DENSE_PAIRS:
        # a few straight surfaces (a long log's walls): every pair is tested exactly for a
        # faced foot in range (far fewer pairs are left than a ball holds), then the ball
        k_l = np.flatnonzero(lines)
        s_l, r_l = _straight_pairs([polys[i] for i in idx[k_l]], echoes, tol)
        k_l = k_l[s_l]
        gap = mid[r_l] - c[k_l]
        ball = np.sqrt(np.einsum("ij,ij->i", gap, gap)) <= h[k_l] + reach[r_l]
        k_c, r_c = (
            _ball_pairs(c[~lines], h[~lines], mid, reach)
            if not lines.all()
            else (np.zeros(0, np.intp), np.zeros(0, np.intp))
        )
        k = np.concatenate((k_l[ball], np.flatnonzero(~lines)[k_c]))
        read = np.concatenate((r_l[ball], r_c))
    else:
        k, read = _ball_pairs(c, h, mid, reach)
    # The surface lies between |s - c| - h and |s - c| + h from a sensor s and, seen from
    # outside its disc (|s - c| > h), within asin(h / |s - c|) of the direction of c: the
    # foot can only be in range and in the beam if those intervals meet (cheap; most
    # readings of a big room fail it). From inside the disc (a robot in the bend of a
    # long curved or cornered surface) the surface may lie in any direction.
    to_c = c[k] - echoes.xy[read]
    dist = np.sqrt(np.einsum("ij,ij->i", to_c, to_c))
    keep = np.abs(dist - echoes.range_m[read]) <= h[k] + tol
    k, read, to_c, dist = k[keep], read[keep], to_c[keep], dist[keep]
    spread = np.where(
        dist > h[k], np.arcsin(np.minimum(h[k] / np.maximum(dist, 1e-12), 1.0)), math.pi
    )
    off_c = np.abs(
        (np.arctan2(to_c[:, 1], to_c[:, 0]) - echoes.heading[read] + math.pi) % (2 * math.pi)
        - math.pi
    )
    keep = off_c <= echoes.half_beam[read] + spread
    surf, read = idx[k[keep]], read[keep]
    o = np.argsort(surf, kind="stable")
    return surf[o], read[o]


def _straight_pairs(
    polys: list[FloatArray], echoes: EchoGeometry, tol: float
) -> tuple[IntArray, IntArray]:
    """(surface, reading) pairs of straight surfaces whose foot is inside, faced, in range.

    Every pair is tested: on a straight surface the foot is the perpendicular foot, and
    the sensor faces it when its heading is within its half beam of the normal pointing
    away from it (a sensor on the line itself is kept: its foot has no direction). These
    are conditions :func:`echo_points` puts on echoing and seeing-through pairs alike.
    """
    if not polys:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    a = np.array([p[0] for p in polys])
    chord = np.array([p[-1] - p[0] for p in polys])
    length = np.maximum(np.hypot(*chord.T), 1e-300)
    tangent = chord / length[:, None]
    half = 0.5 * median_steps(polys)[:, None]
    rel_x = echoes.xy[None, :, 0] - a[:, None, 0]
    rel_y = echoes.xy[None, :, 1] - a[:, None, 1]
    along = rel_x * tangent[:, None, 0] + rel_y * tangent[:, None, 1]
    # signed distance along the normal (-ty, tx)
    side = rel_y * tangent[:, None, 0] - rel_x * tangent[:, None, 1]
    keep = (along > half) & (along < length[:, None] - half)
    keep &= echoes.range_m[None, :] >= np.abs(side) - tol - 1e-9
    # the bearing test on the pairs left (the same arithmetic, pair by pair)
    surf, read = np.nonzero(keep)
    side = side[surf, read]
    # the foot lies along -side * normal: the normal's direction, turned by pi if side > 0
    normal_dir = np.arctan2(tangent[:, 0], -tangent[:, 1])
    foot_dir = normal_dir[surf] + np.where(side > 0, math.pi, 0.0)
    off = np.abs((foot_dir - echoes.heading[read] + math.pi) % (2 * math.pi) - math.pi)
    faced = (off <= echoes.half_beam[read] + 1e-9) | (np.abs(side) < 1e-9)
    return surf[faced].astype(np.intp), read[faced].astype(np.intp)


def _ball_pairs(
    c: FloatArray, h: FloatArray, mid: FloatArray, reach: FloatArray
) -> tuple[IntArray, IntArray]:
    """Pairs (surface k, reading j) with ``|mid_j - c_k| <= h_k + reach_j``.

    Readings are split into classes of similar reach (powers of two), so that each class
    is one radius search (:func:`~sonarproc.surfaces.planar.search.pairs_within`) with a
    radius per surface close to the pairs' own, ``h_k`` plus the class's largest reach
    (one reach for all would take every reading within the largest reach of every
    surface).
    """

    def classes(v: FloatArray) -> IntArray:
        return np.floor(np.log2(np.maximum(v, 0.125) / 0.125)).astype(np.intp)

    rc = classes(reach)
    ks: list[IntArray] = []
    js: list[IntArray] = []
    for b in np.unique(rc):
        rj = np.flatnonzero(rc == b)
        i, j, d2 = pairs_within(c, mid[rj], h + float(reach[rj].max()))
        jj = rj[j]
        keep = np.sqrt(d2) <= h[i] + reach[jj]
        ks.append(i[keep])
        js.append(jj[keep])
    return np.concatenate(ks), np.concatenate(js)

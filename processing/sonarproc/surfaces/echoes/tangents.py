"""Straight walls found from the readings themselves: a vote for the lines tangent to arcs.

A reading that reflected off a flat wall has its range arc tangent to the wall, at the
point where the wall's normal points at the sensor: for the direction ``phi`` of that
normal, ``u(phi) . s + r = rho`` (``s`` the sensor, ``r`` the range, ``u`` the unit
vector, ``rho`` the wall's distance from the origin along ``u``). Every reading votes,
for each direction ``phi`` inside its beam, for the line ``(phi, rho)``; the readings of
one wall all vote for the same line, those of different walls and chance crossings
spread their votes. This is the Hough transform of sonar tangents (Tardós et al., "Robust
mapping and localization in indoor environments using sonar data", IJRR 2002).

:func:`tangent_lines` finds the lines in rounds. Each round histograms the votes of the
readings not yet claimed, and takes the local maxima with at least ``min_votes`` votes,
strongest first: a line claims the readings whose tangent at its direction lies within
``tol`` of it (a first echo comes from one wall), and is kept if it still has
``min_votes`` of them. The side lobes of a strong line (its readings voting, through the
rest of their beams, for nearby directions) lose their readings to it; a weaker wall
next to a strong one, whose peak the strong one's lobes hid, comes out in the next round.
Each line is then cut into segments where its readings' echo points (the points at the
measured range along the normal) leave gaps wider than ``bridge_m``.

The cost is one histogram of ``readings x beam directions`` votes per round and a test of
the readings facing each peak: linear in the readings, where the arc map's chance
crossings, and the ridges they make, grow with the square of the readings per area.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.echoes.specular import EchoGeometry

__all__ = ["TangentSegment", "tangent_lines"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Direction step (rad) of the votes and the histogram.
STEP_RAD = math.radians(1.0)
#: Distance step (m) of the histogram.
RHO_STEP_M = 0.05
#: A peak is a maximum over this many bins each way (direction, distance).
PEAK_HALF_WINDOW = (2, 2)
#: The neighbours a peak is tested against, nearest first: most bins fail against one of
#: them, and the failed ones are dropped before the next test.
_PEAK_OFFSETS = sorted(
    (
        (dp, dr)
        for dp in range(-PEAK_HALF_WINDOW[0], PEAK_HALF_WINDOW[0] + 1)
        for dr in range(-PEAK_HALF_WINDOW[1], PEAK_HALF_WINDOW[1] + 1)
        if dp or dr
    ),
    key=lambda o: (abs(o[0]) + abs(o[1]), o),
)
#: Most peaks tested in one round, strongest first.
PEAKS_PER_ROUND = 64
#: Most rounds.
MAX_ROUNDS = 4
#: A segment is curved when its readings' range residuals bend by more than this (m)
#: between its middle and its ends (see :func:`_bends`).
BEND_M = 0.025


class TangentSegment(NamedTuple):
    """A stretch of a wall found by :func:`tangent_lines`."""

    #: unit normal, pointing away from the sensors that saw it
    normal: FloatArray
    #: distance (m) of the line from the world origin along ``normal``
    rho: float
    #: indices of its readings, sorted along the segment
    readings: IntArray
    #: their echo points, shape (E, 2)
    points: FloatArray
    #: arc length (m) of each echo point along the segment, from 0
    along: FloatArray
    #: where the segment starts along the line's direction (m, relative to the origin
    #: of the vote)
    start: float


def _votes(
    echoes: EchoGeometry, active: IntArray, origin: FloatArray, n_phi: int, half_rho: int
) -> npt.NDArray[np.int64]:
    """Histogram (direction bin, distance bin) of the active readings' tangent votes."""
    k = math.ceil(float(echoes.half_beam[active].max()) / STEP_RAD)
    heading = echoes.heading[active]
    half_beam = echoes.half_beam[active]
    nearest = np.rint(heading / STEP_RAD)
    centre = nearest.astype(np.intp) % n_phi
    # in polar form about the origin, the sensor's tangent at phi lies at
    # R cos(phi - beta) + r = a cos(j step) - b sin(j step) + r for phi = (centre + j) step:
    # two products per vote, no trigonometry
    s = echoes.xy[active] - origin
    scale = 1.0 / RHO_STEP_M
    start = nearest * STEP_RAD - np.arctan2(s[:, 1], s[:, 0])
    radius = np.hypot(s[:, 0], s[:, 1]) * scale
    a_cos, b_sin = radius * np.cos(start), radius * np.sin(start)
    lead = nearest * STEP_RAD - heading
    # the direction rows run from -k to n_phi + k (folded back below), so that a vote's
    # flat bin is an integer offset plus its rounded distance: one rint per vote
    width = 2 * half_rho + 1
    base = (centre + k) * width + echoes.range_m[active] * scale + half_rho
    flats = []
    for j in range(-k, k + 1):
        inside = np.abs(lead + j * STEP_RAD) <= half_beam
        rho = a_cos * math.cos(j * STEP_RAD) - b_sin * math.sin(j * STEP_RAD) + base
        flats.append(np.rint(rho[inside]).astype(np.intp) + j * width)
    rows = n_phi + 2 * k
    h = np.bincount(np.concatenate(flats), minlength=rows * width).reshape(rows, width)
    out = h[k : k + n_phi].copy()
    out[n_phi - k :] += h[:k]
    out[:k] += h[k + n_phi :]
    return out


def _peaks(h: npt.NDArray[np.int64], min_votes: int) -> tuple[IntArray, IntArray]:
    """Local maxima of ``h`` with at least ``min_votes``, strongest first (at most a round's).

    A bin is a maximum when no bin within :data:`PEAK_HALF_WINDOW` of it (directions wrap,
    distances do not) holds more. Only the bins with ``min_votes`` are tested, each
    against its neighbours: a few thousand of a histogram's hundreds of thousands of bins
    (and scipy.ndimage would cost a tenth of a second to import in a fresh process).
    """
    n_phi, width = h.shape
    pi, ri = np.nonzero(h >= min_votes)
    votes = h[pi, ri]
    for dp, dr in _PEAK_OFFSETS:
        cols = np.clip(ri + dr, 0, width - 1)  # (beyond the edge there is no bin to beat)
        keep = votes >= h[(pi + dp) % n_phi, cols]
        keep |= (ri + dr < 0) | (ri + dr >= width)
        pi, ri, votes = pi[keep], ri[keep], votes[keep]
    order = np.argsort(-votes, kind="stable")[:PEAKS_PER_ROUND]
    return pi[order], ri[order]


def _facing(by_heading: IntArray, heading_sorted: FloatArray, phi: float, reach: float) -> IntArray:
    """The readings (``by_heading`` sorts them by heading) looking within ``reach`` of ``phi``."""
    if reach >= math.pi:
        return by_heading
    lo = (phi - reach) % (2 * math.pi)
    hi = (phi + reach) % (2 * math.pi)
    a = int(np.searchsorted(heading_sorted, lo))
    b = int(np.searchsorted(heading_sorted, hi, side="right"))
    if lo <= hi:
        return by_heading[a:b]
    return np.concatenate((by_heading[a:], by_heading[:b]))


def tangent_lines(
    echoes: EchoGeometry,
    *,
    tol: float,
    min_votes: int,
    bridge_m: float,
    min_spread_m: float,
) -> tuple[list[TangentSegment], npt.NDArray[np.bool_]]:
    """Straight walls from the readings' tangent votes (see the module notes).

    Parameters
    ----------
    echoes : EchoGeometry
        The readings.
    tol : float
        A reading belongs to a line when its tangent at the line's direction lies within
        this distance (m) of the line.
    min_votes : int
        Fewest readings a line, and each of its segments, needs.
    bridge_m : float
        Echo points further apart than this (m) along a line start a new segment.
    min_spread_m : float
        Shortest segment (m) between its outermost echo points.

    Returns
    -------
    segments : list of TangentSegment
        The segments, each reading in at most one.
    claimed : ndarray of bool, shape (N,)
        The readings the segments explain: their own, and those whose arcs cross a
        segment inside their beams (diffuse echoes off it).

    Examples
    --------
    Sensors 1 m below a wall along y = 1, looking up, over 6 m of it:

    >>> x = np.linspace(-3.0, 3.0, 41)
    >>> g = EchoGeometry(np.column_stack((x, np.zeros_like(x))), np.full(41, np.pi / 2),
    ...                  np.full(41, 0.2), np.ones(41))
    >>> (seg,), claimed = tangent_lines(g, tol=0.03, min_votes=5, bridge_m=0.3,
    ...                                 min_spread_m=0.1)
    >>> np.round(seg.normal, 6).tolist(), round(seg.rho, 6), seg.readings.size
    ([0.0, 1.0], 1.0, 41)
    """
    n = echoes.size
    if n == 0:
        return [], np.zeros(0, dtype=bool)
    origin = echoes.xy.mean(axis=0)
    n_phi = round(2 * math.pi / STEP_RAD)
    reach = float(np.abs(echoes.xy - origin).max()) * math.sqrt(2) + float(echoes.range_m.max())
    half_rho = math.ceil(reach / RHO_STEP_M) + 1
    heading = echoes.heading % (2 * math.pi)
    by_heading = np.argsort(heading, kind="stable")
    heading_sorted = heading[by_heading]
    max_half = float(echoes.half_beam.max())
    claimed = np.zeros(n, dtype=bool)
    out: list[TangentSegment] = []
    for _ in range(MAX_ROUNDS):
        active = np.flatnonzero(~claimed)
        if active.size < min_votes:
            break
        h = _votes(echoes, active, origin, n_phi, half_rho)
        found = 0
        for pi, ri in zip(*_peaks(h, min_votes), strict=True):
            phi = float(pi) * STEP_RAD
            rho = float(ri - half_rho) * RHO_STEP_M
            cand = _facing(by_heading, heading_sorted, phi, max_half)
            cand = cand[~claimed[cand]]
            u = np.array([math.cos(phi), math.sin(phi)])
            off = np.abs((phi - echoes.heading[cand] + math.pi) % (2 * math.pi) - math.pi)
            cand = cand[off <= echoes.half_beam[cand]]
            d = rho - (echoes.xy[cand] - origin) @ u
            rng = echoes.range_m[cand]
            mine = cand[np.abs(rng - d) <= tol]
            if mine.size < min_votes:
                continue
            segs = _segments(echoes, origin, phi, rho, mine, min_votes, bridge_m, min_spread_m)
            if not segs:
                continue
            claimed[mine] = True
            # only a reading looking within a right angle (and its beam) of the normal can
            # cross the line in its beam
            near = _facing(by_heading, heading_sorted, phi, 0.5 * math.pi + max_half)
            near = near[~claimed[near]]
            claimed[_crossing(echoes, near, origin, u, rho, segs, tol, bridge_m)] = True
            out.extend(segs)
            found += 1
        if found == 0:
            break
    return out, claimed


def _crossing(
    echoes: EchoGeometry,
    idx: IntArray,
    origin: FloatArray,
    u: FloatArray,
    rho: float,
    segs: list[TangentSegment],
    tol: float,
    bridge_m: float,
) -> IntArray:
    """The readings ``idx`` whose arcs cross the line inside their beams, on or next to ``segs``.

    Such a reading may be a diffuse echo off the wall (it reached the wall there), and is
    no evidence of another surface: it votes no more.
    """
    t = np.array([-u[1], u[0]])
    s = echoes.xy[idx] - origin
    d = rho - s @ u
    rng = echoes.range_m[idx]
    front = (d > 0) & (rng >= d - tol)
    idx, s, d, rng = idx[front], s[front], d[front], rng[front]
    # the arc meets the line at +-acos(d / r) from the normal, +-sqrt(r^2 - d^2) along it
    ratio = np.minimum(d / rng, 1.0)
    half = np.arccos(ratio)
    reach = np.sqrt(np.maximum(rng**2 - d**2, 0.0))
    foot = s @ t
    phi = math.atan2(u[1], u[0])
    hit = np.zeros(idx.size, dtype=bool)
    where = np.full(idx.size, np.nan)
    for sign in (-1.0, 1.0):
        psi = phi + sign * half
        off = np.abs((psi - echoes.heading[idx] + math.pi) % (2 * math.pi) - math.pi)
        # the direction psi turns from the normal towards +t for sign > 0: so does the hit
        inside = (off <= echoes.half_beam[idx]) & ~hit
        where[inside] = foot[inside] + sign * reach[inside]
        hit |= inside
    return idx[_reached(where, segs, bridge_m)]


def _reached(
    where: FloatArray, segs: list[TangentSegment], bridge_m: float
) -> npt.NDArray[np.bool_]:
    """Which positions along the line join a segment through gaps of at most ``bridge_m``.

    The echo points end where the perpendiculars from the sensors end; the wall may go on
    (a diffuse echo off it at an angle, up to a corner).
    """
    ends = np.array([[g.start, g.start + float(g.along[-1])] for g in segs])
    ok = np.isfinite(where)
    pos = np.concatenate((where[ok], ends.ravel()))
    seg_mark = np.concatenate((np.zeros(int(ok.sum()), bool), np.ones(ends.size, bool)))
    order = np.argsort(pos)  # (equal positions fall in one cluster whatever their order)
    pos, seg_mark = pos[order], seg_mark[order]
    # positions inside a segment count as joined to it, whatever the gaps
    inner = np.zeros(pos.size, dtype=bool)
    for lo, hi in ends:
        inner |= (pos >= lo) & (pos <= hi)
    cluster = np.concatenate(([0], np.cumsum((np.diff(pos) > bridge_m) & ~inner[1:])))
    joined = np.zeros(int(cluster[-1]) + 1, dtype=bool)
    joined[cluster[seg_mark | inner]] = True
    back = np.empty_like(order)
    back[order] = np.arange(order.size)
    out = np.zeros(where.size, dtype=bool)
    out[ok] = joined[cluster[back[: int(ok.sum())]]]
    return out


def _bends(along: FloatArray, resid: FloatArray) -> bool:
    """Whether the readings' range residuals bend along the segment: a curved surface.

    Against a flat wall a reading's range minus its distance to the line is noise
    wherever it looks from; against a tangent of a pillar or a curved wall it falls off
    with the square of the distance from the tangent point.
    """
    a = along - along.mean()
    half = 0.5 * float(np.ptp(along))
    basis = np.column_stack((np.ones_like(a), a / half, (a / half) ** 2))
    coef, *_ = np.linalg.lstsq(basis, resid, rcond=None)
    return bool(abs(coef[2]) > BEND_M)


def _segments(
    echoes: EchoGeometry,
    origin: FloatArray,
    phi: float,
    rho: float,
    mine: IntArray,
    min_votes: int,
    bridge_m: float,
    min_spread_m: float,
) -> list[TangentSegment]:
    """The line's readings cut where their echo points leave gaps wider than ``bridge_m``."""
    u = np.array([math.cos(phi), math.sin(phi)])
    t = np.array([-u[1], u[0]])
    pts = echoes.xy[mine] + echoes.range_m[mine][:, None] * u
    a = (pts - origin) @ t
    order = np.argsort(a, kind="stable")
    mine, pts, a = mine[order], pts[order], a[order]
    resid = echoes.range_m[mine] - (rho - (echoes.xy[mine] - origin) @ u)
    cuts = np.flatnonzero(np.diff(a) > bridge_m) + 1
    out = []
    for lo, hi in zip(np.r_[0, cuts], np.r_[cuts, a.size], strict=True):
        if hi - lo < min_votes or a[hi - 1] - a[lo] < min_spread_m:
            continue
        if _bends(a[lo:hi], resid[lo:hi]):
            continue
        out.append(TangentSegment(u, rho + float(origin @ u), mine[lo:hi], pts[lo:hi],
                                  a[lo:hi] - a[lo], float(a[lo])))  # fmt: skip
    return out

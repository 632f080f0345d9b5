"""Sound does not pass through walls: of two surfaces that contradict, the weaker goes.

An echo travelled in a straight line from the sensor to its echo point and back, so no
surface can stand across that path. When the echo paths of surface ``a`` cross surface
``b``, one of them is wrong: either ``a`` is a phantom seen through ``b`` (the double
reflections of a room's corner arrive late and map to points behind the walls), or ``b``
is a phantom standing in free space that the sound crossed. Where at least
:data:`MIN_CROSSINGS` paths of one surface cross another, the surface with fewer echoes
is dropped; the strongest contradictions are settled first. A path's last
:data:`END_MARGIN_M` are not tested, so that surfaces meeting at a corner do not
contradict each other. A surface's ends are uncertain (a fit is stretched over its ridge
by up to :data:`~sonarproc.surfaces.echoes.refine.MAX_STRETCH_M`): crossings within
:data:`END_ZONE_M` of its ends do not make it lose, though they still count against the
surface whose paths they are (a phantom seen through a wall near a corner). The paths run
to the feet on the surfaces as they stand (:func:`path_ends`).

A concave corner retro-reflects and an edge diffracts towards every sensor with it in its
beam. When at least :data:`POINT_SHARE` of the readings of ``a`` have the range, within
:data:`CORNER_RANGE_TOL_M`, of one point at an end of ``b`` or on ``b``'s line up to
:data:`CORNER_REACH_M` beyond an end (where ``b``'s corner would be, found short of it as
below), ``a`` is that point's arc, not a plane; those of its paths that cross ``b`` are
the point's echoes, no evidence that the sound crossed ``b`` (:func:`corner_echoes`). A
plane fitted through a corner's retro-echoes from one pass stands tilted behind the
corner's wall; its paths cross the wall's middle but do not make the wall lose.

Walls seen from the middle of a room are found short of its corners: the readings near a
corner echo from its double reflections, not from the walls. The late echoes of those
reflections map to phantoms just behind the corner, and their paths pass between the
walls' ends. So two straight surfaces at least :data:`CORNER_MIN_LENGTH_M` long that
would meet at an angle of at least :data:`CORNER_MIN_DEG` within
:data:`CORNER_REACH_M` of both are completed to their corner for this test
(:func:`corner_extensions`); a path crossing such an extension counts against its own
surface only, as crossings near an end do.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.feet import feet_on_polylines, straight_polylines

__all__ = [
    "CORNER_MIN_DEG", "CORNER_MIN_LENGTH_M", "CORNER_RANGE_TOL_M", "CORNER_REACH_M",
    "END_MARGIN_M", "END_ZONE_M", "MIN_CROSSINGS", "POINT_SHARE", "contradicted",
    "corner_candidates", "corner_echoes", "corner_extensions", "path_ends",
    "segment_crossings",
]  # fmt: skip

FloatArray = npt.NDArray[np.float64]

#: Echo paths of one surface that must cross another before the two contradict.
MIN_CROSSINGS = 3
#: The end of each echo path (m) left out of the test.
END_MARGIN_M = 0.15
#: Crossings this close (m) to a surface's ends do not make it lose.
END_ZONE_M = 0.30
#: Straight surfaces at least this long (m) are completed to the corners they would make...
CORNER_MIN_LENGTH_M = 1.0
#: ... with another at an angle of at least this (degrees)...
CORNER_MIN_DEG = 45.0
#: ... when the corner is at most this far (m) beyond the end of each.
CORNER_REACH_M = 1.0
#: A reading this close (m) in range to a surface's corner or edge may be its echo:
#: the robot's 1-inch range steps (+-1.27 cm), a few mm of noise and the time walk of a
#: weak corner echo (up to about 1.5 cm long, Kleeman & Kuc 1995) add up to it (the
#: point reflectors' gathering tolerance,
#: :data:`sonarproc.surfaces.reflectors.range_models.RANGE_TOL_M`).
CORNER_RANGE_TOL_M = 0.03
#: The share of a surface's readings one point must explain for it to be that point's arc:
#: a plane's echoes come from feet spread along it, and one point's distance matches
#: their ranges only where the foot is near it, so a plane heard from more than a
#: stretch of its length keeps most readings unexplained.
POINT_SHARE = 0.5
#: Echo paths tested against all segments at once, at most (bounds the memory).
_CHUNK = 4096


def _segments(
    polyline: FloatArray, step: int, straight: bool
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Segments of a polyline thinned to every ``step``-th vertex (ends kept), and the
    arc length of each segment's start; a straight polyline is one segment."""
    p = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
    if straight:
        return p[:1], p[-1:], np.zeros(1)
    keep = np.unique(np.r_[np.arange(0, len(p), max(step, 1)), len(p) - 1])
    q = p[keep]
    s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(q, axis=0).T))))
    return q[:-1], q[1:], s[:-1]


def _straight(polys: list[FloatArray]) -> npt.NDArray[np.bool_]:
    return straight_polylines(polys, np.array([len(p) >= 2 for p in polys], dtype=bool))


def corner_extensions(
    polylines: list[FloatArray], *, straight: npt.NDArray[np.bool_] | None = None
) -> tuple[npt.NDArray[np.intp], FloatArray, FloatArray]:
    """The stretches that complete long straight surfaces to their corners (module notes).

    ``straight``: which polylines are straight, if known
    (:func:`~sonarproc.surfaces.planar.feet.straight_polylines`).

    Returns
    -------
    owner : ndarray of int, shape (X,)
        The surface each stretch extends.
    start, end : ndarray, shape (X, 2)
        The stretch: from the surface's end to the corner.

    Examples
    --------
    Two walls of a room found 0.6 m short of their corner at the origin:

    >>> bottom = np.array([[0.6, 0.0], [4.0, 0.0]]); left = np.array([[0.0, 4.0], [0.0, 0.6]])
    >>> owner, start, end = corner_extensions([bottom, left])
    >>> owner.tolist(), start.tolist(), np.round(end, 9).tolist()
    ([0, 1], [[0.6, 0.0], [0.0, 0.6]], [[0.0, 0.0], [0.0, 0.0]])
    """
    polys = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in polylines]
    if straight is None:
        straight = _straight(polys)
    idx = np.array(
        [i for i, p in enumerate(polys)
         if straight[i] and float(np.hypot(*(p[-1] - p[0]))) >= CORNER_MIN_LENGTH_M],
        dtype=np.intp,
    )  # fmt: skip
    none = (np.zeros(0, np.intp), np.zeros((0, 2)), np.zeros((0, 2)))
    if idx.size < 2:
        return none
    a = np.array([polys[i][0] for i in idx])
    b = np.array([polys[i][-1] for i in idx])
    length = np.hypot(*(b - a).T)
    d = (b - a) / length[:, None]
    i, j = np.triu_indices(idx.size, k=1)
    den = d[i, 0] * d[j, 1] - d[i, 1] * d[j, 0]
    corner = np.abs(den) >= np.sin(np.radians(CORNER_MIN_DEG))
    i, j, den = i[corner], j[corner], den[corner]
    w = a[j] - a[i]
    t = (w[:, 0] * d[j, 1] - w[:, 1] * d[j, 0]) / den  # along i, from its first point
    u = (w[:, 0] * d[i, 1] - w[:, 1] * d[i, 0]) / den  # along j
    gap_i = np.maximum(np.maximum(-t, t - length[i]), 0.0)
    gap_j = np.maximum(np.maximum(-u, u - length[j]), 0.0)
    near = (gap_i <= CORNER_REACH_M) & (gap_j <= CORNER_REACH_M)
    owners, starts, ends = [], [], []
    for k, along, gap in ((i, t, gap_i), (j, u, gap_j)):
        sel = near & (gap > 0)
        kk, tt = k[sel], along[sel]
        end = a[kk] + d[kk] * tt[:, None]
        start = np.where((tt < 0)[:, None], a[kk], b[kk])
        owners.append(idx[kk])
        starts.append(start)
        ends.append(end)
    return np.concatenate(owners), np.concatenate(starts), np.concatenate(ends)


def segment_crossings(
    a0: FloatArray, a1: FloatArray, b0: FloatArray, b1: FloatArray
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp], FloatArray]:
    """Proper crossings of segments ``a0 a1`` (rows) with ``b0 b1`` (columns).

    Returns the row and column of every crossing and how far along its ``b`` segment
    (0 to 1) it lies.
    """
    # direct differences (no precomputed directions), so that touching ends give
    # orientations of exactly 0; coordinates broadcast (rows, 1) against (1, cols)
    ax0, ay0, ax1, ay1 = (v[:, None] for v in (a0[:, 0], a0[:, 1], a1[:, 0], a1[:, 1]))
    bx0, by0, bx1, by1 = (v[None, :] for v in (b0[:, 0], b0[:, 1], b1[:, 0], b1[:, 1]))
    dax, day = ax1 - ax0, ay1 - ay0
    s1 = np.sign(dax * (by0 - ay0) - day * (bx0 - ax0))
    s2 = np.sign(dax * (by1 - ay0) - day * (bx1 - ax0))
    # b's ends on both sides of a's line first (few pairs), then a's ends about b's line
    rows, cols = np.nonzero(s1 * s2 < 0)
    p0, p1, q0 = a0[rows], a1[rows], b0[cols]
    dq = b1[cols] - q0
    s3 = np.sign(dq[:, 0] * (p0[:, 1] - q0[:, 1]) - dq[:, 1] * (p0[:, 0] - q0[:, 0]))
    s4 = np.sign(dq[:, 0] * (p1[:, 1] - q0[:, 1]) - dq[:, 1] * (p1[:, 0] - q0[:, 0]))
    both = s3 * s4 < 0
    rows, cols = rows[both], cols[both]
    # a0 + t da = b0 + u db  ->  u = cross(a0 - b0, da) / cross(db, da)
    da = (a1 - a0)[rows]
    db = (b1 - b0)[cols]
    ab = a0[rows] - b0[cols]
    u = (ab[:, 0] * da[:, 1] - ab[:, 1] * da[:, 0]) / (db[:, 0] * da[:, 1] - db[:, 1] * da[:, 0])
    return rows, cols, u


def corner_candidates(polyline: FloatArray, straight: bool, *, cell: float) -> FloatArray:
    """Where a surface's corner or edge may be: its ends and, if straight, its line every
    ``cell`` up to :data:`CORNER_REACH_M` beyond each end (module notes).

    Examples
    --------
    >>> corner_candidates(np.array([[0.0, 0.0], [1.0, 0.0]]), True, cell=0.5).tolist()
    [[0.0, 0.0], [-0.5, 0.0], [-1.0, 0.0], [1.0, 0.0], [1.5, 0.0], [2.0, 0.0]]
    """
    p = np.asarray(polyline, dtype=np.float64).reshape(-1, 2)
    if len(p) < 2 or not straight:
        return p[[0, -1]] if len(p) else p
    d = p[-1] - p[0]
    d /= max(float(np.hypot(*d)), 1e-12)
    step = np.arange(0.0, CORNER_REACH_M + cell / 2, cell)[:, None]
    return np.concatenate((p[0] - step * d, p[-1] + step * d))


def corner_echoes(
    sensors: FloatArray, ranges: FloatArray, candidates: FloatArray
) -> npt.NDArray[np.bool_]:
    """Which readings one point among ``candidates`` explains (module notes).

    Parameters
    ----------
    sensors : ndarray, shape (E, 2)
        Where each reading was sensed from.
    ranges : ndarray, shape (E,)
        Its range (m).
    candidates : ndarray, shape (C, 2)
        Where the point may be (:func:`corner_candidates`).

    Returns
    -------
    ndarray of bool, shape (E,)
        The readings whose range is within :data:`CORNER_RANGE_TOL_M` of their distance
        to the candidate that explains the most of them, if it explains at least
        :data:`MIN_CROSSINGS` and :data:`POINT_SHARE` of them; else none.

    Examples
    --------
    A corner at (8, 6) heard on a pass northwards along x = 7, and a reading 0.5 m long:

    >>> y = np.array([1.0, 2.0, 3.0, 3.5])
    >>> r = np.hypot(1.0, 6.0 - y) + np.array([0.0, 0.01, -0.01, 0.5])
    >>> corner_echoes(np.c_[7 + 0 * y, y], r, np.array([[8.0, 5.0], [8.0, 6.0]])).tolist()
    [True, True, True, False]
    """
    q = np.asarray(sensors, dtype=np.float64).reshape(-1, 2)
    c = np.asarray(candidates, dtype=np.float64).reshape(-1, 2)
    none = np.zeros(q.shape[0], dtype=bool)
    if q.shape[0] < MIN_CROSSINGS or c.shape[0] == 0:
        return none
    dist = np.hypot(q[:, None, 0] - c[None, :, 0], q[:, None, 1] - c[None, :, 1])
    near = np.abs(dist - np.asarray(ranges, dtype=np.float64).reshape(-1, 1)) <= CORNER_RANGE_TOL_M
    count = near.sum(axis=0)
    best = int(np.argmax(count))
    enough = count[best] >= max(MIN_CROSSINGS, POINT_SHARE * q.shape[0])
    return near[:, best] if enough else none


def path_ends(
    polylines: list[FloatArray], closed: list[bool], sensors: list[FloatArray],
    ranges: list[FloatArray],
) -> list[FloatArray]:  # fmt: skip
    """Each surface's echo points as it stands: its readings' ranges along the directions
    of their feet on it (the paths :func:`contradicted` tests).

    A refinement gathers its echo points along the feet on the geometry of the round
    before (a ridge's arc, whose normals turn across the beams by up to their half
    width); the sound went to the foot on the surface refitted through them. Paths
    tilted by the old geometry pass through what the sound did not (the jambs of the
    doorway a wall behind it was heard through).

    Examples
    --------
    A wall y = 2 heard by a sensor at (0.3, 0), range 2 m: the path runs straight up.

    >>> wall = np.column_stack((np.linspace(-1, 1, 201), np.full(201, 2.0)))
    >>> ends = path_ends([wall], [False], [np.array([[0.3, 0.0]])], [np.array([2.0])])
    >>> np.round(ends[0], 9).tolist()
    [[0.3, 2.0]]
    """
    out = []
    for p, cl, q, r in zip(polylines, closed, sensors, ranges, strict=True):
        q = np.asarray(q, dtype=np.float64).reshape(-1, 2)
        if q.shape[0] == 0 or len(p) < 2:
            out.append(q.copy())
            continue
        _, foot, _, _ = feet_on_polylines(q, [np.asarray(p, dtype=np.float64)],
                                          np.zeros(q.shape[0], np.intp), [bool(cl)])  # fmt: skip
        v = foot - q
        v /= np.maximum(np.hypot(v[:, 0], v[:, 1]), 1e-12)[:, None]
        out.append(q + np.asarray(r, dtype=np.float64).reshape(-1, 1) * v)
    return out


def contradicted(
    polylines: list[FloatArray],
    sensors: list[FloatArray],
    points: list[FloatArray],
    *,
    cell: float,
) -> list[int]:
    """Indices of the surfaces to drop (see the module notes).

    Parameters
    ----------
    polylines : list of ndarray, shape (K_i, 2)
        The surfaces, sampled every cell.
    sensors, points : list of ndarray, shape (E_i, 2)
        Each surface's echoes: where each was sensed from and its echo point.
    cell : float
        Cell size (m) of the polylines' sampling; curved ones are tested on chords of
        five samples.

    Returns
    -------
    list of int
        Sorted indices of the surfaces that lose a contradiction.

    Examples
    --------
    A wall y = 1 with 30 echoes from below, and a phantom line at y = 1.5 whose five
    echo paths pass through the wall: the phantom goes.

    >>> x = np.linspace(-1, 1, 201)
    >>> wall, phantom = np.c_[x, 1 + 0 * x], np.c_[x, 1.5 + 0 * x]
    >>> xs = np.linspace(-0.9, 0.9, 30); xp = np.linspace(-0.5, 0.5, 5)
    >>> contradicted([wall, phantom], [np.c_[xs, 0 * xs], np.c_[xp, 0 * xp]],
    ...              [np.c_[xs, 1 + 0 * xs], np.c_[xp, 1.5 + 0 * xp]], cell=0.01)
    [1]
    """
    m = len(polylines)
    if m < 2:
        return []
    polys = [np.asarray(p, dtype=np.float64).reshape(-1, 2) for p in polylines]
    straight = _straight(polys)
    segs = [_segments(p, 5, bool(f)) for p, f in zip(polys, straight, strict=True)]
    b0 = np.concatenate([g[0] for g in segs])
    b1 = np.concatenate([g[1] for g in segs])
    s0 = np.concatenate([g[2] for g in segs])
    owner = np.repeat(np.arange(m), [len(g[0]) for g in segs])
    # the completions to corners: crossings there count like those near an end
    ext_owner, ext0, ext1 = corner_extensions(polys, straight=straight)
    b0, b1 = np.concatenate((b0, ext0)), np.concatenate((b1, ext1))
    s0 = np.concatenate((s0, np.full(ext_owner.size, -np.inf)))
    owner = np.concatenate((owner, ext_owner))
    # where each surface's corner or edge may be, whose echoes do not cross it
    ends = [corner_candidates(p, bool(f), cell=cell) for p, f in zip(polys, straight, strict=True)]
    total = np.array([float(np.hypot(*np.diff(p, axis=0).T).sum()) for p in polylines])
    echoes = np.array([len(p) for p in points], dtype=np.int64)
    cross_any = np.zeros((m, m), dtype=np.int64)  # a's paths crossing b anywhere
    cross_mid = np.zeros((m, m), dtype=np.int64)  # ... away from b's ends
    for a in range(m):
        s = np.asarray(sensors[a], dtype=np.float64).reshape(-1, 2)
        e = np.asarray(points[a], dtype=np.float64).reshape(-1, 2)
        if s.size == 0:
            continue
        v = e - s
        length = np.hypot(*v.T)
        e = s + v * (np.maximum(length - END_MARGIN_M, 0.0) / np.maximum(length, 1e-12))[:, None]
        arcs: dict[int, npt.NDArray[np.bool_]] = {}  # a's readings each surface's point explains
        for c0 in range(0, len(s), _CHUNK):
            rows, cols, u = segment_crossings(s[c0 : c0 + _CHUNK], e[c0 : c0 + _CHUNK], b0, b1)
            crossed = owner[cols]
            at = s0[cols] + u * np.hypot(*(b1 - b0)[cols].T)
            mid = (at > END_ZONE_M) & (at < total[crossed] - END_ZONE_M)
            for k in np.unique(crossed[mid]):
                # a crossed surface's corner heard in the beam is no evidence against it
                if int(k) not in arcs:
                    arcs[int(k)] = corner_echoes(s, length, ends[k])
                at_k = np.flatnonzero(mid & (crossed == k))
                mid[at_k[arcs[int(k)][rows[at_k] + c0]]] = False
            for counts, sel in ((cross_any, slice(None)), (cross_mid, mid)):
                # a path counts once per surface it crosses
                pairs = np.unique(rows[sel] * m + crossed[sel])
                np.add.at(counts[a], pairs % m, 1)
    np.fill_diagonal(cross_any, 0)
    np.fill_diagonal(cross_mid, 0)
    # the pair's loser is the surface with fewer echoes; a crossed surface loses only to
    # crossings away from its ends
    a_loses = echoes[:, None] < echoes[None, :]
    strength = np.where(a_loses, cross_any, cross_mid)
    dropped: set[int] = set()
    for flat in np.argsort(-strength, axis=None, kind="stable"):
        owner_i, crossed_i = divmod(int(flat), m)
        if strength[owner_i, crossed_i] < MIN_CROSSINGS:
            break
        if owner_i in dropped or crossed_i in dropped:
            continue
        dropped.add(owner_i if bool(a_loses[owner_i, crossed_i]) else crossed_i)
    return sorted(dropped)

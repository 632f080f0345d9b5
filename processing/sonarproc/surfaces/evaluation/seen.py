"""The truth the sonars saw: which truth points some reading could have produced.

A truth point ``p`` is seen by a reading when it lies in the transmitter's beam
(``|angle(p - tx) - tx_heading| <= tx half beam width``), in the receiver's beam likewise,
and on the reading's ellipse, ``| |p - tx| + |p - rx| - path | <= 2 tol`` (for a sensor's
own echo: its range circle within ``tol``).

Every point the exact test accepts lies in a ball around the reading's beam sector, so
candidate (reading, point) pairs come from radius searches
(:func:`sonarproc.surfaces.planar.search.pairs_within`): readings sorted by ball radius are
taken in chunks of about the same radius, and each chunk is paired with the truth points
within its balls. Most readings see points that earlier readings already saw (a robot
passes the same wall again and again), so the search holds only the points not seen yet,
refreshed as they go, and a sample of the readings (one in :data:`FIRST_PASS_STRIDE`) is
taken first: it sees most points, and the other readings are then paired with the few
it left. Pairs are tested cheapest first (ball, then ellipse, then both beams), so the
arc tangents are taken only for the few pairs on the ellipse. The answer is the same as
testing every pair, in any order: the ball is a strict superset of the exact test, and a
point already seen cannot be unseen.
"""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.search import pairs_within

__all__ = ["SEEN_TOLERANCE_M", "seen_truth"]

logger = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Range tolerance (m) of "a reading could have produced this truth point".
SEEN_TOLERANCE_M = 0.02
#: Candidate (reading, truth point) pairs tested at once: bounds the memory (~100 B a pair)
#: and the work, as the points seen leave the search only between chunks. The first chunk,
#: paired with every truth point, sees most of them (the shortest readings of a log that
#: passes its walls again and again): smaller chunks drop those points sooner, each for
#: about the cost of a k-d tree of the points. The answer is the same for any size.
PAIRS_PER_CHUNK = 50_000
#: The points searched are refreshed once this fraction of them has been seen.
REBUILD_SEEN_FRACTION = 0.25
#: One reading in this many (spread over every range) is paired first. The order changes
#: no answer, only the work: the sample already sees most of the points a log's many
#: passes along its walls see, so the rest are paired with the few points left.
FIRST_PASS_STRIDE = 16


def _wrap(a: FloatArray) -> FloatArray:
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


def _beam_balls(
    txy: FloatArray, rxy: FloatArray, th: FloatArray, path: FloatArray, tb: FloatArray, tol: float
) -> tuple[FloatArray, FloatArray]:
    """Centre and radius of a ball around each reading's part of the transmitter's beam.

    The reading's points lie in the transmitter's beam at a range between
    ``(path - d) / 2`` and ``(path + d) / 2`` (``d`` the transmitter-receiver distance),
    widened by ``tol``: an annular sector, whose farthest points from the centre (on the
    axis, half-way) are its corners.
    """
    d = np.hypot(*(rxy - txy).T)
    a0 = np.maximum(0.5 * (path - d) - tol, 0.0)
    a1 = 0.5 * (path + d) + tol
    m = 0.5 * (a0 + a1)
    beta = np.minimum(tb, np.pi)

    def corner(a: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(a * np.cos(beta) - m, a * np.sin(beta)), dtype=np.float64)

    radius = np.maximum(corner(a0), corner(a1)) + 1e-9
    centre = txy + m[:, None] * np.stack((np.cos(th), np.sin(th)), axis=1)
    return centre, np.asarray(radius, dtype=np.float64)


def _chunk_size(radius: FloatArray, density: float, step: float, points: int) -> int:
    """How many of the readings ``radius`` (ascending) to pair at once.

    Every reading of a chunk is paired with the points within the chunk's largest radius
    ``R``: about the points on a line through the ball (``2 R / step``) plus the area
    density's share, and never more than the ``points`` searched.
    """
    head = radius[:PAIRS_PER_CHUNK]
    per = np.minimum(2.0 * head / step + density * np.pi * head**2, points) + 1.0
    cost = per * np.arange(1, head.size + 1)
    return max(1, int(np.searchsorted(cost, PAIRS_PER_CHUNK, side="right")))


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
        Truth points (m), e.g. from :func:`sonarproc.surfaces.truth_points`.
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
    with np.errstate(invalid="ignore", over="ignore"):  # a non-finite reading sees nothing
        centre, radius = _beam_balls(txy, rxy, th, L, tb, tol)
    ok = np.all(np.isfinite(centre), axis=1) & np.isfinite(radius)
    order = np.flatnonzero(ok)[np.argsort(radius[ok], kind="stable")]
    sample = np.zeros(order.size, dtype=bool)
    sample[::FIRST_PASS_STRIDE] = True
    area = max(float(np.ptp(pts[:, 0]) * np.ptp(pts[:, 1])), 1e-6)
    step = _point_step(pts)
    chunks = 0
    for readings in (order[sample], order[~sample]):  # each by ascending radius
        live: IntArray = np.flatnonzero(~seen)  # the points still searched
        sorted_radius = radius[readings]
        c0 = 0
        while c0 < readings.size and live.size:
            if np.count_nonzero(seen[live]) > REBUILD_SEEN_FRACTION * live.size:
                live = np.flatnonzero(~seen)
                if live.size == 0:
                    break
            size = _chunk_size(sorted_radius[c0:], live.size / area, step, live.size)
            idx = readings[c0 : c0 + size]
            c0 += size
            chunks += 1
            i, jl, _ = pairs_within(centre[idx], pts[live], radius[idx])
            k, j = idx[i], live[jl]
            keep = ~seen[j]
            k, j = k[keep], j[keep]
            _mark_hits(seen, pts, j, k, txy, rxy, th, rh, L, tb, rb, tol)
    logger.debug("seen truth: %d of %d points, %d chunks", seen.sum(), seen.size, chunks)
    return seen


def _point_step(pts: FloatArray) -> float:
    """The typical spacing of consecutive truth points (for the pair estimate)."""
    if pts.shape[0] < 2:
        return 1.0
    gaps = np.hypot(*np.diff(pts, axis=0).T)
    gaps = gaps[gaps > 0]
    return float(np.median(gaps)) if gaps.size else 1.0


def _mark_hits(
    seen: npt.NDArray[np.bool_],
    pts: FloatArray,
    j: IntArray,
    k: IntArray,
    txy: FloatArray,
    rxy: FloatArray,
    th: FloatArray,
    rh: FloatArray,
    L: FloatArray,
    tb: FloatArray,
    rb: FloatArray,
    tol: float,
) -> None:
    """Set ``seen[j]`` for the candidate pairs (reading ``k``, point ``j``) that pass."""
    p = pts[j]
    vt = p - txy[k]
    vr = p - rxy[k]
    del p
    on = np.abs(np.hypot(vt[:, 0], vt[:, 1]) + np.hypot(vr[:, 0], vr[:, 1]) - L[k]) <= 2.0 * tol
    j, k, vt, vr = j[on], k[on], vt[on], vr[on]
    hit = np.abs(_wrap(np.arctan2(vt[:, 1], vt[:, 0]) - th[k])) <= tb[k]
    j, k, vr = j[hit], k[hit], vr[hit]
    hit = np.abs(_wrap(np.arctan2(vr[:, 1], vr[:, 0]) - rh[k])) <= rb[k]
    seen[j[hit]] = True

"""Points near each other in the plane, found through a grid of buckets (no k-d tree).

The extraction needs, for a few ten thousand nodes, every pair closer than the bridging
distance, and for nodes off a surface's path the nearest node on it; the echo search
needs the readings near each surface. Buckets of side ``r`` hold the points; a pair
closer than ``r`` lies in one bucket or two adjacent ones, so only those bucket pairs
are compared, all at once. Distances are compared squared (``dx * dx + dy * dy <= r *
r``), as :class:`scipy.spatial.cKDTree` does, so both find the same pairs.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.runs import ragged_arange

__all__ = ["close_pairs", "nearest_in_run", "nearest_within", "pairs_within"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: Up to this many buckets, the buckets are one dense array (else sorted keys).
DENSE_BUCKETS = 1 << 22
#: Candidate pairs tested at once by :func:`pairs_within` (temporaries of a few hundred kB).
PAIR_CHUNK = 1 << 15
#: Above this many candidate pairs the nearest-point search goes through a tree of runs
#: of points (:func:`sonarproc.surfaces.planar.nearest.nearest_points`).
BRUTE_FORCE_PAIRS = 4_000_000


def _low_corner(pos: FloatArray) -> FloatArray:
    """Smallest x and y (numpy reduces an (N, 2) array along axis 0 slowly)."""
    return np.array([pos[:, 0].min(), pos[:, 1].min()])


def close_pairs(pos: FloatArray, r: float) -> tuple[IntArray, IntArray, FloatArray]:
    """Every pair ``i < j`` of points at most ``r`` apart, and its squared distance.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
        Points (m).
    r : float
        Largest distance (m), > 0.

    Returns
    -------
    i, j : ndarray of intp
        The pairs (``i < j``), in no particular order.
    d2 : ndarray of float
        ``dx * dx + dy * dy`` of each pair.

    Examples
    --------
    >>> i, j, d2 = close_pairs(np.array([[0.0, 0.0], [0.3, 0.4], [2.0, 0.0]]), 0.5)
    >>> i.tolist(), j.tolist(), d2.round(12).tolist()
    ([0], [1], [0.25])
    """
    n = pos.shape[0]
    empty = np.zeros(0, dtype=np.intp)
    if n < 2:
        return empty, empty, np.zeros(0)
    # buckets a hair wider than r: rounding in the division never puts a pair r apart
    # two buckets apart
    side = r * (1.0 + 1e-6)
    b = np.floor((pos - _low_corner(pos)) / side).astype(np.int64)
    rows = int(b[:, 1].max()) + 3
    key = (b[:, 0] + 1) * rows + (b[:, 1] + 1)
    order = np.argsort(key, kind="stable")
    buckets, start, count = np.unique(key[order], return_index=True, return_counts=True)
    # the bucket itself and the four neighbours ahead of it: each bucket pair once
    pa_list, pb_list = [], []
    for step in (0, 1, rows - 1, rows, rows + 1):
        loc = np.searchsorted(buckets, buckets + step)
        loc = np.minimum(loc, buckets.size - 1)
        hit = np.flatnonzero(buckets[loc] == buckets + step)
        pa_list.append(hit)
        pb_list.append(loc[hit])
    pa, pb = np.concatenate(pa_list), np.concatenate(pb_list)
    ca, cb = count[pa], count[pb]
    # in bucket order (contiguous coordinates); back to point indices for the survivors.
    # One row per point of the first bucket, over the points of the second (within
    # one bucket: over the points after it)
    xs, ys = pos[order, 0], pos[order, 1]
    same = pa == pb
    row_pair, row_k = ragged_arange(ca)
    row_a = start[pa[row_pair]] + row_k
    row_b = np.where(same[row_pair], row_a + 1, start[pb[row_pair]])
    row_len = np.where(same[row_pair], ca[row_pair] - row_k - 1, cb[row_pair])
    row, k = ragged_arange(row_len)
    sa = row_a[row]
    sb = row_b[row] + k
    dx = xs[sa] - xs[sb]
    dy = ys[sa] - ys[sb]
    d2 = dx * dx + dy * dy
    close = np.flatnonzero(d2 <= r * r)
    ia, ib, d2 = order[sa[close]], order[sb[close]], d2[close]
    lo, hi = np.minimum(ia, ib), np.maximum(ia, ib)
    return lo.astype(np.intp), hi.astype(np.intp), d2


def nearest_within(
    pos: FloatArray,
    queries: IntArray,
    targets: IntArray,
    group: IntArray,
    r: float,
    *,
    prune: Callable[[BoolArray], BoolArray] | None = None,
) -> tuple[FloatArray, IntArray]:
    """For each query point, the nearest target point of its group, if within ``r``.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
        All points.
    queries, targets : ndarray of intp
        Indices of the query and the target points.
    group : ndarray of intp, shape (N,)
        Group of every point (>= 0); a query looks only at targets of its group.
    r : float
        Search radius (m), > 0.
    prune : callable, optional
        Given which queries may have a target within ``r`` (the others have none),
        says which of them to search; the rest are reported as having none.

    Returns
    -------
    dist : ndarray of float
        Distance to the nearest target (``sqrt(dx * dx + dy * dy)``), inf if none is
        within ``r``.
    nearest : ndarray of intp
        Its index into ``pos`` (ties: the lower index), -1 if none.

    Examples
    --------
    >>> pos = np.array([[0.0, 0.0], [1.0, 0.0], [1.5, 0.0], [3.0, 0.0]])
    >>> d, k = nearest_within(pos, np.array([2, 3]), np.array([0, 1]), np.zeros(4, int), 1.0)
    >>> d.tolist(), k.tolist()
    ([0.5, inf], [1, -1])
    """
    dist = np.full(queries.size, np.inf)
    nearest = np.full(queries.size, -1, dtype=np.intp)
    if queries.size == 0 or targets.size == 0:
        return dist, nearest
    side = r * (1.0 + 1e-6)
    low = _low_corner(pos)
    bq = np.floor((pos[queries] - low) / side).astype(np.int64) + 1
    bt = np.floor((pos[targets] - low) / side).astype(np.int64) + 1
    rows = int(max(bq[:, 1].max(), bt[:, 1].max())) + 2
    cols = int(max(bq[:, 0].max(), bt[:, 0].max())) + 2
    steps = np.array([dx * rows + dy for dx in (-1, 0, 1) for dy in (-1, 0, 1)], dtype=np.int64)
    if cols * rows <= DENSE_BUCKETS:
        # buckets of all groups in one dense array (the group is checked per pair)
        tkey = bt[:, 0] * rows + bt[:, 1]
        order = np.argsort(tkey, kind="stable")
        count = np.bincount(tkey, minlength=cols * rows)
        start = np.cumsum(count) - count
        want = ((bq[:, 0] * rows + bq[:, 1])[:, None] + steps).ravel()
        hit = np.flatnonzero(count[want] > 0)
        loc = want[hit]
    else:
        tkey = (group[targets].astype(np.int64) * cols + bt[:, 0]) * rows + bt[:, 1]
        order = np.argsort(tkey, kind="stable")
        buckets, start, count = np.unique(tkey[order], return_index=True, return_counts=True)
        qkey = (group[queries].astype(np.int64) * cols + bq[:, 0]) * rows + bq[:, 1]
        want = (qkey[:, None] + steps).ravel()
        loc = np.minimum(np.searchsorted(buckets, want), buckets.size - 1)
        hit = np.flatnonzero(buckets[loc] == want)
        loc = loc[hit]
    q_of = hit // steps.size
    if prune is not None:
        maybe = np.zeros(queries.size, dtype=bool)
        maybe[q_of] = True
        wanted = prune(maybe)[q_of]
        q_of, loc = q_of[wanted], loc[wanted]
    which, k = ragged_arange(count[loc])
    qi = q_of[which]
    si = start[loc][which] + k
    # coordinates in bucket order: contiguous gathers
    sorted_t = targets[order]
    tx, ty = pos[sorted_t, 0], pos[sorted_t, 1]
    qx, qy = pos[queries, 0], pos[queries, 1]
    dx = qx[qi] - tx[si]
    dy = qy[qi] - ty[si]
    d2 = dx * dx + dy * dy
    close = np.flatnonzero((d2 <= r * r) & (group[queries][qi] == group[sorted_t][si]))
    qi, ti, d2 = qi[close], sorted_t[si[close]], d2[close]
    best = np.full(queries.size, np.inf)
    np.minimum.at(best, qi, d2)
    tie = d2 == best[qi]
    top = np.iinfo(np.intp).max
    pick = np.full(queries.size, top, dtype=np.intp)
    np.minimum.at(pick, qi[tie], ti[tie])
    found = pick < top
    dist[found], nearest[found] = np.sqrt(best[found]), pick[found]
    return dist, nearest


def nearest_in_run(
    pos: FloatArray, queries: IntArray, targets: IntArray, bounds: IntArray, run: IntArray
) -> tuple[FloatArray, IntArray]:
    """For each query point, the nearest target point of its run (ties: the lower index).

    Beyond :data:`BRUTE_FORCE_PAIRS` query-target pairs, a tree search
    (:func:`~sonarproc.surfaces.planar.nearest.nearest_points`) answers instead, with the
    same result.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
        All points.
    queries : ndarray of intp
        Indices of the query points.
    targets : ndarray of intp
        Indices of the target points, grouped by run: run ``g`` is
        ``targets[bounds[g]:bounds[g + 1]]`` (each run that a query uses is non-empty).
    bounds : ndarray of intp
        Run bounds into ``targets``.
    run : ndarray of intp
        The run of each query.

    Returns
    -------
    dist : ndarray of float
        Distance to the nearest target (``sqrt(dx * dx + dy * dy)``).
    nearest : ndarray of intp
        Index (into ``pos``) of the nearest target.

    Examples
    --------
    >>> pos = np.array([[0.0, 0.0], [1.0, 0.0], [5.0, 0.0], [3.0, 0.0]])
    >>> d, k = nearest_in_run(pos, np.array([3]), np.array([0, 1, 2]), np.array([0, 3]),
    ...                       np.array([0]))
    >>> d.tolist(), k.tolist()
    ([2.0], [1])
    """
    sizes = (bounds[1:] - bounds[:-1])[run]
    if int(sizes.sum()) > BRUTE_FORCE_PAIRS:
        return _nearest_by_tree(pos, queries, targets, bounds, run)
    q, k = ragged_arange(sizes)
    t = targets[bounds[:-1][run][q] + k]
    a = queries[q]
    dx = pos[a, 0] - pos[t, 0]
    dy = pos[a, 1] - pos[t, 1]
    d2 = dx * dx + dy * dy
    best = np.full(queries.size, np.inf)
    np.minimum.at(best, q, d2)
    tie = d2 == best[q]
    nearest = np.full(queries.size, np.iinfo(np.intp).max, dtype=np.intp)
    np.minimum.at(nearest, q[tie], t[tie])
    return np.sqrt(best), nearest


def _nearest_by_tree(
    pos: FloatArray, queries: IntArray, targets: IntArray, bounds: IntArray, run: IntArray
) -> tuple[FloatArray, IntArray]:
    """:func:`nearest_in_run` for many points: one tree search, a piece per run."""
    # here, not at the top: the tree search uses this module's bucket search
    from sonarproc.surfaces.planar.nearest import nearest_points

    # each run's targets by index, so that the lower index among equally near targets
    # (the tree's tie rule) is the lower index into pos
    t_run = np.repeat(np.arange(bounds.size - 1), np.diff(bounds))
    ordered = targets[np.lexsort((targets, t_run))]
    dist, k = nearest_points(pos[ordered], pos[queries], bounds=bounds, run=run, reorder=True)
    return dist, ordered[k]


def pairs_within(
    a: FloatArray, b: FloatArray, r: float | FloatArray
) -> tuple[IntArray, IntArray, FloatArray]:
    """Every pair ``(i, j)`` with ``b[j]`` at most ``r[i]`` from ``a[i]``.

    Meant for few centres ``a`` (surfaces) and many points ``b`` (readings): ``b`` goes
    into a grid of buckets about a quarter of the typical radius wide; each centre
    takes the buckets its disk touches (a ragged block per centre), then the points in
    them are tested.

    Parameters
    ----------
    a, b : ndarray, shape (N, 2) and (M, 2)
        Centres and points (m).
    r : float or ndarray, shape (N,)
        Radius of each centre (m), >= 0.

    Returns
    -------
    i, j : ndarray of intp
        The pairs, by ascending ``i`` (in no particular order within one ``i``).
    d2 : ndarray of float
        ``dx * dx + dy * dy`` of each pair.

    Examples
    --------
    >>> a = np.array([[0.0, 0.0], [5.0, 5.0]])
    >>> b = np.array([[0.3, 0.4], [2.0, 0.0], [5.0, 5.5], [0.0, -0.5]])
    >>> i, j, d2 = pairs_within(a, b, np.array([0.5, 0.1]))
    >>> o = np.lexsort((j, i))
    >>> i[o].tolist(), j[o].tolist(), d2[o].round(12).tolist()
    ([0, 0], [0, 3], [0.25, 0.25])
    """
    ra = np.broadcast_to(np.asarray(r, dtype=np.float64), (a.shape[0],))
    empty = np.zeros(0, dtype=np.intp)
    if a.shape[0] == 0 or b.shape[0] == 0:
        return empty, empty, np.zeros(0)
    low = _low_corner(b)
    extent = float(max(np.ptp(b[:, 0]), np.ptp(b[:, 1])))
    # a quarter of the median radius: the buckets a disk touches hold little beyond it;
    # never more than DENSE_BUCKETS buckets
    side = max(0.25 * float(np.median(ra)), extent / math.sqrt(DENSE_BUCKETS), 1e-9)
    bx = np.floor((b[:, 0] - low[0]) / side).astype(np.int64)
    by = np.floor((b[:, 1] - low[1]) / side).astype(np.int64)
    cols, rows = int(bx.max()) + 1, int(by.max()) + 1
    key = bx * rows + by
    order = np.argsort(key, kind="stable")
    count = np.bincount(key, minlength=cols * rows)
    start = np.cumsum(count) - count
    xs, ys = b[order, 0], b[order, 1]
    # each centre's block of buckets, clipped to the grid (one bucket of slack for
    # rounding in the division)
    cx, cy = a[:, 0], a[:, 1]
    x0 = np.clip(np.floor((cx - ra - low[0]) / side).astype(np.int64) - 1, 0, cols)
    x1 = np.clip(np.floor((cx + ra - low[0]) / side).astype(np.int64) + 2, 0, cols)
    y0 = np.clip(np.floor((cy - ra - low[1]) / side).astype(np.int64) - 1, 0, rows)
    y1 = np.clip(np.floor((cy + ra - low[1]) / side).astype(np.int64) + 2, 0, rows)
    h = np.maximum(y1 - y0, 0)
    ci, k = ragged_arange(np.maximum(x1 - x0, 0) * h)
    ux = x0[ci] + k // h[ci]
    uy = y0[ci] + k % h[ci]
    bucket = ux * rows + uy
    # buckets with points whose box the disk reaches (the box a hair larger)
    gx = np.maximum(np.maximum(low[0] + ux * side - cx[ci], cx[ci] - low[0] - (ux + 1) * side), 0.0)
    gy = np.maximum(np.maximum(low[1] + uy * side - cy[ci], cy[ci] - low[1] - (uy + 1) * side), 0.0)
    reach = ra[ci] + 1e-9 * (side + extent)
    use = np.flatnonzero((count[bucket] > 0) & (gx * gx + gy * gy <= reach * reach))
    ci, bucket = ci[use], bucket[use]
    # the (centre, point) candidates in slices of about PAIR_CHUNK: small temporaries
    ends = np.cumsum(count[bucket])
    cuts = np.searchsorted(
        ends, np.arange(PAIR_CHUNK, int(ends[-1]) if ends.size else 0, PAIR_CHUNK)
    )
    got_i, got_j, got_d2 = [], [], []
    for lo, hi in zip(np.concatenate(([0], cuts)), np.concatenate((cuts, [ci.size])), strict=True):
        which, k = ragged_arange(count[bucket[lo:hi]])
        ai = ci[lo:hi][which]
        sj = start[bucket[lo:hi]][which] + k
        dx = cx[ai] - xs[sj]
        dy = cy[ai] - ys[sj]
        d2 = dx * dx + dy * dy
        close = np.flatnonzero(d2 <= ra[ai] * ra[ai])
        got_i.append(ai[close])
        got_j.append(order[sj[close]])
        got_d2.append(d2[close])
    return (
        np.concatenate(got_i).astype(np.intp),
        np.concatenate(got_j).astype(np.intp),
        np.concatenate(got_d2),
    )

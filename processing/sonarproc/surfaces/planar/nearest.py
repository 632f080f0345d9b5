"""The nearest of many points to each of many others, at any distance (no k-d tree).

Sensors metres away from a finely sampled surface, cells near a fitted curve, nodes
near a path: each needs the nearest of a few hundred to a few ten thousand points, with
no useful search radius known in advance. The targets are split into *pieces* (one per
polyline, or per run of nodes), each piece into nodes of :data:`BRANCH` consecutive
points, and those into nodes of :data:`BRANCH` nodes, up to one node per piece: a tree
whose nodes are runs of consecutive points, each with a bounding box, a chord (its first
point to its last) and the largest distance of its points from that chord.

Queries with a target within a few target spacings are answered first, all at once, by
the bucket search of :func:`sonarproc.surfaces.planar.neighbours.nearest_within` (exact for
every query it answers). The others walk down the tree together, one level at a time, in
chunks of :data:`QUERY_CHUNK`. Pieces searched together are ordered along a Z-order curve
first, so that the levels above one node per piece are compact too. A node's
points are at least ``max(distance to its box, distance to its chord - deviation)`` from
a query (the chord is what makes a far query cheap: on a smooth polyline the deviation
is tiny and only the nodes near the foot are kept); its middle point gives an upper bound
on the nearest distance. Nodes whose lower bound exceeds the query's best upper bound
are dropped, the rest are opened; at the bottom the remaining points are compared. The
loops are over tree levels (a handful) and query chunks, never over queries or points.

The result is exact: squared distances ``dx * dx + dy * dy`` compared, ties to the lower
target index, the distance their square root.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.neighbours import nearest_within
from sonarproc.surfaces.planar.runs import ragged_arange

__all__ = ["BRANCH", "nearest_points"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Points per bottom node and nodes per node above.
BRANCH = 8
#: Queries with a target within this many target spacings (the median distance of
#: consecutive targets) are answered by one bucket search, the others by the tree.
NEAR_STEPS = 4.0
#: Queries walked down the tree at once.
QUERY_CHUNK = 4096


@dataclass(frozen=True)
class _Level:
    """The nodes of one tree level: ranges ``[lo, hi)`` of the ordered targets."""

    lo: IntArray
    hi: IntArray
    #: bounds of a node's points from any query, one row per node: box x min, y min,
    #: x max, y max; chord start x, y, unit direction x, y, length; the largest
    #: distance of a point from the chord
    bound: FloatArray
    rep: IntArray  # the middle point: its distance bounds the nearest from above
    child_lo: IntArray | None  # the node's children at the level below (None: points)
    child_hi: IntArray | None
    piece: IntArray


def _chord(a: FloatArray, b: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unit direction ``(ux, uy)`` and length of each segment ``a -> b`` (0, 0 if a point)."""
    dx, dy = b[:, 0] - a[:, 0], b[:, 1] - a[:, 1]
    length = np.sqrt(dx * dx + dy * dy)
    inv = np.divide(1.0, length, out=np.zeros_like(length), where=length > 0)
    return dx * inv, dy * inv, length


def _segment_distance(
    qx: FloatArray, qy: FloatArray, ax: FloatArray, ay: FloatArray,
    ux: FloatArray, uy: FloatArray, length: FloatArray,
) -> FloatArray:  # fmt: skip
    """Distance from each point ``q`` to the segment from ``a`` along ``u`` (rows paired)."""
    px, py = qx - ax, qy - ay
    t = np.clip(px * ux + py * uy, 0.0, length)
    fx = px - t * ux
    fy = py - t * uy
    return np.asarray(np.sqrt(fx * fx + fy * fy), dtype=np.float64)


def _level(
    pts: FloatArray, lo: IntArray, hi: IntArray, piece: IntArray,
    child_lo: IntArray | None = None, child_hi: IntArray | None = None,
) -> _Level:  # fmt: skip
    a, b = pts[lo], pts[hi - 1]
    ux, uy, length = _chord(a, b)
    # the nodes cover the targets in order, without gaps: one reduceat per bound
    node = np.repeat(np.arange(lo.size), hi - lo)
    x, y = pts[:, 0], pts[:, 1]
    off = _segment_distance(x, y, a[node, 0], a[node, 1], ux[node], uy[node], length[node])
    bound = np.stack(
        (np.minimum.reduceat(x, lo), np.minimum.reduceat(y, lo),
         np.maximum.reduceat(x, lo), np.maximum.reduceat(y, lo),
         a[:, 0], a[:, 1], ux, uy, length, np.maximum.reduceat(off, lo)),
    )  # fmt: skip
    rep = (lo + hi - 1) // 2
    return _Level(lo, hi, bound, rep, child_lo, child_hi, piece)


def _build(pts: FloatArray, bounds: IntArray, *, join: bool) -> list[_Level]:
    """The tree's levels, bottom first.

    Pieces never share a node below the level of one node per piece; with ``join`` the
    levels go on above it, over all pieces, up to one node.
    """
    sizes = np.diff(bounds)
    count = -(-sizes // BRANCH)
    piece, k = ragged_arange(count)
    lo = bounds[piece] + k * BRANCH
    hi = np.minimum(lo + BRANCH, bounds[piece + 1])
    levels = [_level(pts, lo, hi, piece)]
    while True:
        if count.max(initial=0) <= 1:
            if not join or levels[-1].lo.size <= 1:
                return levels
            count = np.array([levels[-1].lo.size])  # one group: all the pieces' nodes
        first = np.cumsum(count) - count
        below = count
        count = -(-below // BRANCH)
        piece, k = ragged_arange(count)
        child_lo = first[piece] + k * BRANCH
        child_hi = np.minimum(child_lo + BRANCH, first[piece] + below[piece])
        prev = levels[-1]
        levels.append(
            _level(pts, prev.lo[child_lo], prev.hi[child_hi - 1], piece, child_lo, child_hi)
        )


def _lower_bound(qx: FloatArray, qy: FloatArray, lv: _Level, node: IntArray) -> FloatArray:
    """A distance no point of ``node`` is nearer to ``q`` than (rows paired)."""
    x0, y0, x1, y1, ax, ay, ux, uy, length, dev = lv.bound[:, node]
    gx = np.maximum(np.maximum(x0 - qx, qx - x1), 0.0)
    gy = np.maximum(np.maximum(y0 - qy, qy - y1), 0.0)
    chord = _segment_distance(qx, qy, ax, ay, ux, uy, length) - dev
    return np.maximum(np.sqrt(gx * gx + gy * gy), chord)


def _squared(qx: FloatArray, qy: FloatArray, px: FloatArray, py: FloatArray) -> FloatArray:
    dx = qx - px
    dy = qy - py
    return dx * dx + dy * dy


def _morton(pts: FloatArray) -> npt.NDArray[np.uint64]:
    """Z-order key of each point on a 2^16 grid over their box (near points, near keys)."""
    lo = pts.min(axis=0)
    span = float(np.max(pts.max(axis=0) - lo)) or 1.0
    cell = np.minimum((pts - lo) / span * 65535.0, 65535.0).astype(np.uint64)
    key = np.zeros(pts.shape[0], dtype=np.uint64)
    for bit in range(16):
        one = np.uint64(1 << bit)
        key |= (cell[:, 0] & one) << np.uint64(bit)
        key |= (cell[:, 1] & one) << np.uint64(bit + 1)
    return key


def nearest_points(
    targets: npt.ArrayLike,
    queries: npt.ArrayLike,
    *,
    bounds: npt.ArrayLike | None = None,
    run: npt.ArrayLike | None = None,
    reorder: bool = False,
) -> tuple[FloatArray, IntArray]:
    """For each query point, the nearest target point (exact; see the module notes).

    Parameters
    ----------
    targets : array_like, shape (K, 2)
        The target points, in pieces (a polyline's vertices in order search fastest).
    queries : array_like, shape (N, 2)
        The query points.
    bounds : array_like of int, optional
        Piece bounds into ``targets`` (piece ``g`` is ``targets[bounds[g]:bounds[g+1]]``);
        default one piece.
    run : array_like of int, shape (N,), optional
        The piece each query searches (default: all pieces).
    reorder : bool
        Sort the targets of each piece along a Z-order curve first (for pieces that are
        not polylines: the tree's nodes are then compact).

    Returns
    -------
    dist : ndarray of float, shape (N,)
        ``sqrt(dx * dx + dy * dy)`` to the nearest target, inf if its piece is empty.
    nearest : ndarray of intp, shape (N,)
        Its index into ``targets`` (ties: the lower index), -1 if none.

    Examples
    --------
    >>> t = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [5.0, 5.0]])
    >>> d, k = nearest_points(t, np.array([[1.4, 3.0], [1.5, 0.0], [9.0, 9.0]]))
    >>> np.round(d, 6).tolist(), k.tolist()
    ([3.026549, 0.5, 5.656854], [1, 1, 3])
    >>> nearest_points(t, np.array([[4.0, 0.0]]), bounds=[0, 3, 4], run=[0])[1].tolist()
    [2]
    """
    pts = np.asarray(targets, dtype=np.float64).reshape(-1, 2)
    q = np.asarray(queries, dtype=np.float64).reshape(-1, 2)
    bnd = np.asarray([0, pts.shape[0]] if bounds is None else bounds, dtype=np.intp)
    runs = None if run is None else np.asarray(run, dtype=np.intp).reshape(-1)
    n = q.shape[0]
    dist = np.full(n, np.inf)
    nearest = np.full(n, -1, dtype=np.intp)
    if n == 0 or pts.shape[0] == 0:
        return dist, nearest
    piece_of = np.repeat(np.arange(bnd.size - 1), np.diff(bnd))
    # queries near a target: one bucket search, exact for every query it answers (ties
    # to the lower index, as below), within a few target spacings
    gap = np.hypot(*np.diff(pts, axis=0).T)[piece_of[1:] == piece_of[:-1]]
    radius = NEAR_STEPS * float(np.median(gap[gap > 0])) if np.any(gap > 0) else 0.0
    rest = np.arange(n)
    if radius > 0:
        group_q = np.zeros(n, np.intp) if runs is None else runs
        group_t = np.zeros(pts.shape[0], np.intp) if runs is None else piece_of
        d, k = nearest_within(
            np.concatenate((pts, q)),
            np.arange(pts.shape[0], pts.shape[0] + n),
            np.arange(pts.shape[0]),
            np.concatenate((group_t, group_q)),
            radius,
        )
        near = k >= 0
        dist[near], nearest[near] = d[near], k[near]
        rest = np.flatnonzero(~near)
    if rest.size == 0:
        return dist, nearest
    order = np.arange(pts.shape[0])
    n_pieces = bnd.size - 1
    if runs is None and n_pieces > 1:
        # searched together, the pieces are ordered along a Z-order curve (by their
        # middle points), so that the levels above one node per piece are compact too
        mid = pts[np.minimum((bnd[:-1] + bnd[1:]) // 2, pts.shape[0] - 1)]  # empty: any
        by = np.argsort(_morton(mid), kind="stable")
        rank = np.empty(n_pieces, dtype=np.intp)
        rank[by] = np.arange(n_pieces)
        order = np.lexsort((order, rank[piece_of]))
        sizes = np.diff(bnd)[by]
        bnd = np.concatenate(([0], np.cumsum(sizes))).astype(np.intp)
        piece_of = np.repeat(np.arange(n_pieces), sizes)
    if reorder:
        order = order[np.lexsort((_morton(pts[order]), piece_of))]
    tp = pts[order]
    levels = _build(tp, bnd, join=runs is None)
    slack = 1e-9 * (float(np.abs(tp).max()) + float(np.abs(q).max()) + 1.0)
    # queries in chunks: the frontier arrays stay small (in cache, reused)
    for c0 in range(0, rest.size, QUERY_CHUNK):
        sel = rest[c0 : c0 + QUERY_CHUNK]
        sub = None if runs is None else runs[sel]
        dist[sel], nearest[sel] = _descend(levels, tp, order, n_pieces, q[sel], sub, slack)
    return dist, nearest


def _descend(
    levels: list[_Level],
    pts: FloatArray,
    order: IntArray,
    n_pieces: int,
    q: FloatArray,
    run: IntArray | None,
    slack: float,
) -> tuple[FloatArray, IntArray]:
    """The tree search of :func:`nearest_points` for the queries ``q`` (module notes).

    ``pts`` are the targets in tree order, ``order`` their indices in the caller's;
    equally near targets go to the lower of those.
    """
    n = q.shape[0]
    top = levels[-1]
    # frontier: (query, node) pairs of the top level, one node per non-empty piece
    if run is None:
        qi = np.repeat(np.arange(n), top.lo.size)
        node = np.tile(np.arange(top.lo.size), n)
    else:
        node_of_piece = np.full(n_pieces, -1, dtype=np.intp)
        node_of_piece[top.piece] = np.arange(top.lo.size)
        node = node_of_piece[run]
        qi = np.flatnonzero(node >= 0)
        node = node[qi]
    upper = np.full(n, np.inf)
    tx, ty = pts[:, 0], pts[:, 1]
    for depth in range(len(levels) - 1, -1, -1):
        lv = levels[depth]
        qx, qy = q[qi, 0], q[qi, 1]
        r = lv.rep[node]
        np.minimum.at(upper, qi, np.sqrt(_squared(qx, qy, tx[r], ty[r])))
        keep = np.flatnonzero(_lower_bound(qx, qy, lv, node) <= upper[qi] + slack)
        qi, node = qi[keep], node[keep]
        if lv.child_lo is None or lv.child_hi is None:
            break
        which, k = ragged_arange(lv.child_hi[node] - lv.child_lo[node])
        qi, node = qi[which], lv.child_lo[node][which] + k
    bottom = levels[0]
    which, k = ragged_arange(bottom.hi[node] - bottom.lo[node])
    qi, ti = qi[which], bottom.lo[node][which] + k
    d2 = _squared(q[qi, 0], q[qi, 1], tx[ti], ty[ti])
    best = np.full(n, np.inf)
    np.minimum.at(best, qi, d2)
    tie = d2 == best[qi]
    pick = np.full(n, np.iinfo(np.intp).max, dtype=np.intp)
    np.minimum.at(pick, qi[tie], order[ti[tie]])
    found = np.isfinite(best)
    return np.where(found, np.sqrt(best), np.inf), np.where(found, pick, -1)

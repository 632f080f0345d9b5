"""Nearest points and ball searches in the plane, through :class:`scipy.spatial.cKDTree`.

The surface stages need four searches: every pair of nodes closer than the bridging
distance (:func:`close_pairs`); the nearest of many points to each of many others, over
all targets or only over one piece of them per query (:func:`nearest_points`); the
nearest target of a query's own group within a radius (:func:`nearest_within`); and
every point within a ball round each of a few centres, a radius per centre
(:func:`pairs_within`).

A search restricted to one group (a run of targets, a polyline) is one tree over all
targets in three dimensions: the third coordinate is the group number times a length
longer than any distance inside the data, so a query never reaches another group before
its own, and inside a group the third coordinates are equal, so the distances are the
plane's. Squared distances are ``dx * dx + dy * dy``, recomputed from the coordinates
where a caller compares them.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

__all__ = ["close_pairs", "nearest_in_run", "nearest_points", "nearest_within", "pairs_within"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def _squared(a: FloatArray, b: FloatArray) -> FloatArray:
    """``dx * dx + dy * dy`` of paired rows."""
    dx = a[:, 0] - b[:, 0]
    dy = a[:, 1] - b[:, 1]
    return np.asarray(dx * dx + dy * dy, dtype=np.float64)


def _lifted(pts: FloatArray, group: IntArray, apart: float) -> FloatArray:
    """The points in 3-D, each group ``apart`` metres above the previous one."""
    return np.column_stack((pts, group.astype(np.float64) * apart))


def _apart(*pts: FloatArray) -> float:
    """A length longer than any distance between the points given (m)."""
    both = np.concatenate([p for p in pts if p.size]) if any(p.size for p in pts) else None
    if both is None:
        return 1.0
    return 2.0 * float(np.hypot(*np.ptp(both, axis=0))) + 1.0


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
    empty = np.zeros(0, dtype=np.intp)
    if pos.shape[0] < 2:
        return empty, empty, np.zeros(0)
    pairs = cKDTree(pos).query_pairs(r, output_type="ndarray")
    i, j = pairs[:, 0].astype(np.intp), pairs[:, 1].astype(np.intp)
    d2 = _squared(pos[i], pos[j])
    keep = d2 <= r * r
    return i[keep], j[keep], d2[keep]


def nearest_points(
    targets: npt.ArrayLike,
    queries: npt.ArrayLike,
    *,
    bounds: npt.ArrayLike | None = None,
    run: npt.ArrayLike | None = None,
) -> tuple[FloatArray, IntArray]:
    """For each query point, the nearest target point, at any distance.

    Parameters
    ----------
    targets : array_like, shape (K, 2)
        The target points, in pieces.
    queries : array_like, shape (N, 2)
        The query points.
    bounds : array_like of int, optional
        Piece bounds into ``targets`` (piece ``g`` is ``targets[bounds[g]:bounds[g+1]]``);
        only used with ``run``.
    run : array_like of int, shape (N,), optional
        The piece each query searches (default: all targets).

    Returns
    -------
    dist : ndarray of float, shape (N,)
        Distance to the nearest target, inf if its piece is empty.
    nearest : ndarray of intp, shape (N,)
        Its index into ``targets``, -1 if none.

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
    n = q.shape[0]
    dist = np.full(n, np.inf)
    nearest = np.full(n, -1, dtype=np.intp)
    if n == 0 or pts.shape[0] == 0:
        return dist, nearest
    if run is None:
        _, k = cKDTree(pts).query(q, k=2)
        return _lower_of_equals(q, pts, np.asarray(k, dtype=np.intp), None, None)
    bnd = np.asarray([0, pts.shape[0]] if bounds is None else bounds, dtype=np.intp)
    runs = np.asarray(run, dtype=np.intp).reshape(-1)
    piece_of = np.repeat(np.arange(bnd.size - 1), np.diff(bnd))
    apart = _apart(pts, q)
    _, k = cKDTree(_lifted(pts, piece_of, apart)).query(_lifted(q, runs, apart), k=2)
    return _lower_of_equals(q, pts, np.asarray(k, dtype=np.intp), piece_of, runs)


def _lower_of_equals(
    q: FloatArray, pts: FloatArray, k: IntArray, piece_of: IntArray | None, runs: IntArray | None
) -> tuple[FloatArray, IntArray]:
    """Of the two nearest targets ``k`` (N, 2) of each query, the nearer, ties to the lower.

    The tree returns equally near targets in no set order; the lower index makes the
    answer independent of how the targets are split into pieces (a closed polyline's
    last vertex repeats its first). Targets missing (index K) or in another piece do
    not count; a query with none has inf and -1.
    """
    n = q.shape[0]
    valid = k < pts.shape[0]
    kk = np.where(valid, k, 0)
    if piece_of is not None and runs is not None:
        valid &= piece_of[kk] == runs[:, None]
    d2 = np.where(valid, _squared(np.repeat(q, 2, axis=0), pts[kk.ravel()]).reshape(n, 2), np.inf)
    second = (d2[:, 1] < d2[:, 0]) | ((d2[:, 1] == d2[:, 0]) & (kk[:, 1] < kk[:, 0]))
    pick = second.astype(np.intp)
    rows = np.arange(n)
    best = d2[rows, pick]
    found = np.isfinite(best)
    return np.where(found, np.sqrt(best), np.inf), np.where(found, kk[rows, pick], -1)


def nearest_in_run(
    pos: FloatArray, queries: IntArray, targets: IntArray, bounds: IntArray, run: IntArray
) -> tuple[FloatArray, IntArray]:
    """For each query point, the nearest target point of its run.

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
        Distance to the nearest target.
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
    dist, k = nearest_points(pos[targets], pos[queries], bounds=bounds, run=run)
    return dist, np.where(k >= 0, targets[np.maximum(k, 0)], -1).astype(np.intp)


def nearest_within(
    pos: FloatArray, queries: IntArray, targets: IntArray, group: IntArray, r: float
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

    Returns
    -------
    dist : ndarray of float
        Distance to the nearest target, inf if none is within ``r``.
    nearest : ndarray of intp
        Its index into ``pos``, -1 if none.

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
    # groups further apart than the radius: a query never reaches another group
    apart = 2.0 * r + 1.0
    tree = cKDTree(_lifted(pos[targets], group[targets], apart))
    # the tree's bound is strict and its own rounding: a hair wider, the plane's squared
    # test decides below
    bound = r * (1.0 + 1e-9) + 1e-12
    _, k = tree.query(_lifted(pos[queries], group[queries], apart), distance_upper_bound=bound)
    found = k < targets.size
    t = targets[np.asarray(k[found], dtype=np.intp)]
    d2 = _squared(pos[queries[found]], pos[t])
    inside = d2 <= r * r
    at = np.flatnonzero(found)[inside]
    dist[at], nearest[at] = np.sqrt(d2[inside]), t[inside]
    return dist, nearest


def pairs_within(
    a: FloatArray, b: FloatArray, r: float | FloatArray
) -> tuple[IntArray, IntArray, FloatArray]:
    """Every pair ``(i, j)`` with ``b[j]`` at most ``r[i]`` from ``a[i]``.

    One search of the centres' tree against the points' tree at the largest radius,
    then each pair tested against its centre's own radius.

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
    top = float(ra.max())
    # a hair beyond the largest radius: the tree's rounding never drops a pair the
    # squared test below keeps
    got = cKDTree(a).sparse_distance_matrix(
        cKDTree(b), top * (1.0 + 1e-9) + 1e-12, output_type="ndarray"
    )
    i = np.asarray(got["i"], dtype=np.intp)
    j = np.asarray(got["j"], dtype=np.intp)
    d2 = _squared(a[i], b[j])
    keep = np.flatnonzero(d2 <= ra[i] * ra[i])
    keep = keep[np.argsort(i[keep], kind="stable")]
    return i[keep], j[keep], d2[keep]

"""Graph algorithms on edge arrays, numpy only: components, spanning forests, tree distances.

The surface extraction needs three things from a graph of a few ten thousand nodes:
its connected components, a minimum spanning forest, and distances along that forest.
Each works on all components at once with a handful of numpy operations per round and
``O(log n)`` rounds, never a Python loop per node or per edge:

- :func:`connected_components`: every component root hooks onto the smallest root it
  has an edge to, then pointers jump until each node points at its root (the smallest
  node of its component). Labels are numbered in the order of each component's
  smallest node, as :func:`scipy.sparse.csgraph.connected_components` numbers them.
- :func:`minimum_spanning_forest`: Borůvka's rounds. Every component takes its
  lightest outgoing edge, ties broken by the edge's ends, so the forest is the unique
  minimum one under the order ``(weight, smaller end, larger end)``: the forest
  Kruskal's algorithm builds from the weights of a sparse matrix, row by row, sorted
  stably (as :func:`scipy.sparse.csgraph.minimum_spanning_tree` does).
- :func:`forest_tours` and :func:`forest_distances`: the Euler tour of every tree is
  ranked once (pointer jumping along the tour); distances from any sources, one per
  tree, turn each tour to begin at its source, count an edge's length up when the tour
  goes away from the source along it and down when it comes back, and take prefix sums.

Edges are undirected; ``(i, j)`` and ``(j, i)`` are the same edge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "ForestTours",
    "connected_components",
    "forest_distances",
    "forest_tours",
    "minimum_spanning_forest",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def _edges(n: int, i: npt.ArrayLike, j: npt.ArrayLike) -> tuple[IntArray, IntArray]:
    """The edge arrays as intp, checked: one length, nodes in ``0 .. n-1``."""
    if n < 0:
        raise ValueError(f"the number of nodes must be >= 0, got {n}")
    a = np.asarray(i, dtype=np.intp).ravel()
    b = np.asarray(j, dtype=np.intp).ravel()
    if a.shape != b.shape:
        raise ValueError(f"edge arrays i and j must have one length, got {a.size} and {b.size}")
    if a.size and (min(a.min(), b.min()) < 0 or max(a.max(), b.max()) >= n):
        raise ValueError(f"edge ends must be nodes 0 .. {n - 1}")
    return a, b


def connected_components(n: int, i: npt.ArrayLike, j: npt.ArrayLike) -> tuple[int, IntArray]:
    """Connected components of the undirected graph with edges ``(i[e], j[e])``.

    Parameters
    ----------
    n : int
        Number of nodes.
    i, j : array_like of int, shape (E,)
        Edge ends (nodes ``0 .. n-1``); repeated edges and self loops are allowed.

    Returns
    -------
    k : int
        Number of components.
    labels : ndarray of intp, shape (n,)
        Component of each node, ``0 .. k-1``, numbered in the order of each
        component's smallest node.

    Examples
    --------
    >>> k, labels = connected_components(6, [4, 1, 5], [2, 4, 3])
    >>> k, labels.tolist()
    (3, [0, 1, 1, 2, 1, 2])
    """
    a, b = _edges(n, i, j)
    parent = np.arange(n, dtype=np.intp)
    while a.size:
        pa, pb = parent[a], parent[b]
        # an edge inside one component stays inside it: it never matters again
        apart = pa != pb
        if not apart.any():
            break
        a, b, pa, pb = a[apart], b[apart], pa[apart], pb[apart]
        # after the jumps below every parent is a root, and parent[x] <= x throughout:
        # each root hooks onto the smallest root next to it, so no cycle can form
        np.minimum.at(parent, np.maximum(pa, pb), np.minimum(pa, pb))
        parent = _jump_to_roots(parent)
    root = parent == np.arange(n)
    number = np.cumsum(root, dtype=np.intp) - 1
    return int(np.count_nonzero(root)), number[parent]


def _jump_to_roots(parent: IntArray) -> IntArray:
    """Pointer jumping until every node points at its root (``parent[x] <= x``)."""
    while True:
        up = parent[parent]
        if np.array_equal(up, parent):
            return parent
        parent = up


def minimum_spanning_forest(
    n: int, i: npt.ArrayLike, j: npt.ArrayLike, weight: npt.ArrayLike
) -> tuple[IntArray, IntArray]:
    """The edges of a minimum spanning forest (Borůvka), and the trees of the nodes.

    Ties are broken by the edge's ends, ``(weight, min(i, j), max(i, j))``: the forest is
    the one Kruskal's algorithm builds from a stable sort of the weights of the edges
    listed row by row (what :func:`scipy.sparse.csgraph.minimum_spanning_tree` returns
    for a matrix holding each edge once), whatever the order of the edges given.

    Parameters
    ----------
    n : int
        Number of nodes.
    i, j : array_like of int, shape (E,)
        Edge ends (nodes ``0 .. n-1``), each node pair at most once.
    weight : array_like of float, shape (E,)
        Edge weights (finite).

    Returns
    -------
    edges : ndarray of intp
        Indices of the forest's edges, ascending: ``n - k`` of them for ``k`` trees.
    labels : ndarray of intp, shape (n,)
        Tree of each node, as :func:`connected_components` numbers them.

    Examples
    --------
    A triangle and a separate edge: the triangle's heaviest edge goes, and of the two
    equally light ones both stay.

    >>> edges, labels = minimum_spanning_forest(
    ...     5, [0, 1, 0, 3], [1, 2, 2, 4], [1.0, 1.0, 2.0, 5.0])
    >>> edges.tolist(), labels.tolist()
    ([0, 1, 3], [0, 0, 0, 1, 1])
    """
    a, b = _edges(n, i, j)
    w = np.asarray(weight, dtype=np.float64).ravel()
    if w.shape != a.shape:
        raise ValueError(f"weight must have one entry per edge ({a.size}), got {w.size}")
    if not np.isfinite(w).all():
        raise ValueError("edge weights must be finite")
    # (weight, key) is a strict order of the edges, so every component's lightest
    # outgoing edge is unique and the picked edges never close a cycle
    key = np.minimum(a, b).astype(np.int64) * max(n, 1) + np.maximum(a, b)
    live = np.flatnonzero(a != b).astype(np.intp)
    comp = np.arange(n, dtype=np.intp)
    picked: list[IntArray] = []
    none = np.iinfo(np.int64).max
    while live.size:
        ca, cb = comp[a[live]], comp[b[live]]
        out = np.flatnonzero(ca != cb)
        if out.size == 0:
            break
        live, ca, cb = live[out], ca[out], cb[out]
        lw, lk = w[live], key[live]
        lightest = np.full(n, np.inf)
        np.minimum.at(lightest, ca, lw)
        np.minimum.at(lightest, cb, lw)
        first = np.full(n, none, dtype=np.int64)
        at_a, at_b = lw == lightest[ca], lw == lightest[cb]
        np.minimum.at(first, ca[at_a], lk[at_a])
        np.minimum.at(first, cb[at_b], lk[at_b])
        chosen = (at_a & (lk == first[ca])) | (at_b & (lk == first[cb]))
        pick = live[chosen]
        picked.append(pick)
        # components join along the picked edges (as component ids, labels are 0 .. k-1)
        _, joined = connected_components(n, ca[chosen], cb[chosen])
        comp = joined[comp]
    edges = np.sort(np.concatenate(picked)) if picked else np.zeros(0, dtype=np.intp)
    return edges.astype(np.intp), comp


@dataclass(frozen=True)
class ForestTours:
    """The Euler tours of a forest's trees, ranked (from :func:`forest_tours`).

    Every edge is two arcs, one each way. The tours lie one after the other, each
    starting at its tree's smallest node: arc ``a`` is at ``start[labels[tail[a]]] +
    position[a]`` (and ``order`` lists the arcs in that sequence).

    Attributes
    ----------
    n : int
        Number of nodes.
    labels : ndarray of intp, shape (n,)
        Tree of each node (:func:`connected_components` numbering).
    tail, head : ndarray of intp, shape (2E,)
        Arc ends.
    edge : ndarray of intp, shape (2E,)
        Edge of each arc.
    reverse : ndarray of intp, shape (2E,)
        The arc the other way along the same edge.
    first : ndarray of intp, shape (n,)
        An arc out of each node (meaningless for a node without edges).
    position : ndarray of intp, shape (2E,)
        Place of each arc in its tree's tour.
    start : ndarray of intp, shape (T + 1,)
        Where each tree's tour starts in ``order`` (and the end).
    order : ndarray of intp, shape (2E,)
        All arcs, tour after tour.
    """

    n: int
    labels: IntArray
    tail: IntArray
    head: IntArray
    edge: IntArray
    reverse: IntArray
    first: IntArray
    position: IntArray
    start: IntArray
    order: IntArray


def forest_tours(n: int, i: npt.ArrayLike, j: npt.ArrayLike) -> ForestTours:
    """Rank the Euler tour of every tree of a forest (edges ``(i[e], j[e])``).

    Parameters
    ----------
    n : int
        Number of nodes.
    i, j : array_like of int, shape (E,)
        Edge ends; the edges must form a forest (no cycle, no repeated edge).

    Returns
    -------
    ForestTours
        For :func:`forest_distances`, as many times as needed.

    Raises
    ------
    ValueError
        When the edges hold a cycle.
    """
    a, b = _edges(n, i, j)
    m = a.size
    k, labels = connected_components(n, a, b)
    nodes = np.bincount(labels, minlength=k)
    edges = np.bincount(labels[a], minlength=k)
    if np.any(edges != nodes - 1):
        raise ValueError("the edges are not a forest: a tree holds a cycle or a repeated edge")
    tail, head = np.concatenate((a, b)), np.concatenate((b, a))
    # arcs by tail, then head: the pairs are unique in a forest, so any sort agrees
    by_tail = np.argsort(tail.astype(np.int64) * max(n, 1) + head, kind="stable")
    by_tail = by_tail.astype(np.intp)
    tail, head = tail[by_tail], head[by_tail]
    place = np.empty_like(by_tail)
    place[by_tail] = np.arange(2 * m, dtype=np.intp)
    reverse = place[(by_tail + m) % max(2 * m, 1)]
    degree = np.bincount(tail, minlength=n).astype(np.intp)
    first = (np.cumsum(degree) - degree).astype(np.intp)
    # the tour leaves a node by its next arc (cyclically) after the one it came in by
    after = np.arange(1, 2 * m + 1, dtype=np.intp)
    wrap = np.flatnonzero(after == first[tail] + degree[tail])
    after[wrap] = first[tail[wrap]]
    succ = after[reverse]
    # cut every tour just before the first arc out of its tree's smallest node
    smallest = np.flatnonzero(labels > np.maximum.accumulate(np.concatenate(([-1], labels[:-1]))))
    roots = smallest[degree[smallest] > 0]
    succ[reverse[first[roots] + degree[roots] - 1]] = -1
    tree = labels[tail]
    position = 2 * edges[tree] - 1 - _rank_lists(succ)
    start = np.concatenate(([0], np.cumsum(2 * edges))).astype(np.intp)
    order = np.empty_like(position)
    order[start[tree] + position] = np.arange(2 * m, dtype=np.intp)
    return ForestTours(n, labels, tail, head, by_tail % max(m, 1), reverse, first, position,
                       start, order)  # fmt: skip


def _rank_lists(succ: IntArray) -> IntArray:
    """Number of arcs after each one in its list (``succ``: next arc, -1 at the end).

    Wyllie's pointer jumping: every round each arc adds the count of the arc it points
    at and then points where that one pointed, so a list of L arcs takes log2 L rounds.
    """
    nxt = succ.copy()
    count = (nxt >= 0).astype(np.intp)
    live = np.flatnonzero(nxt >= 0)
    while live.size:
        ahead = nxt[live]
        gained, beyond = count[ahead], nxt[ahead]
        count[live] += gained
        nxt[live] = beyond
        live = live[beyond >= 0]
    return count


def forest_distances(
    tours: ForestTours, weight: npt.ArrayLike, sources: npt.ArrayLike
) -> FloatArray:
    """Distance of every node from the source in its tree, along the tree.

    What ``dijkstra(forest, directed=False, indices=sources, min_only=True)`` gives on a
    forest whose trees hold one source each (to rounding: the sums run in another order).

    Parameters
    ----------
    tours : ForestTours
        The forest (:func:`forest_tours`).
    weight : array_like of float, shape (E,)
        Edge lengths, in the order of the edges given to :func:`forest_tours`.
    sources : array_like of int
        Source nodes, at most one per tree (repeats are the same source).

    Returns
    -------
    ndarray of float, shape (n,)
        Sum of the edge lengths from the tree's source; inf in trees without one.

    Raises
    ------
    ValueError
        When a tree holds two sources.

    Examples
    --------
    A path 0 - 1 - 2 - 3 and a lone edge 4 - 5, from nodes 2 and 5:

    >>> t = forest_tours(6, [0, 1, 2, 4], [1, 2, 3, 5])
    >>> forest_distances(t, [1.0, 2.0, 4.0, 0.5], [2, 5]).tolist()
    [3.0, 2.0, 0.0, 4.0, 0.5, 0.0]
    """
    n, labels, start = tours.n, tours.labels, tours.start
    w = np.asarray(weight, dtype=np.float64).ravel()
    if w.size != tours.tail.size // 2:
        raise ValueError(f"weight must have one entry per edge ({tours.tail.size // 2})")
    src = np.unique(np.asarray(sources, dtype=np.intp).ravel())
    if src.size and (src[0] < 0 or src[-1] >= n):
        raise ValueError(f"sources must be nodes 0 .. {n - 1}")
    source_of = np.full(start.size - 1, -1, dtype=np.intp)
    source_of[labels[src]] = src
    if np.count_nonzero(source_of >= 0) != src.size:
        raise ValueError("each tree may hold at most one source")
    dist = np.where(source_of[labels] >= 0, 0.0, np.inf)
    if tours.tail.size == 0:
        return dist
    # the tour from a source is its tree's tour turned to begin at the source's first arc
    tree = labels[tours.tail]
    s = source_of[tree]
    begin = tours.position[tours.first[np.maximum(s, 0)]]
    length = np.diff(start)[tree]
    turned = (tours.position - begin) % length
    # an arc away from the source comes before its reverse on that tour
    down = turned < turned[tours.reverse]
    signed = np.where(down, w[tours.edge], -w[tours.edge])
    # prefix sums along the tours as they lie; the stretch from the source's first arc to
    # an arc wraps round the end of the tour when the arc comes before that first arc
    total = np.cumsum(signed[tours.order])
    before = total - signed[tours.order]
    at = start[tree] + tours.position
    last = total.size - 1  # (trees without edges have empty tours: their sums go unused)
    tour_sum = total[np.clip(start[1:] - 1, 0, last)] - before[np.minimum(start[:-1], last)]
    wrapped = np.where(tours.position < begin, tour_sum[tree], 0.0)
    reach = total[at] - before[start[tree] + begin] + wrapped
    into = np.flatnonzero(down & (s >= 0))
    dist[tours.head[into]] = reach[into]
    return dist

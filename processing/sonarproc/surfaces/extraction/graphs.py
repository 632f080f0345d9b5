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
    # the edges still between two components: their index, components, weight and key
    idx = np.flatnonzero(a != b).astype(np.intp)
    ca, cb, lw, lk = a[idx], b[idx], w[idx], key[idx]
    comp = np.arange(n, dtype=np.intp)
    k = n
    picked: list[IntArray] = []
    while idx.size:
        lightest = np.full(k, np.inf)
        np.minimum.at(lightest, ca, lw)
        np.minimum.at(lightest, cb, lw)
        at_a = np.flatnonzero(lw == lightest[ca])
        at_b = np.flatnonzero(lw == lightest[cb])
        least = np.full(k, np.iinfo(np.int64).max)
        np.minimum.at(least, ca[at_a], lk[at_a])
        np.minimum.at(least, cb[at_b], lk[at_b])
        chosen = np.union1d(at_a[lk[at_a] == least[ca[at_a]]], at_b[lk[at_b] == least[cb[at_b]]])
        picked.append(idx[chosen])
        # components join along the picked edges (component ids are labels 0 .. k-1)
        k, joined = connected_components(k, ca[chosen], cb[chosen])
        comp = joined[comp]
        ca, cb = joined[ca], joined[cb]
        apart = np.flatnonzero(ca != cb)
        idx, ca, cb, lw, lk = idx[apart], ca[apart], cb[apart], lw[apart], lk[apart]
    edges = np.sort(np.concatenate(picked)) if picked else np.zeros(0, dtype=np.intp)
    return edges.astype(np.intp), comp


@dataclass(frozen=True)
class ForestTours:
    """The Euler tours of a forest's trees (from :func:`forest_tours`).

    Every edge is two arcs, one each way. The arcs are listed tour after tour, each
    tour from its tree's smallest node; the arrays over arcs follow that order.

    Attributes
    ----------
    labels : ndarray of intp, shape (n,)
        Tree of each node (as given, else :func:`connected_components` numbering).
    first : ndarray of intp, shape (n,)
        An arc out of each node (-1 for a node without edges).
    start : ndarray of intp, shape (T + 1,)
        Where each tree's tour starts among the arcs (and the end).
    tree : ndarray of intp, shape (2E,)
        Tree of each arc.
    head : ndarray of intp, shape (2E,)
        The node each arc leads to.
    edge : ndarray of intp, shape (2E,)
        Edge of each arc (index into the edges given).
    reverse : ndarray of intp, shape (2E,)
        The arc the other way along the same edge.
    """

    labels: IntArray
    first: IntArray
    start: IntArray
    tree: IntArray
    head: IntArray
    edge: IntArray
    reverse: IntArray


def forest_tours(
    n: int, i: npt.ArrayLike, j: npt.ArrayLike, *, labels: npt.ArrayLike | None = None
) -> ForestTours:
    """The Euler tour of every tree of a forest (edges ``(i[e], j[e])``).

    Parameters
    ----------
    n : int
        Number of nodes.
    i, j : array_like of int, shape (E,)
        Edge ends; the edges must form a forest (no cycle, no repeated edge).
    labels : array_like of int, shape (n,), optional
        The tree of each node, ``0 .. T-1``, when it is known already (as from
        :func:`minimum_spanning_forest`); checked, not trusted. Found when not given.

    Returns
    -------
    ForestTours
        For :func:`forest_distances`, as many times as needed.

    Raises
    ------
    ValueError
        When the edges hold a cycle, or do not join the nodes into the given trees.

    Examples
    --------
    >>> t = forest_tours(4, [0, 1], [1, 2])
    >>> t.labels.tolist(), t.head.tolist(), t.edge.tolist()
    ([0, 0, 0, 1], [1, 2, 1, 0], [0, 1, 1, 0])
    """
    a, b = _edges(n, i, j)
    m = a.size
    if labels is None:
        k, tree_of = connected_components(n, a, b)
    else:
        tree_of = np.asarray(labels, dtype=np.intp).ravel()
        if tree_of.size != n or (n and tree_of.min() < 0):
            raise ValueError(f"labels must be {n} trees numbered from 0")
        k = int(tree_of.max()) + 1 if n else 0
        if np.any(tree_of[a] != tree_of[b]):
            raise ValueError("labels: an edge joins two trees")
    nodes = np.bincount(tree_of, minlength=k)
    edges = np.bincount(tree_of[a], minlength=k)
    if np.any(edges != nodes - 1):
        raise ValueError("the edges are not a forest of the trees: a cycle or a node apart")
    tail, head = np.concatenate((a, b)), np.concatenate((b, a))
    by_tail = _stable_order(tail)
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
    smallest = np.full(k, n, dtype=np.intp)
    np.minimum.at(smallest, tree_of, np.arange(n, dtype=np.intp))
    roots = smallest[edges > 0]
    succ[reverse[first[roots] + degree[roots] - 1]] = -1
    tree = tree_of[tail]
    longest = 2 * int(edges.max()) if k else 0
    count, done = _count_after(succ, longest)
    if not done:  # a tour left uncut: its tree was not one tree of the labels
        raise ValueError("the edges are not a forest of the trees: a cycle or a node apart")
    position = 2 * edges[tree] - 1 - count
    start = np.concatenate(([0], np.cumsum(2 * edges))).astype(np.intp)
    at = start[tree] + position
    order = np.empty_like(at)
    order[at] = np.arange(2 * m, dtype=np.intp)
    joined = np.flatnonzero(degree > 0)
    out = np.full(n, -1, dtype=np.intp)
    out[joined] = at[first[joined]]
    return ForestTours(tree_of, out, start, tree[order], head[order],
                       by_tail[order] % max(m, 1), at[reverse[order]])  # fmt: skip


def _stable_order(keys: IntArray) -> IntArray:
    """``argsort(keys, kind="stable")`` for keys >= 0, as 16-bit radix passes (O(N) each)."""
    order = np.arange(keys.size, dtype=np.intp)
    top = int(keys.max()) if keys.size else 0
    for shift in range(0, max(top.bit_length(), 1), 16):
        digit = ((keys[order] >> shift) & 0xFFFF).astype(np.uint16)
        order = order[np.argsort(digit, kind="stable")]
    return order


def _count_after(succ: IntArray, longest: int) -> tuple[IntArray, bool]:
    """Number of arcs after each one in its list (``succ``: next arc, -1 at the end).

    Wyllie's pointer jumping: every round each arc adds the count of the arc it points
    at and then points where that one pointed, so lists of at most ``longest`` arcs
    take ``log2(longest)`` rounds. The end is an arc of its own that points at itself
    and counts nothing, so every round is two gathers over all arcs. Also whether every
    arc reached an end (not so on a cycle).
    """
    end = succ.size
    nxt = np.append(np.where(succ >= 0, succ, end), end)
    count = np.append(succ >= 0, False).astype(np.intp)
    for _ in range(max(longest - 1, 0).bit_length()):
        count += count[nxt]
        nxt = nxt[nxt]
    return count[:end], bool(np.all(nxt == end))


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
    labels, start, tree = tours.labels, tours.start, tours.tree
    n = labels.size
    w = np.asarray(weight, dtype=np.float64).ravel()
    if 2 * w.size != tree.size:
        raise ValueError(f"weight must have one entry per edge ({tree.size // 2})")
    src = np.unique(np.asarray(sources, dtype=np.intp).ravel())
    if src.size and (src[0] < 0 or src[-1] >= n):
        raise ValueError(f"sources must be nodes 0 .. {n - 1}")
    source_of = np.full(start.size - 1, -1, dtype=np.intp)
    source_of[labels[src]] = src
    if np.count_nonzero(source_of >= 0) != src.size:
        raise ValueError("each tree may hold at most one source")
    dist = np.where(source_of[labels] >= 0, 0.0, np.inf)
    if tree.size == 0:
        return dist
    # each tour turned to begin at its source's first arc: an arc leads away from the
    # source when it comes before its reverse on the turned tour
    sourced = source_of >= 0
    begin = np.where(sourced, tours.first[np.maximum(source_of, 0)], start[:-1])
    turned = np.arange(tree.size, dtype=np.intp) - begin[tree]
    wrapped = turned < 0
    turned[wrapped] += np.diff(start)[tree[wrapped]]
    down = turned < turned[tours.reverse]
    step = w[tours.edge]
    signed = np.where(down, step, -step)
    # prefix sums along the tours as they lie; the stretch from a source's first arc
    # to an arc before it wraps round the end of the tour
    total = np.cumsum(signed)
    before = total - signed
    last = tree.size - 1  # (trees without edges have empty tours: their sums go unused)
    tour_sum = total[np.clip(start[1:] - 1, 0, last)] - before[np.minimum(start[:-1], last)]
    offset = before[np.clip(begin, 0, last)]
    reach = total - offset[tree]
    reach[wrapped] += tour_sum[tree[wrapped]]
    into = np.flatnonzero(down & sourced[tree])
    dist[tours.head[into]] = reach[into]
    return dist

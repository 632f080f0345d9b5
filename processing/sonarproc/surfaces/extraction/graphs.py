"""Graphs of the extraction: a minimum spanning forest (our own kernel, kept), components.

:func:`minimum_spanning_forest` is Borůvka's rounds in numpy: every component takes its
lightest outgoing edge, ties broken by the edge's ends, so the forest is the unique
minimum one under the order ``(weight, smaller end, larger end)``: the forest Kruskal's
algorithm builds from the weights of a sparse matrix, row by row, sorted stably (as
:func:`scipy.sparse.csgraph.minimum_spanning_tree` does). It is kept because
``./scripts/bench`` (``tests/benchmarks/test_bench_graphs.py``: the node graph of a
20 m room, about 40 000 nodes and 200 000 edges, the extraction's real workload)
measures it at 0.35 of scipy's time for the same forest and its trees (sparse matrix,
``minimum_spanning_tree`` and ``connected_components``), about 3x faster: each round is
a handful of array operations over the edges still between two trees, and the trees
come with the forest.

:func:`components` and :func:`tree_distances` are :mod:`scipy.sparse.csgraph`'s
``connected_components`` and ``dijkstra`` on an edge list. Edges are undirected;
``(i, j)`` and ``(j, i)`` are the same edge.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components as _csgraph_components
from scipy.sparse.csgraph import dijkstra

__all__ = ["components", "minimum_spanning_forest", "tree_distances"]

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


def _components(n: int, i: npt.ArrayLike, j: npt.ArrayLike) -> tuple[int, IntArray]:
    """Connected components of the undirected graph with edges ``(i[e], j[e])``.

    The rounds of :func:`minimum_spanning_forest` join components with it: hooking and
    pointer jumping on the few edges picked per round, no sparse matrix each time.

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
    >>> k, labels = _components(6, [4, 1, 5], [2, 4, 3])
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
        Tree of each node, as :func:`components` numbers them.

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
        k, joined = _components(k, ca[chosen], cb[chosen])
        comp = joined[comp]
        ca, cb = joined[ca], joined[cb]
        apart = np.flatnonzero(ca != cb)
        idx, ca, cb, lw, lk = idx[apart], ca[apart], cb[apart], lw[apart], lk[apart]
    edges = np.sort(np.concatenate(picked)) if picked else np.zeros(0, dtype=np.intp)
    return edges.astype(np.intp), comp


def _matrix(n: int, a: IntArray, b: IntArray, weight: npt.ArrayLike) -> csr_matrix:
    return csr_matrix((np.asarray(weight, dtype=np.float64), (a, b)), shape=(n, n))


def components(n: int, i: npt.ArrayLike, j: npt.ArrayLike) -> tuple[int, IntArray]:
    """Connected components (:func:`scipy.sparse.csgraph.connected_components`).

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
    >>> k, labels = components(6, [4, 1, 5], [2, 4, 3])
    >>> k, labels.tolist()
    (3, [0, 1, 1, 2, 1, 2])
    """
    a, b = _edges(n, i, j)
    k, labels = _csgraph_components(_matrix(n, a, b, np.ones(a.size)), directed=False)
    return int(k), labels.astype(np.intp)


def tree_distances(
    n: int, i: npt.ArrayLike, j: npt.ArrayLike, weight: npt.ArrayLike, sources: npt.ArrayLike
) -> FloatArray:
    """Distance of every node from the nearest source along the edges (:func:`dijkstra`).

    Parameters
    ----------
    n : int
        Number of nodes.
    i, j : array_like of int, shape (E,)
        Edge ends, each node pair at most once.
    weight : array_like of float, shape (E,)
        Edge lengths, > 0.
    sources : array_like of int
        Source nodes (on a forest: one per tree, and each node's distance is along
        its own tree).

    Returns
    -------
    ndarray of float, shape (n,)
        inf where no source is reachable.

    Examples
    --------
    A path 0 - 1 - 2 - 3 and a lone edge 4 - 5, from nodes 2 and 5:

    >>> tree_distances(6, [0, 1, 2, 4], [1, 2, 3, 5], [1.0, 2.0, 4.0, 0.5], [2, 5]).tolist()
    [3.0, 2.0, 0.0, 4.0, 0.5, 0.0]
    """
    a, b = _edges(n, i, j)
    src = np.unique(np.asarray(sources, dtype=np.intp).ravel())
    if src.size == 0:
        return np.full(n, np.inf)
    got = dijkstra(_matrix(n, a, b, weight), directed=False, indices=src, min_only=True)
    return np.asarray(got, dtype=np.float64)

"""The extraction's graphs on edge lists, through :mod:`scipy.sparse.csgraph`.

Nodes are ``0 .. n-1``; edges are undirected, ``(i, j)`` and ``(j, i)`` the same edge.
:func:`minimum_spanning_forest` is :func:`~scipy.sparse.csgraph.minimum_spanning_tree` of
the matrix holding each edge once above the diagonal, its edges given back as indices
into the list; :func:`components` is
:func:`~scipy.sparse.csgraph.connected_components`; :func:`tree_distances` is
:func:`~scipy.sparse.csgraph.dijkstra` from several sources at once on a
:func:`graph_matrix`, built once and searched as often as needed.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components, dijkstra, minimum_spanning_tree

__all__ = ["components", "graph_matrix", "minimum_spanning_forest", "tree_distances"]

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


def graph_matrix(n: int, i: npt.ArrayLike, j: npt.ArrayLike, weight: npt.ArrayLike) -> csr_matrix:
    """The edges as a sparse matrix, each once above the diagonal (weights > 0).

    Examples
    --------
    >>> graph_matrix(3, [1, 0], [0, 2], [2.0, 5.0]).toarray().tolist()
    [[0.0, 2.0, 5.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    """
    a, b = _edges(n, i, j)
    w = np.asarray(weight, dtype=np.float64).ravel()
    if w.shape != a.shape:
        raise ValueError(f"weight must have one entry per edge ({a.size}), got {w.size}")
    return csr_matrix((w, (np.minimum(a, b), np.maximum(a, b))), shape=(n, n))


def components(n: int, i: npt.ArrayLike, j: npt.ArrayLike) -> tuple[int, IntArray]:
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
    >>> k, labels = components(6, [4, 1, 5], [2, 4, 3])
    >>> k, labels.tolist()
    (3, [0, 1, 1, 2, 1, 2])
    """
    a, b = _edges(n, i, j)
    k, labels = connected_components(graph_matrix(n, a, b, np.ones(a.size)), directed=False)
    return int(k), labels.astype(np.intp)


def minimum_spanning_forest(
    n: int, i: npt.ArrayLike, j: npt.ArrayLike, weight: npt.ArrayLike
) -> tuple[IntArray, IntArray]:
    """The edges of a minimum spanning forest, and the trees of the nodes.

    Ties go as scipy's Kruskal takes them: the edges sorted stably by weight in the
    order of the matrix's rows (``(min(i, j), max(i, j))``), whatever the order given.

    Parameters
    ----------
    n : int
        Number of nodes.
    i, j : array_like of int, shape (E,)
        Edge ends (nodes ``0 .. n-1``), each node pair at most once.
    weight : array_like of float, shape (E,)
        Edge weights (finite, > 0).

    Returns
    -------
    edges : ndarray of intp
        Indices of the forest's edges, ascending: ``n - k`` of them for ``k`` trees.
    labels : ndarray of intp, shape (n,)
        Tree of each node, as :func:`components` numbers them.

    Examples
    --------
    A triangle and a separate edge: the triangle's heaviest edge goes.

    >>> edges, labels = minimum_spanning_forest(
    ...     5, [0, 1, 0, 3], [1, 2, 2, 4], [1.0, 1.0, 2.0, 5.0])
    >>> edges.tolist(), labels.tolist()
    ([0, 1, 3], [0, 0, 0, 1, 1])
    """
    a, b = _edges(n, i, j)
    w = np.asarray(weight, dtype=np.float64).ravel()
    if w.shape != a.shape:
        raise ValueError(f"weight must have one entry per edge ({a.size}), got {w.size}")
    if not (np.isfinite(w).all() and (w > 0).all()):
        raise ValueError("edge weights must be finite and > 0")
    forest = minimum_spanning_tree(graph_matrix(n, a, b, w)).tocoo()
    # back to the edges given: each node pair once, so its key finds it
    key = np.minimum(a, b).astype(np.int64) * max(n, 1) + np.maximum(a, b)
    by_key = np.argsort(key, kind="stable")
    want = forest.row.astype(np.int64) * max(n, 1) + forest.col
    edges = np.sort(by_key[np.searchsorted(key[by_key], want)]).astype(np.intp)
    _, labels = connected_components(forest, directed=False)
    return edges, labels.astype(np.intp)


def tree_distances(graph: csr_matrix, sources: npt.ArrayLike) -> FloatArray:
    """Distance of every node from the nearest source along the edges of ``graph``.

    Parameters
    ----------
    graph : scipy.sparse.csr_matrix
        The edges and their lengths (:func:`graph_matrix`), undirected.
    sources : array_like of int
        Source nodes (on a forest: one per tree, so each node's distance is along its
        own tree).

    Returns
    -------
    ndarray of float, shape (n,)
        inf where no source is reachable.

    Examples
    --------
    A path 0 - 1 - 2 - 3 and a lone edge 4 - 5, from nodes 2 and 5:

    >>> g = graph_matrix(6, [0, 1, 2, 4], [1, 2, 3, 5], [1.0, 2.0, 4.0, 0.5])
    >>> tree_distances(g, [2, 5]).tolist()
    [3.0, 2.0, 0.0, 4.0, 0.5, 0.0]
    """
    src = np.unique(np.asarray(sources, dtype=np.intp).ravel())
    if src.size == 0:
        return np.full(graph.shape[0], np.inf)
    got = dijkstra(graph, directed=False, indices=src, min_only=True)
    return np.asarray(got, dtype=np.float64)

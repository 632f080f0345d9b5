"""The extraction's graphs (scipy's csgraph on edge lists): hand-made graphs with exact
answers; the spanning forest's edges given back as indices into the list, whatever its order."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components as scipy_components
from scipy.sparse.csgraph import minimum_spanning_tree

from sonarproc.surfaces.extraction.graphs import (
    components,
    graph_matrix,
    minimum_spanning_forest,
    tree_distances,
)

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def _random_graph(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Edges over n nodes, each node pair at most once, no self loops (i < j)."""
    m = int(rng.integers(0, 3 * n + 1))
    i, j = rng.integers(0, n, m), rng.integers(0, n, m)
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    pairs = np.unique(np.stack((lo, hi), axis=1)[lo != hi], axis=0)
    pairs = pairs[rng.permutation(pairs.shape[0])]
    return pairs[:, 0], pairs[:, 1]


def _scipy_graph(n: int, i: np.ndarray, j: np.ndarray, w: np.ndarray) -> coo_matrix:
    """The edges as scipy takes them: each once, above the diagonal."""
    return coo_matrix((w, (np.minimum(i, j), np.maximum(i, j))), shape=(n, n))


def test_components_of_a_hand_made_graph() -> None:
    # 0-1-2 with a repeated edge and a self loop, 3 alone, 4-6 and 5-6
    i = [2, 0, 1, 6, 5, 1]
    j = [1, 1, 2, 4, 6, 1]
    k, labels = components(7, i, j)
    assert k == 3
    assert labels.tolist() == [0, 0, 0, 1, 2, 2, 2]
    assert labels.dtype == np.intp


def test_components_of_no_nodes_and_of_no_edges() -> None:
    k, labels = components(0, [], [])
    assert (k, labels.tolist()) == (0, [])
    k, labels = components(3, [], [])
    assert (k, labels.tolist()) == (3, [0, 1, 2])


def test_a_long_path_numbered_backwards_is_one_component() -> None:
    n = 5000
    k, labels = components(n, np.arange(n - 1, 0, -1), np.arange(n - 2, -1, -1))
    assert k == 1 and not labels.any()


@pytest.mark.parametrize(
    ("i", "j", "message"),
    [([0, 1], [1], "one length"), ([0], [3], "nodes 0 .. 2"), ([-1], [0], "nodes 0 .. 2")],
)
def test_bad_edges_are_refused(i: list[int], j: list[int], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        components(3, i, j)


@settings(max_examples=60, deadline=None)
@given(SEEDS, st.integers(1, 80))
def test_components_equal_scipys_labels(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    i, j = _random_graph(rng, n)
    k, labels = components(n, i, j)
    want_k, want = scipy_components(_scipy_graph(n, i, j, np.ones(i.size)), directed=False)
    assert k == want_k
    assert labels.tolist() == want.tolist()


def test_spanning_forest_of_a_hand_made_graph() -> None:
    # a square 0-1-2-3 with a diagonal, all sides 1 (ties), and a separate edge 4-5
    i = [0, 1, 2, 3, 0, 4]
    j = [1, 2, 3, 0, 2, 5]
    w = [1.0, 1.0, 1.0, 1.0, 1.2, 0.5]
    edges, labels = minimum_spanning_forest(6, i, j, w)
    # the equal sides in the order (0, 1), (0, 3), (1, 2), (2, 3): the last one closes a cycle
    assert edges.tolist() == [0, 1, 3, 5]
    assert labels.tolist() == [0, 0, 0, 0, 1, 1]


def test_spanning_forest_without_edges() -> None:
    edges, labels = minimum_spanning_forest(3, [], [], [])
    assert edges.tolist() == [] and labels.tolist() == [0, 1, 2]


def test_spanning_forest_refuses_bad_weights() -> None:
    with pytest.raises(ValueError, match="one entry per edge"):
        minimum_spanning_forest(3, [0, 1], [1, 2], [1.0])
    with pytest.raises(ValueError, match="finite"):
        minimum_spanning_forest(3, [0, 1], [1, 2], [1.0, np.nan])
    with pytest.raises(ValueError, match="> 0"):
        minimum_spanning_forest(3, [0, 1], [1, 2], [1.0, 0.0])


@settings(max_examples=60, deadline=None)
@given(SEEDS, st.integers(1, 80), st.booleans())
def test_spanning_forest_equals_scipys(seed: int, n: int, ties: bool) -> None:
    rng = np.random.default_rng(seed)
    i, j = _random_graph(rng, n)
    w = rng.integers(1, 4, i.size) * 0.5 if ties else rng.uniform(0.1, 2.0, i.size)
    edges, labels = minimum_spanning_forest(n, i, j, w)
    tree = minimum_spanning_tree(_scipy_graph(n, i, j, w).tocsr()).tocoo()
    k, want_labels = scipy_components(_scipy_graph(n, i, j, w), directed=False)
    assert edges.size == n - k
    assert np.all(np.diff(edges) > 0)
    assert labels.tolist() == want_labels.tolist()
    assert np.isclose(w[edges].sum(), tree.data.sum(), rtol=1e-12, atol=0.0)
    # the same tie-break as scipy's stable sort of the edges row by row: the same tree
    got = sorted(zip(np.minimum(i, j)[edges].tolist(), np.maximum(i, j)[edges].tolist(),
                     strict=True))  # fmt: skip
    assert got == sorted(zip(tree.row.tolist(), tree.col.tolist(), strict=True))
    # and whatever the order of the edges or of their ends
    flip = rng.permutation(i.size)
    again, _ = minimum_spanning_forest(n, j[flip], i[flip], w[flip])
    assert sorted(flip[again].tolist()) == edges.tolist()


def test_distances_along_a_hand_made_forest() -> None:
    # a star 3-(0, 1, 2) with 2-4 beyond, then 5-6 without a source, and 7 alone (a source)
    i = [3, 1, 2, 4, 5]
    j = [0, 3, 3, 2, 6]
    w = [1.0, 2.0, 0.5, 0.25, 9.0]
    g = graph_matrix(8, i, j, w)
    got = tree_distances(g, [4, 7])
    assert got.tolist() == [1.75, 2.75, 0.25, 0.75, 0.0, np.inf, np.inf, 0.0]
    assert tree_distances(g, [1]).tolist()[:5] == [3.0, 0.0, 2.5, 2.0, 2.75]
    assert np.isinf(tree_distances(graph_matrix(3, [0], [1], [1.0]), [])).all()

"""The longest path of every tree of a spanning forest, side branches split off.

A surface is its tree's longest path, found with two distance passes along every tree
at once (from any node to the farthest, ``u``; from ``u`` to the farthest, ``v``; the
path is where ``d(u) + d(v)`` equals the length; :func:`scipy.sparse.csgraph.dijkstra`).
A node off the path hangs on the nearest path node of its tree in the plane (on a thick
band the tree may run beside the path for a long way) and takes that node's arc length.
Side branches reaching more than ``bridge_m`` off the path, whose farthest node is at
least ``min_length_m`` from it, become trees of their own and go round again (at most
:data:`MAX_ROUNDS` rounds). A tree whose path ends lie within ``1.5 bridge_m`` of each
other, around a path at least ``4 bridge_m`` long, is closed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt
from scipy.sparse import csr_matrix

from sonarproc.surfaces.extraction.graphs import components, graph_matrix, tree_distances
from sonarproc.surfaces.planar.runs import bounds_of
from sonarproc.surfaces.planar.search import nearest_in_run, nearest_within

__all__ = ["MAX_ROUNDS", "TreePaths", "tree_paths"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

#: Rounds of branch splitting (a branch of a branch of ...); deeper ones stay attached.
MAX_ROUNDS = 6


class PathParams(Protocol):
    """The lengths :func:`tree_paths` uses (:class:`~sonarproc.surfaces.SurfaceParams`)."""

    @property
    def bridge_m(self) -> float: ...

    @property
    def min_length_m(self) -> float: ...


@dataclass(frozen=True)
class TreePaths:
    """Per node: its tree (group), arc length along the tree's path, the node it hangs on.

    Attributes
    ----------
    group : ndarray of intp
        Final group of each node (trees split off get new ids).
    s : ndarray of float
        Arc length (m) along the group's path (of the node it hangs on when off it).
    on_path : ndarray of bool
        The node lies on its group's path.
    anchor : ndarray of intp
        The path node whose arc length the node has (itself on the path); -1 when its
        group never got a path (split off in the last round).
    loop : ndarray of float
        Per group id: path length plus the gap between its ends for a closed group,
        NaN for an open one.
    """

    group: IntArray
    s: FloatArray
    on_path: BoolArray
    anchor: IntArray
    loop: FloatArray


def _argmax_per_group(values: FloatArray, order: IntArray, bounds: IntArray) -> IntArray:
    """Per run of ``order`` (nodes sorted by group, then index): its largest finite value.

    Ties go to the highest node index.
    """
    v = values[order]
    v = np.where(np.isfinite(v), v, -1.0)
    top = np.maximum.reduceat(v, bounds[:-1])
    at_top = np.where(v == np.repeat(top, np.diff(bounds)), order, -1)
    return np.asarray(np.maximum.reduceat(at_top, bounds[:-1]), dtype=np.intp)


def _along(forest: tuple[csr_matrix, IntArray, IntArray], sources: IntArray, n: int) -> FloatArray:
    """Distances along the active nodes' trees from ``sources`` (inf off them).

    ``forest`` is the active nodes' forest (:func:`graph_matrix`, numbered among them),
    the active nodes and the number of each node among them.
    """
    graph, act, local = forest
    d = np.full(n, np.inf)
    d[act] = tree_distances(graph, local[sources])
    return d


def _near_path(
    pairs: tuple[IntArray, IntArray, FloatArray], path: BoolArray
) -> tuple[FloatArray, IntArray]:
    """Nearest path node of each off node among its pairs (ties: the lower index).

    The pairs are those of the active nodes within a group, so a path node within the
    pair distance is the nearest one of the group. Others: inf and -1.
    """
    n = path.size
    dist = np.full(n, np.inf)
    src = np.full(n, -1, dtype=np.intp)
    a, b, d2 = pairs
    near = ~path[a] & path[b]
    a, b, d2 = a[near], b[near], d2[near]
    best = np.full(n, np.inf)
    np.minimum.at(best, a, d2)
    tie = d2 == best[a]
    top = np.iinfo(np.intp).max
    nearest = np.full(n, top, dtype=np.intp)
    np.minimum.at(nearest, a[tie], b[tie])
    found = nearest < top
    dist[found], src[found] = np.sqrt(best[found]), nearest[found]
    return dist, src


def _far_path(
    pos: FloatArray, far: IntArray, path: BoolArray, group: IntArray, reach: float
) -> tuple[FloatArray, IntArray]:
    """Nearest path node of each far node (none within the pair distance).

    With a finite ``reach``, only that far: a node farther than ``reach`` from the path
    is in a long branch, whose nodes get a path of their own next round (inf and -1).
    """
    on = np.flatnonzero(path)
    if np.isfinite(reach):
        return nearest_within(pos, far, on, group, reach)
    on = on[np.argsort(group[on], kind="stable")]
    ids = np.unique(group[on])
    run = np.searchsorted(ids, group[far])
    return nearest_in_run(pos, far, on, bounds_of(group[on], ids), run)


def tree_paths(
    forest: tuple[IntArray, IntArray, FloatArray],
    pos: FloatArray,
    labels: IntArray,
    pairs: tuple[IntArray, IntArray, FloatArray],
    p: PathParams,
) -> TreePaths:
    """Longest paths of the spanning forest, branches split off round by round.

    Parameters
    ----------
    forest : tuple of ndarray
        ``i, j, w``: the edges of the nodes' minimum spanning forest and their lengths (m).
    pos : ndarray, shape (N, 2)
        Node positions (m).
    labels : ndarray of intp
        Tree of each node (``0 .. T-1``).
    pairs : tuple of ndarray
        ``i, j, d2``: node pairs (``i < j``) closer than ``bridge_m`` and their squared
        distances (:func:`~sonarproc.surfaces.planar.search.close_pairs`).
    p : SurfaceParams
        ``bridge_m`` and ``min_length_m``.

    Returns
    -------
    TreePaths
    """
    n = pos.shape[0]
    group = labels.astype(np.intp).copy()
    s = np.zeros(n)
    on_path = np.zeros(n, dtype=bool)
    anchor = np.full(n, -1, dtype=np.intp)
    next_label = int(group.max()) + 1 if n else 0
    loop = np.full(next_label, np.nan)
    both = (
        np.concatenate((pairs[0], pairs[1])),
        np.concatenate((pairs[1], pairs[0])),
        np.concatenate((pairs[2], pairs[2])),
    )
    ei, ej, ew = forest
    active = np.ones(n, dtype=bool)
    for round_ in range(MAX_ROUNDS):
        act = np.flatnonzero(active)
        if act.size == 0:
            break
        if round_ > 0:
            a, b = both[0], both[1]
            inside = active[a] & active[b] & (group[a] == group[b])
            both = (a[inside], b[inside], both[2][inside])
        keep = active[ei] & active[ej] & (group[ei] == group[ej])
        order = act[np.argsort(group[act], kind="stable")]
        sorted_group = group[order]
        starts = np.flatnonzero(np.diff(sorted_group, prepend=-1))
        ids = sorted_group[starts]
        bounds = np.append(starts, order.size).astype(np.intp)
        first = order[bounds[:-1]]
        # the active nodes' trees (one per group), numbered among the active nodes
        local = np.full(n, -1, dtype=np.intp)
        local[act] = np.arange(act.size)
        trees = (graph_matrix(act.size, local[ei[keep]], local[ej[keep]], ew[keep]), act, local)
        d0 = _along(trees, first, n)
        u = _argmax_per_group(d0, order, bounds)
        du = _along(trees, u, n)
        du[~active] = np.nan
        v = _argmax_per_group(du, order, bounds)
        dv = _along(trees, v, n)
        length = np.zeros(next_label + 1)
        length[ids] = du[v]
        tol = 1e-9 * max(1.0, float(np.nanmax(du)) if np.isfinite(du).any() else 1.0)
        path = active & (np.abs(du + dv - length[group]) <= tol)
        on_path |= path
        s[path] = du[path]
        anchor[path] = np.flatnonzero(path)
        gap = np.hypot(*(pos[u] - pos[v]).T)
        shut = (gap <= 1.5 * p.bridge_m) & (du[v] >= 4.0 * p.bridge_m)
        loop[ids[shut]] = du[v][shut] + gap[shut]
        dist, src = _near_path(both, path)
        off = active & ~path
        branch = off & (dist > p.bridge_m)
        if branch.any():
            # branches: components of the forest restricted to branch nodes
            bk = branch[ei] & branch[ej]
            _, blab = components(n, ei[bk], ej[bk])
            far = np.flatnonzero(off & (src < 0))
            if far.size:
                # a node farther than both bridge_m and min_length_m from the path is in
                # a long branch, which gets a path of its own next round: its nearest
                # path node is not needed (but in the last round it is)
                last = round_ == MAX_ROUNDS - 1
                reach = np.inf if last else max(p.bridge_m, p.min_length_m)
                dist[far], src[far] = _far_path(pos, far, path, group, reach)
        hung = off & (src >= 0)
        s[hung] = s[src[hung]]
        anchor[hung] = src[hung]
        if not branch.any():
            break
        bl = blab[branch]
        nb = int(bl.max()) + 1
        # a branch's size: its farthest node from the path
        extent = np.zeros(nb)
        np.maximum.at(extent, bl, dist[branch])
        long_b = extent >= p.min_length_m
        newly = np.flatnonzero(branch)[long_b[bl]]
        if newly.size == 0:
            break
        active = np.zeros(n, dtype=bool)
        active[newly] = True
        group[newly] = next_label + blab[newly]
        anchor[newly] = -1
        next_label = int(group.max()) + 1
        loop = np.concatenate((loop, np.full(next_label - loop.size, np.nan)))
    return TreePaths(group, s, on_path, anchor, loop)

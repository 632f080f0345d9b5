"""Split kept cells into separate surfaces, each ordered along its length.

The cells (cell centres in world metres) are first pooled into *nodes*: squares of side
``h = max(cell, bridge_m / 4)``, each node at the mean of its cells, so that thick bands
and thin ridges cost about the same. Nodes closer than ``bridge_m`` are joined (that is
the gap bridging), and each connected group is reduced to its minimum spanning tree
(:mod:`~sonarproc.surfaces.extraction.graphs`). A surface is the tree's longest path (found
with two distance passes along every tree at once); nodes off that path hang on it, at the arc
length of the path node they hang from. Side branches that reach more than ``bridge_m``
off the path and are at least ``min_length_m`` long (a T junction, a box against a wall)
become groups of their own and go round again. A group whose two path ends lie within
``1.5 bridge_m`` of each other, around a path at least ``4 bridge_m`` long, is closed (a
pillar seen all round).

Each path is then cut at corners: where the turning angle between the chords
``p(s - w) -> p(s)`` and ``p(s) -> p(s + w)`` (``w = corner_window_m``) reaches
``corner_deg`` and is the largest within ``w``. Nothing assumes y = f(x): the order is
the arc length along the tree, so vertical walls, closed shapes and folds work alike.

Every step works on all groups at once: the node pairs come from a k-d tree
(:mod:`~sonarproc.surfaces.planar.search`), the paths from
:mod:`~sonarproc.surfaces.extraction.paths`, centre lines and corners from
:mod:`~sonarproc.surfaces.extraction.corners` (numpy on runs of one array,
:mod:`~sonarproc.surfaces.planar.runs`). A centre-line point sums its neighbours in
ascending order, so equal inputs give equal outputs to the last bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarproc.grid import Grid
from sonarproc.surfaces.extraction.corners import centrelines, corners
from sonarproc.surfaces.extraction.graphs import minimum_spanning_forest
from sonarproc.surfaces.extraction.paths import TreePaths, tree_paths
from sonarproc.surfaces.planar.runs import bounds_of, run_searchsorted
from sonarproc.surfaces.planar.search import close_pairs

__all__ = ["SurfaceCells", "SurfaceParams", "cells_of", "extract_surfaces"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True)
class SurfaceParams:
    """How cells are grouped into surfaces (lengths in metres, angles in degrees).

    Attributes
    ----------
    bridge_m : float
        Cells closer than this belong to one surface (gaps up to this long are bridged).
    corner_deg : float
        A turn at least this sharp within ``corner_window_m`` splits a surface.
    corner_window_m : float
        Chord length on each side of a point for its turning angle.
    min_length_m : float
        Surfaces shorter than this are dropped (their cells counted as unassigned).
    """

    bridge_m: float = 0.10
    corner_deg: float = 45.0
    corner_window_m: float = 0.10
    min_length_m: float = 0.20

    def __post_init__(self) -> None:
        for name in ("bridge_m", "corner_window_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be > 0 m, got {v!r}")
        if not (math.isfinite(self.min_length_m) and self.min_length_m >= 0):
            raise ValueError(f"min_length_m must be >= 0 m, got {self.min_length_m!r}")
        if not 0 < self.corner_deg < 180:
            raise ValueError(f"corner_deg must be in (0, 180), got {self.corner_deg!r}")


@dataclass(frozen=True)
class SurfaceCells:
    """The cells of one surface, in order along it.

    Attributes
    ----------
    x, y : ndarray, shape (P,)
        Cell centres (m), sorted by ``s``.
    s : ndarray, shape (P,)
        Arc length (m) along the surface of each cell, from 0, non-decreasing.
    weight : ndarray, shape (P,)
        Evidence of each cell (arcs crossing it; 1 without counts).
    closed : bool
        The surface closes on itself (seen all round).
    """

    x: FloatArray
    y: FloatArray
    s: FloatArray
    weight: FloatArray
    closed: bool

    @property
    def size(self) -> int:
        """Number of cells."""
        return int(self.x.size)

    @property
    def extent_m(self) -> float:
        """Arc length from the first to the last cell (m)."""
        return float(self.s[-1] - self.s[0]) if self.s.size else 0.0


def cells_of(
    mask: npt.ArrayLike, grid: Grid, counts: npt.ArrayLike | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """World centres ``x, y`` of the set cells of a map, and their weights (counts or 1).

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=0.5, nx=3, ny=2)
    >>> x, y, w = cells_of(np.array([[0, 1, 0], [0, 0, 1]], bool), g)
    >>> x.tolist(), y.tolist(), w.tolist()
    ([0.5, 1.0], [0.0, 0.5], [1.0, 1.0])
    """
    m = np.asarray(mask, dtype=bool)
    if m.shape != grid.shape:
        raise ValueError(f"map shape {m.shape} does not match the grid {grid.shape}")
    iy, ix = np.nonzero(m)
    x = grid.x0 + grid.cell * ix.astype(np.float64)
    y = grid.y0 + grid.cell * iy.astype(np.float64)
    if counts is None:
        return x, y, np.ones_like(x)
    c = np.asarray(counts)
    if c.shape != m.shape:
        raise ValueError("counts and mask must have one shape")
    return x, y, np.maximum(c[iy, ix].astype(np.float64), 1.0)


def _nodes(x: FloatArray, y: FloatArray, h: float) -> tuple[IntArray, FloatArray]:
    """Pool points into squares of side h: node of each point, node positions."""
    kx = np.floor(x / h).astype(np.int64)
    ky = np.floor(y / h).astype(np.int64)
    key = (kx - kx.min()) * (int(ky.max() - ky.min()) + 1) + (ky - ky.min())
    _, node, count = np.unique(key, return_inverse=True, return_counts=True)
    node = node.ravel()
    pos = np.stack(
        (np.bincount(node, weights=x) / count, np.bincount(node, weights=y) / count), axis=1
    )
    return node.astype(np.intp), pos


def extract_surfaces(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    *,
    cell: float,
    weight: npt.ArrayLike | None = None,
    params: SurfaceParams | None = None,
) -> list[SurfaceCells]:
    """Group cells into surfaces, each ordered along its length.

    Parameters
    ----------
    x, y : array_like, shape (P,)
        Cell centres (m), e.g. from :func:`cells_of`.
    cell : float
        Cell size (m).
    weight : array_like, shape (P,), optional
        Evidence per cell (arc counts); carried along, not used for the grouping.
    params : SurfaceParams, optional
        Bridging, corners and minimum length (defaults: :class:`SurfaceParams`).

    Returns
    -------
    list of SurfaceCells
        Longest first. Empty when no group of cells is ``min_length_m`` long.

    Examples
    --------
    Two parallel walls 0.5 m apart, the lower one with a 5 cm gap (bridged):

    >>> xs = np.round(np.arange(0.0, 1.0, 0.01), 2)
    >>> lower = xs[(xs < 0.4) | (xs > 0.45)]
    >>> x = np.concatenate((lower, xs)); y = np.concatenate((0 * lower, 0 * xs + 0.5))
    >>> found = extract_surfaces(x, y, cell=0.01)
    >>> sorted((round(float(np.mean(f.y)), 2), f.size) for f in found)
    [(0.0, 94), (0.5, 100)]
    """
    p = params or SurfaceParams()
    px = np.asarray(x, dtype=np.float64).ravel()
    py = np.asarray(y, dtype=np.float64).ravel()
    pw = np.ones_like(px) if weight is None else np.asarray(weight, dtype=np.float64).ravel()
    if not (px.shape == py.shape == pw.shape):
        raise ValueError("x, y and weight must have one length")
    if not (math.isfinite(cell) and cell > 0):
        raise ValueError(f"cell must be > 0 m, got {cell!r}")
    if px.size == 0:
        return []
    h = max(cell, p.bridge_m / 4.0)
    node, pos = _nodes(px, py, h)
    n = pos.shape[0]
    pi, pj, d2 = close_pairs(pos, p.bridge_m + 1e-9)
    xs, ys = pos[:, 0].copy(), pos[:, 1].copy()  # contiguous: faster gathers
    d = np.hypot(xs[pi] - xs[pj], ys[pi] - ys[pj]) + 1e-12
    # the forest's trees are the connected groups: one pass gives both
    tree, labels = minimum_spanning_forest(n, pi, pj, d)
    # groups too small to hold a surface min_length_m long go now (noise): a surface of
    # length L spans a box whose diagonal is at least about 0.45 L (a full circle)
    big = _diagonal(pos, labels)[labels] >= 0.4 * p.min_length_m
    if not big.any():
        return []
    sub = np.flatnonzero(big)
    remap = np.full(n, -1, dtype=np.intp)
    remap[sub] = np.arange(sub.size)
    node = remap[node]
    keep_pt = node >= 0
    px, py, pw, node = px[keep_pt], py[keep_pt], pw[keep_pt], node[keep_pt]
    pos = pos[sub]
    n = sub.size
    # whole components are kept: their labels, renumbered in the same order
    kept_label = np.zeros(int(labels.max()) + 1, dtype=bool)
    kept_label[labels[sub]] = True
    labels = (np.cumsum(kept_label) - 1)[labels[sub]].astype(np.intp)
    kept_pair = big[pi]
    pairs = (remap[pi[kept_pair]], remap[pj[kept_pair]], d2[kept_pair])
    tree = tree[big[pi[tree]]]
    forest = (remap[pi[tree]], remap[pj[tree]], d[tree])
    paths = tree_paths(forest, pos, labels, pairs, p)
    piece, s_node, loop = _pieces(paths, pos, pairs, p)
    return _surfaces(px, py, pw, paths.group[node], piece[node], s_node[node], loop, p)


def _diagonal(pos: FloatArray, labels: IntArray) -> FloatArray:
    """Diagonal (m) of the bounding box of each labelled group of points."""
    k = int(labels.max()) + 1
    ext = []
    for axis in (0, 1):
        hi = np.full(k, -np.inf)
        lo = np.full(k, np.inf)
        np.maximum.at(hi, labels, pos[:, axis])
        np.minimum.at(lo, labels, pos[:, axis])
        ext.append(hi - lo)
    return np.asarray(np.hypot(ext[0], ext[1]), dtype=np.float64)


def _pieces(
    paths: TreePaths, pos: FloatArray, pairs: tuple[IntArray, IntArray, FloatArray],
    p: SurfaceParams,
) -> tuple[IntArray, FloatArray, FloatArray]:  # fmt: skip
    """Per node: its piece of its group (cut at corners) and arc length along the centre line.

    Also the loop length of each closed group along its centre line (NaN when open); a
    closed group with corners is open pieces, the one across its start continued
    round (its arc lengths past the loop length).
    """
    n = pos.shape[0]
    group = paths.group
    on = np.flatnonzero(paths.on_path)
    # by group, then arc length (complex numbers sort by real, then imaginary part)
    on = on[np.argsort(group[on] + 1j * paths.s[on], kind="stable")]
    ids = np.unique(group[on])
    bounds = bounds_of(group[on], ids)
    centre, new_s = centrelines(on, bounds, pos, group, pairs, 0.5 * p.bridge_m)
    # arc length along the centre line, not along the zig-zag of the path: every node
    # has the arc length of the path node it hangs on
    place = np.full(n, -1, dtype=np.intp)
    place[on] = np.arange(on.size)
    s_node = paths.s.copy()
    hung = np.flatnonzero(paths.anchor >= 0)
    s_node[hung] = new_s[place[paths.anchor[hung]]]
    loop = paths.loop.copy()
    shut = np.isfinite(loop[ids])
    last = bounds[1:] - 1
    end_gap = np.hypot(*(centre[last] - centre[bounds[:-1]]).T)
    loop_ids = np.full(ids.size, np.nan)
    loop_ids[shut] = new_s[last[shut]] + end_gap[shut]
    loop[ids] = loop_ids
    cs, crun = corners(new_s, centre, bounds, loop_ids, window=p.corner_window_m,
                       corner_deg=p.corner_deg)  # fmt: skip
    # nodes of groups with a path: which piece (corners passed), by group
    piece = np.zeros(n, dtype=np.intp)
    members = hung
    mrun = np.searchsorted(ids, group[members])
    cut_bounds = bounds_of(crun, np.arange(ids.size))
    k = run_searchsorted(cs, cut_bounds, s_node[members], mrun, side="right")
    ncut = np.diff(cut_bounds)[mrun]
    ring = shut[mrun]
    # the piece before a closed group's first corner continues its last one round
    wrap = ring & (ncut > 0) & (k == 0)
    k[wrap] = ncut[wrap]
    s_node[members[wrap]] += loop_ids[mrun[wrap]]
    piece[members] = k
    # a closed group without corners stays one closed piece
    loop[ids[shut & (np.diff(cut_bounds) > 0)]] = np.nan
    return piece, s_node, loop


def _surfaces(
    px: FloatArray, py: FloatArray, pw: FloatArray, group: IntArray, piece: IntArray,
    s: FloatArray, loop: FloatArray, p: SurfaceParams,
) -> list[SurfaceCells]:  # fmt: skip
    """The cells of each (group, piece), ordered by arc length; long ones, longest first."""
    # by (group, piece), then arc length (complex numbers sort by real, then imaginary)
    whole = group.astype(np.float64) * (int(piece.max()) + 1) + piece
    order = np.argsort(whole + 1j * s, kind="stable")
    g, pc, ss = group[order], piece[order], s[order]
    cut = np.flatnonzero((g[1:] != g[:-1]) | (pc[1:] != pc[:-1])) + 1
    starts = np.concatenate(([0], cut))
    ends = np.concatenate((cut, [order.size]))
    first, final = ss[starts], ss[ends - 1]
    ring = np.isfinite(loop[g[starts]]) & (pc[starts] == 0)
    length = np.where(ring, loop[g[starts]], final - first)
    long = np.flatnonzero(length >= p.min_length_m)
    x, y, w = px[order], py[order], pw[order]
    rel = ss - np.repeat(first, ends - starts)
    out = [
        SurfaceCells(x[a:b], y[a:b], rel[a:b], w[a:b], bool(r))
        for a, b, r in zip(starts[long].tolist(), ends[long].tolist(), ring[long].tolist(),
                           strict=True)
    ]  # fmt: skip
    out.sort(key=lambda c: (-c.extent_m, -c.size))
    return out

"""The surface extraction as first written: one group at a time, k-d trees per group.

The oracle for :func:`sonarproc.surfaces.extract_surfaces`, which does the same for
all groups at once. Two choices the first version left to the k-d tree are fixed here
as the vectorised version makes them: an off-path node hangs on the nearest path node
with the lowest index among equally near ones, and a centre-line point is the mean of
its neighbours summed in ascending node order.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import connected_components, dijkstra, minimum_spanning_tree
from scipy.spatial import cKDTree

from sonarproc.surfaces import SurfaceCells, SurfaceParams

__all__ = ["extract_surfaces_reference"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Rounds of branch splitting (a branch of a branch of ...); deeper ones stay attached.
MAX_ROUNDS = 6


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


def _argmax_per_group(values: FloatArray, group: IntArray, groups: IntArray) -> IntArray:
    """Index of the largest finite value in each group of ``groups`` (sorted ids)."""
    v = np.where(np.isfinite(values), values, -1.0)
    order = np.lexsort((v, group))
    last = np.searchsorted(group[order], groups, side="right") - 1
    return np.asarray(order[last], dtype=np.intp)


@dataclass
class _Paths:
    """Per node: its group, arc length along the group's path, whether it lies on it."""

    group: IntArray
    s: FloatArray
    on_path: npt.NDArray[np.bool_]
    closed: dict[int, float]  # group -> loop length, for closed groups


def _tree_paths(forest: csr_matrix, pos: FloatArray, labels: IntArray, p: SurfaceParams) -> _Paths:
    """Longest paths of the spanning forest, branches split off round by round."""
    n = pos.shape[0]
    group = labels.astype(np.intp).copy()
    s = np.zeros(n)
    on_path = np.zeros(n, dtype=bool)
    closed: dict[int, float] = {}
    active = np.ones(n, dtype=bool)
    coo = forest.tocoo()
    ei, ej, ew = coo.row, coo.col, coo.data
    next_label = int(group.max()) + 1 if n else 0
    for _ in range(MAX_ROUNDS):
        keep = active[ei] & active[ej] & (group[ei] == group[ej])
        g = csr_matrix((ew[keep], (ei[keep], ej[keep])), shape=(n, n))
        ids = np.unique(group[active])
        if ids.size == 0:
            break
        act = np.flatnonzero(active)
        order = act[np.argsort(group[act], kind="stable")]
        first = order[np.searchsorted(group[order], ids)]
        d0 = np.asarray(dijkstra(g, directed=False, indices=first, min_only=True))
        d0[~active] = np.nan
        u = _argmax_per_group(d0, group, ids)
        du = np.asarray(dijkstra(g, directed=False, indices=u, min_only=True))
        du[~active] = np.nan
        v = _argmax_per_group(du, group, ids)
        dv = np.asarray(dijkstra(g, directed=False, indices=v, min_only=True))
        length = np.zeros(next_label + 1)
        length[ids] = du[v]
        tol = 1e-9 * max(1.0, float(np.nanmax(du)) if np.isfinite(du).any() else 1.0)
        path = active & (np.abs(du + dv - length[group]) <= tol)
        on_path |= path
        s[path] = du[path]
        gap = np.hypot(*(pos[u] - pos[v]).T)
        for gid, lg, gp in zip(ids.tolist(), du[v].tolist(), gap.tolist(), strict=True):
            if gp <= 1.5 * p.bridge_m and lg >= 4.0 * p.bridge_m:
                closed[gid] = lg + gp
        # off-path nodes hang on the nearest path node of their group (in the plane: on a
        # thick band the tree may run beside the path for a long way)
        dist = np.full(n, np.inf)
        src = np.full(n, -1, dtype=np.intp)
        for members in np.split(order, np.searchsorted(group[order], ids[1:])):
            on = members[path[members]]
            off_m = members[~path[members]]
            if off_m.size and on.size:
                dx = pos[off_m][:, None, 0] - pos[on][None, :, 0]
                dy = pos[off_m][:, None, 1] - pos[on][None, :, 1]
                d2 = dx * dx + dy * dy
                kk = np.argmin(d2, axis=1)
                dist[off_m], src[off_m] = np.sqrt(d2[np.arange(off_m.size), kk]), on[kk]
        off = active & ~path & (src >= 0)
        s[off] = s[src[off]]
        branch = off & (dist > p.bridge_m)
        if not branch.any():
            break
        # branches: components of the forest restricted to branch nodes
        bk = branch[ei] & branch[ej]
        bg = csr_matrix((ew[bk], (ei[bk], ej[bk])), shape=(n, n))
        _, blab = connected_components(bg, directed=False)
        bl = blab[branch]
        nb = int(bl.max()) + 1
        # a branch's size: its farthest node from the path, plus the reach of that node
        reach = np.zeros(nb)
        np.maximum.at(reach, bl, dist[branch])
        long_b = reach >= p.min_length_m
        newly = np.flatnonzero(branch)[long_b[bl]]
        if newly.size == 0:
            break
        active = np.zeros(n, dtype=bool)
        active[newly] = True
        group[newly] = next_label + blab[newly]
        next_label = int(group.max()) + 1
    return _Paths(group, s, on_path, closed)


def _centreline(on_xy: FloatArray, xy: FloatArray, radius: float) -> FloatArray:
    """Mean position of the group's nodes within ``radius`` of each path node.

    On a band several nodes thick the longest path of the tree zig-zags across it; the
    mean of the nodes around a path node lies on the band's centre line.
    """
    near = cKDTree(on_xy).sparse_distance_matrix(cKDTree(xy), radius, output_type="ndarray")
    i, j = near["i"], near["j"]
    srt = np.lexsort((j, i))
    i, j = i[srt], j[srt]
    cnt = np.bincount(i, minlength=on_xy.shape[0]).astype(np.float64)
    sx = np.bincount(i, weights=xy[j, 0], minlength=on_xy.shape[0])
    sy = np.bincount(i, weights=xy[j, 1], minlength=on_xy.shape[0])
    ok = cnt > 0
    out = on_xy.copy()
    out[ok, 0], out[ok, 1] = sx[ok] / cnt[ok], sy[ok] / cnt[ok]
    return out


def _corners(sp: FloatArray, xy: FloatArray, loop: float | None, p: SurfaceParams) -> FloatArray:
    """Arc lengths of the corners along one path (nodes sorted by arc length)."""
    w = p.corner_window_m
    total = float(sp[-1]) if sp.size else 0.0
    if sp.size < 3 or (loop is None and total < 2.0 * w):
        return np.zeros(0)
    if loop is not None:
        ext_s = np.concatenate((sp - loop, sp, sp + loop))
        ext = np.concatenate((xy, xy, xy))
        back, ahead = sp - w, sp + w
        ok = np.ones(sp.size, dtype=bool)
    else:
        ext_s, ext = sp, xy
        back, ahead = sp - w, sp + w
        ok = (back >= 0.0) & (ahead <= total)

    def at(t: FloatArray) -> FloatArray:
        return np.stack((np.interp(t, ext_s, ext[:, 0]), np.interp(t, ext_s, ext[:, 1])), axis=1)

    here, prev, nxt = at(sp), at(back), at(ahead)
    a, b = here - prev, nxt - here
    na, nb = np.hypot(*a.T), np.hypot(*b.T)
    cosang = np.einsum("ij,ij->i", a, b) / np.maximum(na * nb, 1e-12)
    angle = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    angle[~ok] = 0.0
    step = max(float(np.median(np.diff(sp))) if sp.size > 1 else w, 1e-9)
    size = 2 * max(1, round(w / step)) + 1
    mode = "wrap" if loop is not None else "constant"
    peak = ndimage.maximum_filter1d(angle, size=size, mode=mode)
    cand = np.flatnonzero((angle >= p.corner_deg) & (angle >= peak))
    if cand.size == 0:
        return np.zeros(0)
    cs = sp[cand]
    keep = np.concatenate(([True], np.diff(cs) > w))
    return np.asarray(cs[keep], dtype=np.float64)


def extract_surfaces_reference(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    *,
    cell: float,
    weight: npt.ArrayLike | None = None,
    params: SurfaceParams | None = None,
) -> list[SurfaceCells]:
    """:func:`sonarproc.surfaces.extract_surfaces`, one group at a time."""
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
    pairs = cKDTree(pos).query_pairs(r=p.bridge_m + 1e-9, output_type="ndarray")
    d = np.hypot(*(pos[pairs[:, 0]] - pos[pairs[:, 1]]).T) + 1e-12
    graph = coo_matrix((d, (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr()
    _, labels = connected_components(graph, directed=False)
    # groups too small to hold a surface min_length_m long go now (noise): a surface of
    # length L spans a box whose diagonal is at least about 0.45 L (a full circle)
    diag = np.hypot(
        *(
            np.stack([ndimage.maximum(pos[:, k], labels, np.arange(labels.max() + 1))
                      - ndimage.minimum(pos[:, k], labels, np.arange(labels.max() + 1))
                      for k in (0, 1)])
        )
    )  # fmt: skip
    big = diag[labels] >= 0.4 * p.min_length_m
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
    graph = graph[sub][:, sub]
    _, labels = connected_components(graph, directed=False)
    forest = minimum_spanning_tree(graph)
    paths = _tree_paths(forest, pos, labels.astype(np.intp), p)

    # per group: corners on the path, then a (group, piece) label for every node
    piece = np.zeros(n, dtype=np.intp)
    s_node = paths.s
    closed_piece: set[tuple[int, int]] = set()
    for gid in np.unique(paths.group).tolist():
        on = np.flatnonzero((paths.group == gid) & paths.on_path)
        if on.size == 0:
            continue
        on = on[np.argsort(paths.s[on], kind="stable")]
        loop = paths.closed.get(gid)
        members = np.flatnonzero(paths.group == gid)
        centre = _centreline(pos[on], pos[members], 0.5 * p.bridge_m)
        # arc length along the centre line, not along the zig-zag of the path
        old_s = paths.s[on]
        new_s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(centre, axis=0).T))))
        paths.s[members] = np.interp(paths.s[members], old_s, new_s)
        if loop is not None:
            loop = float(new_s[-1]) + float(np.hypot(*(centre[-1] - centre[0])))
            paths.closed[gid] = loop
        cs = _corners(new_s, centre, loop, p)
        sm = paths.s[members]
        k = np.searchsorted(cs, sm, side="right")
        if loop is not None and cs.size:
            # the piece before the first corner continues the last one round the loop
            wrap = k == 0
            k[wrap] = cs.size
            s_node[members[wrap]] = sm[wrap] + loop
        elif loop is not None:
            closed_piece.add((gid, 0))
        piece[members] = k

    key = paths.group[node].astype(np.int64) * (int(piece.max()) + 1) + piece[node]
    s_pt = s_node[node]
    order = np.lexsort((s_pt, key))
    key_sorted = key[order]
    starts = np.flatnonzero(np.concatenate(([True], key_sorted[1:] != key_sorted[:-1])))
    out: list[SurfaceCells] = []
    ends = np.concatenate((starts[1:], [order.size]))
    for a, b in zip(starts.tolist(), ends.tolist(), strict=True):
        idx = order[a:b]
        ss = s_pt[idx]
        k0 = int(key_sorted[a])
        gid, pc = divmod(k0, int(piece.max()) + 1)
        is_closed = (gid, pc) in closed_piece
        length = paths.closed[gid] if is_closed else float(ss[-1] - ss[0])
        if length < p.min_length_m:
            continue
        out.append(SurfaceCells(px[idx], py[idx], ss - ss[0], pw[idx], is_closed))
    out.sort(key=lambda c: (-c.extent_m, -c.size))
    return out

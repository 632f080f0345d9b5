"""Centre lines and corners of every surface's path at once.

The paths of all surfaces lie in one array, sorted by (surface, arc length); surface
``g`` is the run ``bounds[g]:bounds[g + 1]``.

- :func:`centrelines`: on a band several nodes thick the longest path of the tree
  zig-zags across it; the mean of the surface's nodes within ``radius`` of a path node
  lies on the band's centre line. The arc length is then measured along that line.
- :func:`corners`: a corner is where the turning angle between the chords
  ``p(s - w) -> p(s)`` and ``p(s) -> p(s + w)`` reaches ``corner_deg`` and is the
  largest within ``w`` path steps' worth of arc length (``w = corner_window_m``); of
  corners closer than ``w`` the first is kept. A closed path wraps round.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.runs import ragged_arange, run_cumsum, run_interp, run_median

__all__ = ["centrelines", "corners"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]


def centrelines(
    path_nodes: IntArray,
    bounds: IntArray,
    pos: FloatArray,
    group: IntArray,
    pairs: tuple[IntArray, IntArray, FloatArray],
    radius: float,
) -> tuple[FloatArray, FloatArray]:
    """Centre-line points of every path and the arc length along them.

    Parameters
    ----------
    path_nodes : ndarray of intp
        The path nodes, sorted by (group, arc length along the tree).
    bounds : ndarray of intp
        Run bounds of each group in ``path_nodes``.
    pos : ndarray, shape (N, 2)
        Node positions (m).
    group : ndarray of intp
        Group of every node.
    pairs : tuple of ndarray
        ``i, j, d2``: node pairs (``i < j``) with squared distances, all those at most
        ``radius`` apart among them.
    radius : float
        Nodes of a path node's group within this distance (m) are averaged.

    Returns
    -------
    centre : ndarray, shape (P, 2)
        Centre-line point of each path node.
    s : ndarray, shape (P,)
        Arc length (m) along the centre line, from 0 at each path's start.
    """
    n = pos.shape[0]
    on = np.zeros(n, dtype=bool)
    on[path_nodes] = True
    i, j, d2 = pairs
    near = (d2 <= radius * radius) & (group[i] == group[j]) & (on[i] | on[j])
    # summed in one order, ascending node index: two path nodes with the same
    # neighbours get the same centre to the last bit (and a step of exactly 0). With
    # the pairs (i < j) sorted, node a meets its neighbours i < a (pairs (i, a)), then
    # itself, then its neighbours j > a (pairs (a, j)), each in ascending order
    key = np.sort(i[near].astype(np.int64) * n + j[near])
    i, j = key // n, key % n
    order = np.concatenate((j, path_nodes, i))
    other = np.concatenate((i, path_nodes, j))
    keep = on[order]
    a, b = order[keep], other[keep]
    cnt = np.bincount(a, minlength=n).astype(np.float64)
    sx = np.bincount(a, weights=pos[b, 0], minlength=n)
    sy = np.bincount(a, weights=pos[b, 1], minlength=n)
    centre = np.stack((sx[path_nodes] / cnt[path_nodes], sy[path_nodes] / cnt[path_nodes]), 1)
    step = np.zeros(path_nodes.size)
    step[1:] = np.hypot(*np.diff(centre, axis=0).T)
    step[bounds[:-1][np.diff(bounds) > 0]] = 0.0
    return centre, run_cumsum(step, bounds)


def _peaks(angle: FloatArray, cand: IntArray, run: IntArray, half: IntArray, bounds: IntArray,
           closed: BoolArray) -> BoolArray:  # fmt: skip
    """Which candidates are the largest angle within ``half`` places on each side.

    Outside an open path the angle counts as 0 (below any candidate); a closed path
    wraps round (a window longer than the path covers it once).
    """
    lo, size, h = bounds[:-1][run], np.diff(bounds)[run], half[run]
    ring = closed[run]
    whole = ring & (2 * h + 1 >= size)
    end = lo + size - 1
    first = np.where(whole, lo, np.where(ring, cand - h, np.maximum(lo, cand - h)))
    last = np.where(whole, end, np.where(ring, cand + h, np.minimum(end, cand + h)))
    which, k = ragged_arange(last - first + 1)
    at = first[which] + k
    at = lo[which] + (at - lo[which]) % size[which]
    beaten = angle[at] > angle[cand[which]]
    return np.bincount(which[beaten], minlength=cand.size) == 0


def corners(
    s: FloatArray,
    centre: FloatArray,
    bounds: IntArray,
    loop: FloatArray,
    *,
    window: float,
    corner_deg: float,
) -> tuple[FloatArray, IntArray]:
    """Arc lengths of the corners along every path.

    Parameters
    ----------
    s : ndarray, shape (P,)
        Arc length of every path point, ascending within each path.
    centre : ndarray, shape (P, 2)
        The path points.
    bounds : ndarray of intp
        Run bounds of each path.
    loop : ndarray of float
        Per path: its loop length when closed, NaN when open.
    window : float
        Chord length ``w`` (m) on each side.
    corner_deg : float
        Smallest turning angle of a corner (degrees).

    Returns
    -------
    at : ndarray of float
        Corner arc lengths, sorted by (path, arc length).
    run : ndarray of intp
        The path of each corner.
    """
    w = window
    npath = bounds.size - 1
    size = np.diff(bounds)
    run = np.repeat(np.arange(npath), size)
    closed = np.isfinite(loop)
    total = np.zeros(npath)
    total[size > 0] = s[bounds[1:][size > 0] - 1]
    live = (size >= 3) & (closed | (total >= 2.0 * w))
    # the knots of each path; a closed one's three times round (s - L, s, s + L)
    reps = np.where(closed, 3, 1) * size
    knot_bounds = np.concatenate(([0], np.cumsum(reps))).astype(np.intp)
    kr, kk = ragged_arange(reps)
    base = bounds[:-1][kr] + kk % np.maximum(size[kr], 1)
    turn = np.where(closed[kr], kk // np.maximum(size[kr], 1) - 1, 0)
    lp = np.where(closed, loop, 0.0)[kr]
    ks = np.where(turn < 0, s[base] - lp, np.where(turn > 0, s[base] + lp, s[base]))
    back, ahead = s - w, s + w
    ok = closed[run] | ((back >= 0.0) & (ahead <= total[run]))
    # np.interp at a knot gives the last of the knots equal to it: the point itself,
    # or the last of those with the same arc length
    last = np.ones(s.size, dtype=bool)
    last[:-1] = (s[1:] != s[:-1]) | (run[1:] != run[:-1])
    ends = np.flatnonzero(last)
    here = centre[ends[np.searchsorted(ends, np.arange(s.size))]]
    m = s.size
    both = run_interp(np.concatenate((back, ahead)), np.concatenate((run, run)), ks,
                      centre[base], knot_bounds)  # fmt: skip
    prev, nxt = both[:m], both[m:]
    a, b = here - prev, nxt - here
    na, nb = np.hypot(*a.T), np.hypot(*b.T)
    cosang = np.einsum("ij,ij->i", a, b) / np.maximum(na * nb, 1e-12)
    angle = np.degrees(np.arccos(np.clip(cosang, -1.0, 1.0)))
    angle[~ok | ~live[run]] = 0.0
    cand = np.flatnonzero(angle >= corner_deg)
    if cand.size == 0:
        return np.zeros(0), np.zeros(0, dtype=np.intp)
    diffs = np.diff(s)
    starts = bounds[:-1]
    # the steps inside each path: one fewer than its points
    inner = np.ones(diffs.size, dtype=bool)
    inner[starts[(starts > 0) & (size > 0)] - 1] = False
    step_bounds = np.concatenate(([0], np.cumsum(np.maximum(size - 1, 0)))).astype(np.intp)
    step = np.maximum(run_median(diffs[inner], step_bounds), 1e-9)
    half = np.zeros(npath, dtype=np.intp)
    # round() as Python rounds (half to even), as np.rint does
    half[live] = np.maximum(1, np.rint(w / step[live])).astype(np.intp)
    cr = run[cand]
    cand = cand[_peaks(angle, cand, cr, half, bounds, closed)]
    cr = run[cand]
    cs = s[cand]
    keep = np.ones(cand.size, dtype=bool)
    keep[1:] = (cr[1:] != cr[:-1]) | (np.diff(cs) > w)
    return cs[keep], cr[keep]

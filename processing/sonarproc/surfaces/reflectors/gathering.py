"""Where to look for point reflectors, and which readings pass through a point.

:func:`candidates` are the local maxima of the arc count map (every arc through a point
adds a vote there), strongest first. :class:`ArcIndex` holds k-d trees of the readings'
arcs so that :func:`gather` (one point) and :func:`gather_all` (many at once) test only
the readings whose arcs may pass near a point: a reading passes through it when its
range is within :data:`RANGE_TOL_M` of its sensor's distance to the point and its beam
(the half-width times :data:`BEAM_SLACK`) holds the point.
"""

from __future__ import annotations

import math
from itertools import chain

import numpy as np
import numpy.typing as npt
from scipy import ndimage
from scipy.spatial import cKDTree

from sonarproc.grid import Grid
from sonarproc.surfaces.echoes.specular import EchoGeometry
from sonarproc.surfaces.reflectors.range_models import RANGE_TOL_M

__all__ = [
    "BEAM_SLACK",
    "CANDIDATE_SPACING_M",
    "MAX_CANDIDATES",
    "MIN_READINGS",
    "ArcIndex",
    "candidates",
    "gather",
    "gather_all",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: A point echo is heard beyond the nominal half-width of the beam: the effective beam
#: of a Polaroid transducer widens close by (16 degrees at 0.5 m for a nominal 12.5,
#: Kuc & Siegel 1987), most for strong echoes such as a corner's.
BEAM_SLACK = 1.3
#: Fewest readings of a point: a sonar ring fires about eight times per 0.4 m of travel
#: at a reflector 2 m away within its beam; fewer are a chance crossing of arcs.
MIN_READINGS = 8
#: Local maxima of the counts closer than this (m) are one candidate: the arcs through a
#: point spread their votes over the range tolerance round it.
CANDIDATE_SPACING_M = 2 * RANGE_TOL_M
#: Most candidates tested, strongest first: a point reflector is among the strongest
#: local maxima of the map; the weakest are the many chance crossings of arcs.
MAX_CANDIDATES = 400


def _as_index(found: list[int]) -> IntArray:
    """A k-d tree's list of point indices as an index array."""
    return np.fromiter(found, dtype=np.intp, count=len(found))


def _wrap(a: FloatArray) -> FloatArray:
    return np.asarray((a + np.pi) % (2 * np.pi) - np.pi, dtype=np.float64)


class ArcIndex:
    """The readings whose arcs may pass near a point: k-d trees of the arcs' midpoints.

    Every point of a reading's arc (within :data:`BEAM_SLACK` times its half beam) lies
    within the arc's chord of its midpoint; readings are grouped by that reach (doubling
    classes), one tree per class, so a query asks each tree for its class's reach.

    The trees split at the sliding midpoint, not the median, and keep their nodes' boxes
    as built (``balanced_tree=False, compact_nodes=False``): a ball query answers the
    same readings whatever the tree's shape, and a long log's trees (tens of thousands
    of arcs, built twice a run and asked a few hundred times) are built several times
    faster so; the gathers of the 90 000-reading room run cost about a third less.
    """

    def __init__(self, echoes: EchoGeometry, free: npt.NDArray[np.bool_]) -> None:
        idx = np.flatnonzero(free)
        half = np.minimum(BEAM_SLACK * echoes.half_beam[idx], 0.5 * np.pi)
        rng = echoes.range_m[idx]
        mid = echoes.arcs[1][idx]  # the arcs' midpoints, made once per EchoGeometry
        reach = 2.0 * rng * np.sin(0.5 * half) + RANGE_TOL_M
        cls = np.ceil(np.log2(np.maximum(reach, 0.05) / 0.05)).astype(np.int64)
        self.groups: list[tuple[IntArray, cKDTree, float]] = []
        for k in np.unique(cls):
            sel = np.flatnonzero(cls == k)
            rows = idx[sel]
            tree = cKDTree(mid[sel], balanced_tree=False, compact_nodes=False)
            self.groups.append((rows, tree, float(reach[sel].max())))

    def near(self, p: FloatArray) -> IntArray:
        """Readings whose arcs may pass within :data:`RANGE_TOL_M` of ``p``."""
        # the trees answer with lists; np.fromiter reads one about twice as fast as
        # indexing with it (a wall end of a long log is near thousands of readings)
        parts = [rows[_as_index(tree.query_ball_point(p, r))] for rows, tree, r in self.groups]
        return np.concatenate(parts).astype(np.intp) if parts else np.zeros(0, np.intp)

    def near_many(self, pts: FloatArray) -> tuple[IntArray, IntArray]:
        """:meth:`near` of every point of ``pts`` (C, 2) at once: (point, reading) pairs,
        in no particular order."""
        which, rows_near = [np.zeros(0, np.intp)], [np.zeros(0, np.intp)]
        for rows, tree, r in self.groups:
            # unsorted: the pairs come in no particular order (gather_all sorts them)
            hits = tree.query_ball_point(pts, r, return_sorted=False)
            counts = np.fromiter(map(len, hits), dtype=np.intp, count=len(hits))
            if counts.sum() == 0:
                continue
            which.append(np.repeat(np.arange(len(hits)), counts))
            flat = np.fromiter(chain.from_iterable(hits), dtype=np.intp, count=int(counts.sum()))
            rows_near.append(rows[flat])
        return np.concatenate(which), np.concatenate(rows_near)


def _passes(echoes: EchoGeometry, idx: IntArray, d: FloatArray) -> npt.NDArray[np.bool_]:
    """Whether readings ``idx``, ``d`` (N, 2) from the point to their sensors, pass through it.

    Through it: the range within :data:`RANGE_TOL_M` of the distance, the point inside
    the beam (its half-width times :data:`BEAM_SLACK`).
    """
    dist = np.hypot(d[:, 0], d[:, 1])
    ok = np.abs(dist - echoes.range_m[idx]) <= RANGE_TOL_M
    bearing = np.arctan2(-d[ok, 1], -d[ok, 0])
    off = np.abs(_wrap(bearing - echoes.heading[idx[ok]]))
    ok[ok] = off <= BEAM_SLACK * echoes.half_beam[idx[ok]]
    return ok


def gather(
    echoes: EchoGeometry, free: npt.NDArray[np.bool_], p: FloatArray, index: ArcIndex | None
) -> IntArray:
    """Free readings whose arcs pass within :data:`RANGE_TOL_M` of ``p`` inside their beams."""
    idx = np.flatnonzero(free) if index is None else np.sort(index.near(p))
    if index is not None:
        idx = idx[free[idx]]
    return idx[_passes(echoes, idx, echoes.xy[idx] - p)]


def gather_all(
    echoes: EchoGeometry, free: npt.NDArray[np.bool_], starts: FloatArray, index: ArcIndex
) -> list[IntArray]:
    """:func:`gather` round every start at once (each list sorted, as :func:`gather`'s).

    A reading passes or not whatever the other readings do, so a gather made now and
    restricted later to the readings still free is the gather made then.
    """
    which, idx = index.near_many(starts)
    keep = free[idx]
    which, idx = which[keep], idx[keep]
    keep = _passes(echoes, idx, echoes.xy[idx] - starts[which])
    which, idx = which[keep], idx[keep]
    order = np.lexsort((idx, which))
    which, idx = which[order], idx[order]
    return np.split(idx, np.searchsorted(which, np.arange(1, starts.shape[0])))


def candidates(
    counts: npt.ArrayLike, grid: Grid, *, around: FloatArray | None = None, reach: float = 0.0
) -> FloatArray:
    """Local maxima of the counts with at least :data:`MIN_READINGS` votes, strongest first.

    A plateau of equal maxima, or maxima closer than :data:`CANDIDATE_SPACING_M`, give
    their strongest (first) one. With ``around`` (P, 2), only the maxima within ``reach``
    (m) of one of those points are looked for (in windows of the map: a long log's map is
    millions of cells).

    Examples
    --------
    >>> g = Grid(x0=0.0, y0=0.0, cell=0.02, nx=20, ny=10)
    >>> c = np.zeros(g.shape, int); c[5, 7] = 12; c[5, 8] = 11; c[2, 15] = 3
    >>> candidates(c, g).round(3).tolist()
    [[0.14, 0.1]]
    >>> candidates(c, g, around=np.array([[0.3, 0.04]]), reach=0.05).tolist()
    []
    """
    c = np.asarray(counts)
    size = max(3, 2 * round(CANDIDATE_SPACING_M / grid.cell) + 1)
    if around is None:
        windows = [(slice(0, grid.ny), slice(0, grid.nx))]
    else:
        pad = math.ceil(reach / grid.cell) + size
        iy, ix = grid.to_index(around[:, 0], around[:, 1])
        windows = [(slice(max(0, y - pad), max(0, y + pad + 1)),
                    slice(max(0, x - pad), max(0, x + pad + 1)))
                   for y, x in zip(iy.tolist(), ix.tolist(), strict=True)]  # fmt: skip
    rows, cols, votes = [], [], []
    for wy, wx in windows:
        part = c[wy, wx]
        if part.size == 0:
            continue
        peak = (part == ndimage.maximum_filter(part, size=size, mode="constant")) & (
            part >= MIN_READINGS
        )
        py, px = np.nonzero(peak)
        rows.append(py + wy.start)
        cols.append(px + wx.start)
        votes.append(part[py, px])
    if not rows:
        return np.zeros((0, 2))
    iy_all, ix_all, v = np.concatenate(rows), np.concatenate(cols), np.concatenate(votes)
    order = np.argsort(-v, kind="stable")
    x, y = grid.to_world(iy_all[order], ix_all[order])
    pts_xy = np.column_stack((x, y)).astype(np.float64)
    _, first = np.unique(pts_xy, axis=0, return_index=True)  # windows overlap
    pts_xy = pts_xy[np.sort(first)]
    if around is not None:
        gap = pts_xy[:, None, :] - around[None, :, :]
        pts_xy = pts_xy[np.hypot(gap[..., 0], gap[..., 1]).min(axis=1) <= reach]
    keep = np.ones(pts_xy.shape[0], dtype=bool)
    for i, near in enumerate(cKDTree(pts_xy).query_ball_point(pts_xy, CANDIDATE_SPACING_M)):
        if keep[i]:
            keep[[j for j in near if j > i]] = False
    return pts_xy[keep][:MAX_CANDIDATES]

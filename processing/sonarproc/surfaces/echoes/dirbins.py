"""Readings that may meet straight surfaces along their normals: a search over direction bins.

A reading reflects from a straight surface along the surface's normal (the foot of the
sensor on the line), and only when that normal lies in its beam. So instead of a radius
search round each reading's arc (a disc of the arc's chord, most of it far from any
surface point the reading could meet perpendicularly), directions are cut into bins of
:data:`BIN_DEG`:

* a reading is entered in every bin whose centre lies within half a bin of its beam, at
  the point at its range along the bin's centre;
* a segment is entered in the bins of its two normals (the sensor may lie on either
  side);
* a reading whose beam holds a normal of a segment is entered in that normal's bin (its
  centre is within half a bin of the normal), and there its point lies within
  ``r * bin / 2`` (``r`` its range) of the point at its range along the normal itself.
  Square buckets of :data:`BUCKET_M` round each segment, its bounding box grown by the
  caller's reach and that shift, find it (a table over every (bin, bucket) key when
  there are at most :data:`DENSE_KEYS`, else a sorted search).

:func:`normal_bin_pairs` returns those pairs; the caller applies its exact tests. Its
cost grows with the readings times the bins their beams span (about ten) and with the
buckets round the segments: it pays for many short segments, not for a few long ones
scored against every reading (a radius search does those at a third of the cost).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from sonarproc.surfaces.planar.runs import ragged_arange

__all__ = ["BIN_DEG", "BUCKET_M", "DENSE_KEYS", "normal_bin_pairs"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Width (deg) of the direction bins.
BIN_DEG = 3.0
#: Side (m) of the square buckets the readings' points are looked up in.
BUCKET_M = 0.5
#: Up to this many (bin, bucket) keys, entries are found by a table over all keys.
DENSE_KEYS = 1 << 22


def normal_bin_pairs(
    ends: npt.ArrayLike,
    reach: npt.ArrayLike,
    xy: FloatArray,
    heading: FloatArray,
    half_beam: FloatArray,
    range_m: FloatArray,
) -> tuple[IntArray, IntArray]:
    """Distinct (segment, reading) pairs, among them every pair described below.

    Every reading whose beam (``heading +- half_beam``) holds a normal ``u`` of segment
    ``g`` and whose point ``xy + range_m * u`` lies within ``reach[g]`` of the segment
    is paired with it (see the module notes); so are some others.

    Parameters
    ----------
    ends : array_like, shape (G, 2, 2)
        Each segment's two ends (m).
    reach : array_like, shape (G,)
        Distance (m) from each segment within which the readings' points are sought.
    xy, heading, half_beam, range_m : ndarray, shape (N, 2), (N,), (N,), (N,)
        The readings: sensor position, beam axis and half width (rad), range (m).

    Returns
    -------
    seg, read : ndarray of int
        The pairs, sorted by segment then reading.

    Examples
    --------
    A wall along y = 1, a sensor below it looking up and one looking along it:

    >>> seg, read = normal_bin_pairs([[[-1.0, 1.0], [1.0, 1.0]]], [0.05],
    ...     np.zeros((2, 2)), np.array([np.pi / 2, 0.0]), np.full(2, 0.2), np.ones(2))
    >>> seg.tolist(), read.tolist()
    ([0], [0])
    """
    e = np.asarray(ends, dtype=np.float64).reshape(-1, 2, 2)
    grow_by = np.asarray(reach, dtype=np.float64).reshape(-1)
    n = int(range_m.size)
    if e.shape[0] == 0 or n == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    nbin = math.ceil(360.0 / BIN_DEG)
    step = 2 * math.pi / nbin
    centre = (np.arange(nbin) + 0.5) * step
    unit = np.stack((np.cos(centre), np.sin(centre)), axis=1)
    # readings: every bin whose centre lies within half a bin of the beam
    th = np.mod(heading, 2 * math.pi)
    half = np.minimum(half_beam, math.pi) + 0.5 * step
    k_lo = np.ceil((th - half) / step - 0.5).astype(np.intp)
    k_hi = np.floor((th + half) / step - 0.5).astype(np.intp)
    read, k = ragged_arange(np.clip(k_hi - k_lo + 1, 0, nbin))
    k = np.mod(k_lo[read] + k, nbin)
    q = xy[read] + range_m[read, None] * unit[k]
    # segments: the bin holding each normal (a reading whose beam holds that normal is
    # entered there); the two normals lie half a turn apart, so no reading meets both
    t = e[:, 1] - e[:, 0]
    normal = np.arctan2(t[:, 0], -t[:, 1])  # the direction of (-t_y, t_x)
    seg = np.repeat(np.arange(e.shape[0]), 2)
    side_dir = np.mod(np.stack((normal, normal + math.pi), axis=1).ravel(), 2 * math.pi)
    ks = np.minimum(np.floor(side_dir / step).astype(np.intp), nbin - 1)
    # the buckets round each (segment, bin) entry: its box grown by the reach and by the
    # largest shift of a point in a bin
    grow = grow_by[seg] + 0.5 * step * float(range_m.max()) + 1e-6
    lo = np.floor((e[seg].min(axis=1) - grow[:, None]) / BUCKET_M).astype(np.int64)
    hi = np.floor((e[seg].max(axis=1) + grow[:, None]) / BUCKET_M).astype(np.int64)
    qb = np.floor(q / BUCKET_M).astype(np.int64)
    base, top = qb.min(axis=0), qb.max(axis=0)
    # buckets no reading's point falls in are never looked up: clip the boxes to them
    lo = np.maximum(lo, base)
    hi = np.minimum(hi, top)
    live = np.all(hi >= lo, axis=1)
    seg, ks, lo, hi = seg[live], ks[live], lo[live], hi[live]
    nx_, ny_ = int(top[0] - base[0] + 1), int(top[1] - base[1] + 1)
    ex, bx = ragged_arange((hi[:, 0] - lo[:, 0] + 1).astype(np.intp))
    ey, by = ragged_arange((hi[ex, 1] - lo[ex, 1] + 1).astype(np.intp))
    entry = ex[ey]
    key = (ks[entry].astype(np.int64) * nx_ + (lo[entry, 0] + bx[ey] - base[0])) * ny_ + (
        lo[entry, 1] + by - base[1]
    )
    order = np.argsort(key, kind="stable")
    key, entry = key[order], entry[order]
    pkey = (k.astype(np.int64) * nx_ + (qb[:, 0] - base[0])) * ny_ + (qb[:, 1] - base[1])
    size = nbin * nx_ * ny_
    if size <= DENSE_KEYS:
        # every key's run of entries, by a table over all keys
        count = np.bincount(key, minlength=size)
        first = (np.cumsum(count) - count)[pkey]
        point, off = ragged_arange(count[pkey])
    else:
        first = np.searchsorted(key, pkey, side="left")
        point, off = ragged_arange(np.searchsorted(key, pkey, side="right") - first)
    g = seg[entry[first[point] + off]].astype(np.int64)
    pair = g * n + read[point]
    # a beam of half a turn may hold both normals of a segment: one pair, not two
    pair = np.unique(pair) if float(half.max()) >= 0.5 * math.pi else np.sort(pair)
    return (pair // n).astype(np.intp), (pair % n).astype(np.intp)

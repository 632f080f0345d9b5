"""Higher-order specular reflections by mirror images (flat segments only).

For a sequence of flat segments ``s1 .. sn`` the transmitter is mirrored across each
segment's line in turn; the path length is the distance from the last image to the
receiver, and the bounce points are found by tracing back from the receiver towards the
images. A bounce point must fall on its segment, and the first and last legs must lie in
the transmitter's and receiver's beams. A concave corner's double bounce is the ``n = 2``
case; for a single sensor facing a right-angle corner that path runs into the corner and
back (both bounce points at the corner, length twice the distance to the corner), which
is the corner's well-known strong echo. Curved surfaces (curves, circles) take part only
in first-order reflections.
"""

from __future__ import annotations

import itertools

import numpy as np

from sonarsim.geometry import FloatArray, dot, perp
from sonarsim.segments import Segments
from sonarsim.specular import Hits, IntArray, Sensors, Tables, in_beam

MAX_SEQUENCES = 200_000
"""Refuse orders whose segment sequences would exceed this many (guards memory)."""


def sequences(flat_idx: IntArray, order: int) -> IntArray:
    """All sequences of ``order`` flat segments with no segment repeated back to back."""
    if order < 2 or flat_idx.size < 2:
        return np.zeros((0, order), np.intp)
    f = flat_idx.size
    count = f * (f - 1) ** (order - 1)
    if count > MAX_SEQUENCES:
        raise ValueError(
            f"max_order {order} with {f} flat segments needs {count} image sequences "
            f"(limit {MAX_SEQUENCES}); lower max_order"
        )
    seq = np.array(list(itertools.product(range(f), repeat=order)), dtype=np.intp)
    keep = np.all(seq[:, 1:] != seq[:, :-1], axis=1)
    return flat_idx[seq[keep]]


def image_order(
    segs: Segments,
    sensors: Sensors,
    tables: Tables,
    ti: IntArray,
    ri: IntArray,
    seqs: IntArray,
) -> Hits:
    """Reflections of order ``seqs.shape[1]`` for pairs ``(ti[k], ri[k])``."""
    if seqs.size == 0 or ti.size == 0:
        return Hits.empty()
    order = seqs.shape[1]
    ok_first = tables.overlap[ti][:, seqs[:, 0]]
    ok_last = tables.overlap[ri][:, seqs[:, -1]]
    p, q = np.nonzero(ok_first & ok_last)
    if p.size == 0:
        return Hits.empty()
    t, r = ti[p], ri[p]
    seq = seqs[q]
    tx, rx = sensors.xy[t], sensors.xy[r]
    a = segs.a[seq]  # (K, n, 2)
    d = segs.ta[seq]
    n = perp(d)
    length = np.hypot(*(segs.b[seq] - a).transpose(2, 0, 1))
    images = np.empty((p.size, order, 2))
    img = tx
    for k in range(order):
        img = img - 2.0 * dot(img - a[:, k], n[:, k])[:, None] * n[:, k]
        images[:, k] = img
    ok = np.ones(p.size, dtype=bool)
    points = np.empty((p.size, order, 2))
    qpt = rx
    for k in range(order - 1, -1, -1):
        dq = dot(qpt - a[:, k], n[:, k])
        di = dot(images[:, k] - a[:, k], n[:, k])
        # Q on the line (a bounce exactly in a corner) counts as crossing there.
        cross_ok = (dq * di < 0.0) | ((np.abs(dq) <= 1e-12) & (np.abs(di) > 1e-12))
        frac = dq / np.where(cross_ok, dq - di, 1.0)
        pk = qpt + (images[:, k] - qpt) * frac[:, None]
        v = dot(pk - a[:, k], d[:, k])
        ok &= cross_ok & (v >= -1e-12) & (v <= length[:, k] + 1e-12)
        points[:, k] = pk
        qpt = pk
    ok &= in_beam(tx, sensors.heading[t], sensors.half_beamwidth[t], points[:, 0])
    ok &= in_beam(rx, sensors.heading[r], sensors.half_beamwidth[r], points[:, -1])
    path = np.hypot(*(images[:, -1] - rx).T)
    half = 0.5 * path
    ok &= (half >= sensors.min_range[r]) & (half <= sensors.max_range[r])
    p, seq, points, path, tx, rx = p[ok], seq[ok], points[ok], path[ok], tx[ok], rx[ok]
    legs: list[tuple[FloatArray, FloatArray]] = [(tx, points[:, 0])]
    legs += [(points[:, k], points[:, k + 1]) for k in range(order - 1)]
    legs.append((points[:, -1], rx))
    return Hits(
        p, path, points[:, 0], points[:, -1], seq[:, -1], np.full(p.size, order, np.int8),
        tuple(legs),
    )  # fmt: skip

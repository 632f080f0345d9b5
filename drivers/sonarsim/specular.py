"""First-order specular reflections, vectorised over transmitter/receiver pairs.

A point P on a surface reflects from transmitter T to receiver R when the surface normal
at P bisects P->T and P->R. Equivalently (Fermat) the path length |TP| + |PR| is
stationary along the surface, i.e. ``g = tangent . (unit(T - P) + unit(R - P)) = 0``.
``g`` splits into a transmitter part and a receiver part, so it is computed per sensor
and segment end once and then only added per pair: a sign change of ``g`` between a
segment's ends brackets a reflection point. Flat segments are then solved exactly by the
mirror image of R; smooth segments by two regula-falsi steps with the interpolated
tangent. Finally P must lie in both beams and the half path in the receiver's range.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from sonarsim.geometry import FloatArray, dot, heading_vectors, perp, unit, wrap_angle
from sonarsim.segments import Segments

IntArray = NDArray[np.intp]


@dataclass(frozen=True)
class Sensors:
    """World poses and beam parameters of the sensors taking part (one row each)."""

    xy: FloatArray
    heading: FloatArray
    half_beamwidth: FloatArray
    min_range: FloatArray
    max_range: FloatArray

    def __len__(self) -> int:
        return int(self.xy.shape[0])

    def take(self, idx: IntArray) -> Sensors:
        """The rows ``idx``."""
        return Sensors(
            self.xy[idx], self.heading[idx], self.half_beamwidth[idx], self.min_range[idx],
            self.max_range[idx],
        )  # fmt: skip


@dataclass(frozen=True)
class Tables:
    """Per sensor x segment-end quantities (shape (M, S) each)."""

    ha: FloatArray  # tangent_a . unit(X - a)
    hb: FloatArray  # tangent_b . unit(X - b)
    overlap: NDArray[np.bool_]  # the segment meets the sensor's beam wedge

    @cached_property
    def overlap_bits(self) -> NDArray[np.uint8]:
        """:attr:`overlap` packed eight segments to a byte (shape (M, ceil(S / 8)))."""
        return np.packbits(self.overlap, axis=1)


def pair_overlaps(tables: Tables, ti: IntArray, ri: IntArray) -> tuple[IntArray, IntArray]:
    """``np.nonzero(tables.overlap[ti] & tables.overlap[ri])``: (pair, segment) indices in
    row-major order, the segments both sensors of a pair have in their beams.

    The pairs' rows are combined packed, eight segments to a byte, and only the bytes with
    a common segment are unpacked: most pairs share few of a long wall's segments, so this
    moves an eighth of the memory of the boolean rows (a third of a scan's simulation time).

    Examples
    --------
    >>> seen = np.zeros((2, 10), dtype=bool)
    >>> seen[0, [0, 9]] = seen[1, 1] = True
    >>> t = Tables(np.zeros((2, 10)), np.zeros((2, 10)), seen)
    >>> [a.tolist() for a in pair_overlaps(t, np.array([0, 1, 0]), np.array([0, 1, 1]))]
    [[0, 0, 1], [0, 9, 1]]
    """
    common = tables.overlap_bits[ti] & tables.overlap_bits[ri]
    pair, byte = np.nonzero(common)
    # packbits is big-endian: bit j (from the left) of byte b is segment 8 b + j
    k, bit = np.nonzero(np.unpackbits(common[pair, byte][:, None], axis=1))
    return pair[k], byte[k] * 8 + bit


def sensor_tables(segs: Segments, sensors: Sensors) -> Tables:
    """Precompute the per-sensor halves of the reflection condition and beam overlaps."""
    x = sensors.xy[:, None, :]
    va = segs.a[None, :, :] - x
    vb = segs.b[None, :, :] - x
    ea, _ = unit(va)
    eb, _ = unit(vb)
    ha = -dot(segs.ta[None, :, :], ea)
    hb = -dot(segs.tb[None, :, :], eb)
    h = sensors.heading[:, None]
    ang_a = wrap_angle(np.arctan2(va[..., 1], va[..., 0]) - h)
    ang_b = wrap_angle(np.arctan2(vb[..., 1], vb[..., 0]) - h)
    w = sensors.half_beamwidth[:, None] + 1e-9
    overlap = (
        (np.abs(ang_a - ang_b) <= np.pi)
        & (np.maximum(ang_a, ang_b) >= -w)
        & (np.minimum(ang_a, ang_b) <= w)
    )
    return Tables(ha, hb, overlap)


@dataclass(frozen=True)
class Hits:
    """Candidate reflections (before occlusion), one row each."""

    pair: IntArray  # index into the pair list
    path: FloatArray  # |TP| + |PR| (m)
    first: FloatArray  # first reflection point (K, 2)
    last: FloatArray  # last reflection point (K, 2)
    segment: IntArray  # segment of the last reflection
    order: NDArray[np.int8]
    legs: tuple[tuple[FloatArray, FloatArray], ...]  # straight legs for occlusion tests

    @staticmethod
    def empty() -> Hits:
        """No hits."""
        z2 = np.zeros((0, 2))
        zi = np.zeros(0, np.intp)
        return Hits(zi, np.zeros(0), z2, z2, zi, np.zeros(0, np.int8), ())


def in_beam(
    sensor_xy: FloatArray, heading: FloatArray, hbw: FloatArray, p: FloatArray
) -> NDArray[np.bool_]:
    """Whether points ``p`` lie inside the beams (half angle ``hbw``) of the sensors."""
    v, n = unit(p - sensor_xy)
    return (dot(v, heading_vectors(heading)) >= np.cos(hbw) - 1e-12) & (n > 0.0)


def first_order(
    segs: Segments, sensors: Sensors, tables: Tables, ti: IntArray, ri: IntArray
) -> Hits:
    """First-order reflections for the pairs ``(ti[k], ri[k])`` (rows of ``sensors``).

    Returns candidate hits with ``pair`` indexing into ``ti``/``ri``; occlusion is not
    applied here.
    """
    p, s = pair_overlaps(tables, ti, ri)
    if p.size == 0:
        return Hits.empty()
    t = ti[p]
    r = ri[p]
    ga = tables.ha[t, s] + tables.ha[r, s]
    gb = tables.hb[t, s] + tables.hb[r, s]
    root = ((ga > 0.0) & (gb <= 0.0)) | ((ga < 0.0) & (gb >= 0.0))
    p, s, t, r, ga, gb = p[root], s[root], t[root], r[root], ga[root], gb[root]
    if p.size == 0:
        return Hits.empty()
    a = segs.a[s]
    b = segs.b[s]
    tx = sensors.xy[t]
    rx = sensors.xy[r]
    flat = segs.flat[s]
    point = np.empty_like(a)
    ok = np.ones(p.size, dtype=bool)

    # Flat segments: exact mirror image of the receiver.
    if flat.any():
        fa = a[flat]
        n = perp(segs.ta[s[flat]])
        d_t = dot(tx[flat] - fa, n)
        d_r = dot(rx[flat] - fa, n)
        same = d_t * d_r > 0.0
        denom = np.where(same, d_t + d_r, 1.0)
        mirror = rx[flat] - 2.0 * d_r[:, None] * n
        point[flat] = tx[flat] + (mirror - tx[flat]) * (d_t / denom)[:, None]
        ok[flat] = same

    # Smooth segments: regula falsi on g with interpolated tangents.
    sm = ~flat
    if sm.any():
        sa, sb = a[sm], b[sm]
        ta, tb = segs.ta[s[sm]], segs.tb[s[sm]]
        txs, rxs = tx[sm], rx[sm]
        lo = np.zeros(sa.shape[0])
        hi = np.ones(sa.shape[0])
        glo, ghi = ga[sm], gb[sm]
        frac = glo / (glo - ghi)
        for _ in range(2):
            pt = sa + (sb - sa) * frac[:, None]
            tan, _ = unit(ta + (tb - ta) * frac[:, None])
            g = dot(tan, unit(txs - pt)[0] + unit(rxs - pt)[0])
            left = np.sign(g) == np.sign(glo)
            lo = np.where(left, frac, lo)
            glo = np.where(left, g, glo)
            hi = np.where(left, hi, frac)
            ghi = np.where(left, ghi, g)
            den = glo - ghi
            frac = np.where(den != 0.0, lo + (hi - lo) * glo / np.where(den != 0.0, den, 1.0), frac)
        pt = sa + (sb - sa) * frac[:, None]
        tan, _ = unit(ta + (tb - ta) * frac[:, None])
        n = perp(tan)
        ok[sm] = dot(txs - pt, n) * dot(rxs - pt, n) > 0.0
        point[sm] = pt

    ok &= in_beam(tx, sensors.heading[t], sensors.half_beamwidth[t], point)
    ok &= in_beam(rx, sensors.heading[r], sensors.half_beamwidth[r], point)
    path = np.hypot(*(point - tx).T) + np.hypot(*(point - rx).T)
    half = 0.5 * path
    ok &= (half >= sensors.min_range[r]) & (half <= sensors.max_range[r])
    p, s, point, path, tx, rx = p[ok], s[ok], point[ok], path[ok], tx[ok], rx[ok]
    return Hits(p, path, point, point, s, np.ones(p.size, np.int8), ((tx, point), (point, rx)))

"""The connected-chain rasteriser behind :mod:`sonarproc.arcs` (private; use that package).

Each reading's arc (see :mod:`sonarproc.arcs._geometry`) is drawn as a minimal
8-connected chain of cells, the way a midpoint circle algorithm draws one, but
vectorised over all arcs at once (no Python loop per arc, per piece or per sample):

1. :func:`sonarproc.arcs._plan.plan_pieces` cuts each arc into pieces on which one grid
   axis advances by one cell per sample, with closed-form conic parameters;
2. :func:`sonarproc.arcs._fill.blocks` computes every interior sample's cell key in
   float32 with proven float64 repair, block by block in reused memory;
3. this module removes the repeats and scatters the keys. Within a piece the cells are
   distinct (one per column or row). A cell can repeat only next to a piece's ends, and
   on an arc whose tangent turns by at most 45 degrees two samples in one cell lie within
   about 1.5 cells of arc; so the repeats are found by comparing each end sample with the
   few before it along the arc. Other arcs (wide beams, thin ellipses, two-piece joint
   regions) get an exact sort-based check.

Keys are flat cell indices ``iy * nx + ix``; cells outside the grid and padding slots take
the trash key ``nx * ny``. :func:`accumulate` scatters each block with ``np.add.at`` while
the block is in cache, into a uint16 count map where a tile bound
(:func:`sonarproc.arcs._bounds.overlap_bound`) proves no cell reaches 2**16 arcs (else
uint32); it keeps aside only the samples that may repeat, and takes the repeats off again.
:func:`batch_keys` (for :func:`sonarproc.arcs.arc_cells`) writes all keys to one buffer and
trashes the repeats there. Arcs are processed in batches of about ``_BATCH`` samples.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs._fill import blocks
from sonarproc.arcs._plan import IntArray, RasterPlan

__all__ = ["BatchKeys", "accumulate", "batch_keys", "batches", "ranges"]

#: Cells of a simple arc repeat at most this many places apart in its boundary sequence.
_LAG = 8
#: Interior samples at each end of a piece that may repeat a cell of the arc.
_EDGE = 2
#: Samples per batch of whole arcs: bounds the key buffer of :func:`batch_keys`.
_BATCH = 1 << 25


def ranges(starts: IntArray, lengths: IntArray) -> IntArray:
    """Concatenation of ``arange(s, s + n)`` for each pair (vectorised)."""
    before = np.cumsum(lengths) - lengths
    total = int(lengths.sum())
    return np.arange(total, dtype=np.intp) + np.repeat(starts - before, lengths)


@dataclass(frozen=True)
class BatchKeys:
    keys: IntArray  # buffer of padded flat keys (repeats and padding hold the trash key)
    row_base: IntArray  # buffer position of each piece's first interior sample
    start_pos: IntArray  # buffer position of each piece's start point (-1 if none)
    end_pos: IntArray


def batch_keys(plan: RasterPlan, p0: int, p1: int, trash: int) -> BatchKeys:
    """Keys of all samples of pieces ``[p0, p1)`` (whole arcs), each arc's repeats trashed."""
    n = plan.n[p0:p1]
    pre = plan.pre[p0:p1]
    npc = p1 - p0
    n_interior = int(n.sum())
    n_pre = int(pre.sum())
    keys = np.empty(n_interior + n_pre + npc, dtype=np.intp)
    row_base = np.full(npc, -1, dtype=np.intp)
    before = np.cumsum(n) - n
    row_base[n > 0] = before[n > 0]
    for blk in blocks(plan, p0, p1, trash):
        nb = n[blk.rows]
        if blk.width == 1:
            keys[row_base[blk.rows]] = blk.keys[:, 0]
        else:
            mask = np.arange(blk.width) < nb[:, None]
            keys[ranges(row_base[blk.rows], nb)] = blk.keys[mask]
    pos = n_interior
    start_pos = np.full(npc, -1, dtype=np.intp)
    has_pre = pre.astype(bool)
    start_pos[has_pre] = pos + np.arange(n_pre, dtype=np.intp)
    keys[pos : pos + n_pre] = plan.start_key[p0:p1][has_pre]
    pos += n_pre
    end_pos = pos + np.arange(npc, dtype=np.intp)
    keys[pos : pos + npc] = plan.end_key[p0:p1]
    _trash_repeats(plan, p0, p1, keys, row_base, row_base + n, row_base, start_pos, end_pos, trash)
    return BatchKeys(keys=keys, row_base=row_base, start_pos=start_pos, end_pos=end_pos)


def accumulate(plan: RasterPlan, counts: NDArray[np.unsignedinteger[Any]], trash: int) -> None:
    """Add every arc's cells to ``counts`` (padded flat map plus the trash bin), in place.

    Each generation block is scattered while it is in cache. Only the samples that may
    repeat a cell of their arc (each piece's end points and ``_EDGE`` interior samples at
    each end, and every sample of a complex arc) are kept aside; the repeat check of
    :func:`batch_keys` runs on them, and each repeat is taken off again.
    """
    one = counts.dtype.type(1)
    for p0, p1 in batches(plan):
        n = plan.n[p0:p1]
        npc = p1 - p0
        cx = plan.complex_arc[p0:p1]
        any_cx = bool(cx.any())
        # Side store: 4 slots a simple piece (samples 0, 1, n - 2, n - 1), then start and
        # end points, then complex pieces' whole rows.
        edge = np.zeros((npc, 4), dtype=np.intp)
        full_rows: list[IntArray] = []
        full_base = np.zeros(npc, dtype=np.intp)
        full_pos = 0
        for blk in blocks(plan, p0, p1, trash):
            np.add.at(counts, blk.keys.reshape(-1), one)
            nb = n[blk.rows]
            width = blk.width
            edge[blk.rows, 0] = blk.keys[:, 0]
            if width > 1:
                edge[blk.rows, 1] = blk.keys[:, 1]
            flat = blk.keys.reshape(-1)
            base = np.arange(blk.rows.shape[0], dtype=np.intp) * width
            edge[blk.rows, 2] = flat[base + np.maximum(nb - 2, 0)]
            edge[blk.rows, 3] = flat[base + nb - 1]
            cxb = np.flatnonzero(cx[blk.rows]) if any_cx else cx[:0].nonzero()[0]
            if cxb.size:
                full_rows.append(blk.keys[cxb].reshape(-1))
                full_base[blk.rows[cxb]] = 4 * npc + full_pos + width * np.arange(cxb.size)
                full_pos += cxb.size * width
        pre = plan.pre[p0:p1]
        has_pre = pre.astype(bool)
        n_pre = int(pre.sum())
        start_keys = plan.start_key[p0:p1][has_pre]
        end_keys = plan.end_key[p0:p1]
        np.add.at(counts, start_keys, one)
        np.add.at(counts, end_keys, one)
        store = np.concatenate([edge.reshape(-1), *full_rows, start_keys, end_keys])
        orig = store.copy()
        head_base = np.where(cx, full_base, 4 * np.arange(npc, dtype=np.intp))
        tail_end = np.where(cx, full_base + n, head_base + 4)
        after = 4 * npc + full_pos
        start_pos = np.full(npc, -1, dtype=np.intp)
        start_pos[has_pre] = after + np.arange(n_pre, dtype=np.intp)
        end_pos = after + n_pre + np.arange(npc, dtype=np.intp)
        _trash_repeats(
            plan, p0, p1, store, head_base, tail_end, full_base, start_pos, end_pos, trash
        )
        changed = np.flatnonzero(store != orig)
        np.subtract.at(counts, orig[changed], one)


def _trash_repeats(
    plan: RasterPlan,
    p0: int,
    p1: int,
    keys: IntArray,
    head_base: IntArray,
    tail_end: IntArray,
    full_base: IntArray,
    start_pos: IntArray,
    end_pos: IntArray,
    trash: int,
) -> None:
    """Send every repeat of a cell within one arc to ``trash`` (in place).

    ``keys`` holds a piece's first ``min(n, _EDGE)`` interior samples from
    ``head_base``, its last ``min(n - head, _EDGE)`` ending at ``tail_end``, its start
    and end points at ``start_pos`` / ``end_pos``, and, for complex arcs, all its ``n``
    interior samples from ``full_base``.

    Interior samples of a piece have distinct driver indices, and on an arc whose tangent
    turns by at most 45 degrees two samples in one cell lie within about 1.5 cells of arc
    of each other. So only each piece's end points and ``_EDGE`` interior samples at each
    end can repeat, and only within ``_LAG`` places in that boundary sequence; the other
    arcs are checked exactly by sorting.
    """
    n = plan.n[p0:p1]
    pre = plan.pre[p0:p1]
    head = np.minimum(n, _EDGE)
    tail = np.minimum(n - head, _EDGE)
    cnt = pre + head + tail + 1
    off = np.cumsum(cnt) - cnt
    seq = np.empty(int(cnt.sum()), dtype=np.intp)
    has_pre = pre.astype(bool)
    seq[off[has_pre]] = start_pos[has_pre]
    seq[ranges(off + pre, head)] = ranges(head_base, head)
    seq[ranges(off + pre + head, tail)] = ranges(tail_end - tail, tail)
    seq[off + pre + head + tail] = end_pos
    # Key and arc in one int64, so that equal values are repeats within one arc.
    skeys = np.repeat(plan.arc[p0:p1].astype(np.int64) * np.int64(trash + 1), cnt)
    skeys += keys[seq]
    dup = np.zeros(skeys.shape[0], dtype=bool)
    for lag in range(1, _LAG + 1):
        dup[lag:] |= skeys[lag:] == skeys[:-lag]
    keys[seq[dup]] = trash
    cx = np.flatnonzero(plan.complex_arc[p0:p1])
    if cx.size:
        idx = np.concatenate(
            [ranges(full_base[cx], n[cx]), start_pos[cx][pre[cx] > 0], end_pos[cx]]
        )
        owner = np.concatenate(
            [
                np.repeat(plan.arc[p0:p1][cx], n[cx]),
                plan.arc[p0:p1][cx][pre[cx] > 0],
                plan.arc[p0:p1][cx],
            ]
        )
        comb = owner.astype(np.int64) * np.int64(trash + _LAG + 2) + keys[idx]
        _, first = np.unique(comb, return_index=True)
        rep = np.ones(idx.shape[0], dtype=bool)
        rep[first] = False
        keys[idx[rep]] = trash


def batches(plan: RasterPlan) -> Iterator[tuple[int, int]]:
    """Piece ranges ``[p0, p1)`` holding whole arcs and about ``_BATCH`` samples."""
    arc_end = np.flatnonzero(plan.last) + 1  # piece index after each arc
    if arc_end.shape[0] == 0:
        return
    cum_at_end = np.cumsum(plan.n + plan.pre + 1)[arc_end - 1]
    i = 0
    while i < arc_end.shape[0]:
        base = int(cum_at_end[i - 1]) if i > 0 else 0
        k = max(int(np.searchsorted(cum_at_end, base + _BATCH, side="right")), i + 1)
        yield (int(arc_end[i - 1]) if i > 0 else 0), int(arc_end[k - 1])
        i = k

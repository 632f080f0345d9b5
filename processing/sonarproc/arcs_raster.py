"""The vectorised engine behind :mod:`sonarproc.arcs` (private; use that module).

Each reading's arc (see :mod:`sonarproc.arcs_geometry`) is drawn as a minimal
8-connected chain of cells, the way a midpoint circle algorithm draws one, but
vectorised over all arcs at once (no Python loop per arc, per piece or per sample):

1. Each arc is cut into pieces at the points where its tangent is at 45 degrees. On a
   "flat" piece (``|dy/dx| <= 1``) the chain takes one cell per grid column, on a "steep"
   piece one cell per row; the other coordinate comes from the closed-form conic
   ``v = alpha u +- sqrt(beta u^2 + gamma)`` (float64: a rounding slip near a 45-degree
   point would open a gap). The exact end points of every piece (beam limits and the
   45 degree points) are cells of the chain too, which closes the joints.
2. Pieces are sorted into blocks of equal padded length and equal kind (circle or
   ellipse, axis, direction, branch, needs clipping), so each block is a handful of
   broadcast numpy operations on a 2-D array in reused memory.
3. Within a piece the cells are distinct (one per column or row). A cell can repeat
   only next to a piece's ends, and on an arc whose tangent turns by at most 45 degrees
   two samples in one cell lie within about 1.5 cells of arc; so the repeats are found
   by comparing each end sample with the few before it along the arc. Other arcs (wide
   beams, thin ellipses, two-piece joint regions) get an exact sort-based check. Repeats
   and padding go to a trash bin.
4. One ``np.bincount`` over flat cell indices of a grid padded by one cell makes the count
   map; cells outside the grid fall into the padding ring and are cut off. Arcs are
   processed in batches of about ``_BATCH`` samples to bound memory.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs_geometry import TWO_PI, ArcGeometry, mod_2pi
from sonarproc.grid import Grid

#: Arcs whose tangent may turn more than this (rad) get the exact (sorting) repeat check.
_SIMPLE_TURNING = np.pi / 4
#: Cells of a simple arc repeat at most this many places apart in its boundary sequence.
_LAG = 8
#: Interior samples at each end of a piece that may repeat a cell of the arc.
_EDGE = 2
#: Samples per generation block (a few float64 temporaries of this size).
_CHUNK = 1 << 17
#: Samples per batch of whole arcs: bounds the key buffer (8 bytes per sample).
_BATCH = 1 << 25
#: Row widths of the generation blocks (pieces are padded up to the next width).
_WIDTHS = np.unique(np.round(1.25 ** np.arange(0, 100)).astype(np.intp))

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class _Plan:
    """Per-piece sample layout and conic parameters in grid units, in order along arcs.

    A piece is a part of an arc between 45-degree tangent points (or beam limits) on which
    one grid axis, the driver, advances by one cell per sample; the other (computed)
    coordinate is ``centre + alpha u + sign sqrt(beta u^2 + gamma)``, u being the driver
    coordinate relative to the ellipse centre.
    """

    arc: IntArray  # reading index
    pre: IntArray  # 1 when the piece begins its interval (its start point is a sample)
    n: IntArray  # interior samples
    last: BoolArray  # last piece of its arc
    complex_arc: BoolArray
    u0: FloatArray  # driver coordinate of the first interior sample minus the centre's
    beta: FloatArray
    gamma: FloatArray
    c_alpha: FloatArray
    c_offset: FloatArray  # centre's computed coordinate + 1.5 (padding, round half up)
    c_max: FloatArray  # last padded index of the computed axis
    d_key0: IntArray  # flat-key part of the first interior sample's driver index
    kind: IntArray  # block kind bits (_CLIP, _ELLIPSE, _X_DRIVEN, _UP, _PLUS)
    width: int  # padded grid width
    start_key: IntArray
    end_key: IntArray

    def __len__(self) -> int:
        return int(self.n.shape[0])


def _padded_key(gx: FloatArray, gy: FloatArray, grid: Grid) -> IntArray:
    """Flat key in the padded grid of continuous grid coordinates (clipped to the ring)."""
    w = grid.nx + 2
    ix = np.clip(np.floor(gx + 1.5), 0, grid.nx + 1).astype(np.intp)
    iy = np.clip(np.floor(gy + 1.5), 0, grid.ny + 1).astype(np.intp)
    return iy * w + ix


def _unit(e: FloatArray) -> tuple[FloatArray, FloatArray]:
    """cos e, sin e: float32 trigonometry renormalised to an exact float64 unit vector.

    Used for arc ends only, where an angle error of 1e-7 rad does not matter; the point
    stays exactly on its ellipse. (float64 sin/cos cost ten times more.)
    """
    e32 = e.astype(np.float32)
    c = np.cos(e32).astype(np.float64)
    s = np.sin(e32).astype(np.float64)
    r = np.sqrt(c * c + s * s)
    return c / r, s / r


def _breakpoints(geom: ArcGeometry) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """The four points where the tangent is at 45 degrees, in order of increasing E.

    Returns ``e0`` (K,), the E of the first, and ``off, cos, sin`` (K, 4): offsets
    ``E_k - e0`` (0 <= off < 2 pi, increasing, since the tangent turns monotonically) and
    the cosine and sine of each ``E_k``.
    """
    es, cs, ss = [], [], []
    for beta in (0.25 * np.pi, 0.75 * np.pi):
        cb, sb = np.cos(beta), np.sin(beta)
        cg = cb * geom.ca + sb * geom.sa  # cos(beta - axis)
        sg = sb * geom.ca - cb * geom.sa
        y = -geom.b * cg
        x = geom.a * sg
        r = np.sqrt(x * x + y * y)
        es.append(np.arctan2(y, x))
        cs.append(x / r)
        ss.append(y / r)
    k = es[0].shape[0]
    d1 = mod_2pi(es[1] - es[0])
    off = np.empty((k, 4))
    off[:, 0] = 0.0
    off[:, 1] = d1
    off[:, 2] = np.pi
    off[:, 3] = d1 + np.pi
    c = np.empty((k, 4))
    s = np.empty((k, 4))
    c[:, 0], c[:, 1], c[:, 2], c[:, 3] = cs[0], cs[1], -cs[0], -cs[1]
    s[:, 0], s[:, 1], s[:, 2], s[:, 3] = ss[0], ss[1], -ss[0], -ss[1]
    return es[0], off, c, s


def _plan(geom: ArcGeometry, grid: Grid) -> _Plan:
    """Cut every arc into pieces and set up their sampling (vectorised, no loop per arc)."""
    k = len(geom)
    # Intervals, in order along arcs.
    two = np.isfinite(geom.length[:, 1])
    if two.any():
        lo_all = geom.lo.reshape(-1)
        len_all = geom.length.reshape(-1)
        iv_row = np.repeat(np.arange(k, dtype=np.intp), 2)
        keep = np.isfinite(len_all)
        lo, length, iv_row = lo_all[keep], len_all[keep], iv_row[keep]
    else:
        lo, length = geom.lo[:, 0], geom.length[:, 0]
        iv_row = np.arange(k, dtype=np.intp)
    m = iv_row.shape[0]
    e0, off, bp_c, bp_s = _breakpoints(geom)
    # Breakpoints in order from lo: k = j0, j0 + 1, ... (k >= 4 wraps once round).
    t = mod_2pi(lo - e0[iv_row])
    offr = off[iv_row]
    j0 = (offr[:, 0] < t).astype(np.intp) + (offr[:, 1] < t) + (offr[:, 2] < t) + (offr[:, 3] < t)
    idx = j0[:, None] + np.arange(4)[None, :]
    wrap = idx >= 4
    src = (4 * iv_row)[:, None] + np.where(wrap, idx - 4, idx)
    rel = off.ravel()[src] + np.where(wrap, TWO_PI, 0.0) - t[:, None]
    ln = length[:, None]
    inside = rel < ln
    c_lo, s_lo = _unit(lo)
    c_hi, s_hi = _unit(lo + length)
    b_rel = np.empty((m, 6))
    b_cos = np.empty((m, 6))
    b_sin = np.empty((m, 6))
    b_rel[:, 0] = 0.0
    b_rel[:, 1:5] = np.where(inside, rel, ln)
    b_rel[:, 5] = length
    b_cos[:, 0] = c_lo
    b_cos[:, 1:5] = np.where(inside, bp_c.ravel()[src], c_hi[:, None])
    b_cos[:, 5] = c_hi
    b_sin[:, 0] = s_lo
    b_sin[:, 1:5] = np.where(inside, bp_s.ravel()[src], s_hi[:, None])
    b_sin[:, 5] = s_hi
    pk = b_rel[:, 1:] > b_rel[:, :-1]
    pk[:, 0] = True
    nz = np.flatnonzero(pk)
    piv = nz // 5
    kk = nz - 5 * piv
    row = iv_row[piv]
    pre = (kk == 0).astype(np.intp)
    at = 6 * piv + kk
    cs, ss = b_cos.ravel()[at], b_sin.ravel()[at]
    ce, se = b_cos.ravel()[at + 1], b_sin.ravel()[at + 1]
    last = np.ones(row.shape[0], dtype=bool)
    last[:-1] = row[1:] != row[:-1]
    complex_row = (geom.turning[:, 0] > _SIMPLE_TURNING) | two

    # Geometry in grid units.
    cell = grid.cell
    a = geom.a[row] / cell
    b = geom.b[row] / cell
    ca, sa = geom.ca[row], geom.sa[row]
    gcx = (geom.cx[row] - grid.x0) / cell
    gcy = (geom.cy[row] - grid.y0) / cell
    sx = gcx + a * cs * ca - b * ss * sa
    sy = gcy + a * cs * sa + b * ss * ca
    ex = gcx + a * ce * ca - b * se * sa
    ey = gcy + a * ce * sa + b * se * ca
    xd = np.abs(ex - sx) >= np.abs(ey - sy)  # flat piece: x drives
    ia2 = 1.0 / (a * a)
    ib2 = 1.0 / (b * b)
    q_x2 = ca * ca * ia2 + sa * sa * ib2
    q_y2 = sa * sa * ia2 + ca * ca * ib2
    q_xy = 2.0 * ca * sa * (ia2 - ib2)
    q_c = np.where(xd, q_y2, q_x2)  # coefficient of the computed coordinate squared
    c_alpha = -q_xy / (2.0 * q_c)
    beta = -(ia2 * ib2) / (q_c * q_c)
    gamma = 1.0 / q_c
    d_centre = np.where(xd, gcx, gcy)
    c_centre = np.where(xd, gcy, gcx)
    ds = np.where(xd, sx, sy)
    de = np.where(xd, ex, ey)
    rs = np.where(xd, sy, sx) - c_centre - c_alpha * (ds - d_centre)
    re = np.where(xd, ey, ex) - c_centre - c_alpha * (de - d_centre)
    sign = np.where(rs + re >= 0.0, 1.0, -1.0)
    n_d = np.where(xd, grid.nx, grid.ny).astype(np.float64)
    up = de >= ds
    step = np.where(up, 1.0, -1.0)
    first = np.where(up, np.ceil(ds), np.floor(ds))
    lastd = np.where(up, np.floor(de), np.ceil(de))
    first = np.where(up, np.maximum(first, 0.0), np.minimum(first, n_d - 1.0))
    lastd = np.where(up, np.minimum(lastd, n_d - 1.0), np.maximum(lastd, 0.0))
    n = np.maximum((lastd - first) * step + 1.0, 0.0).astype(np.intp)
    w = grid.nx + 2
    d_mult = np.where(xd, 1, w).astype(np.intp)
    # Range of the computed coordinate over the piece: its end values and, if the piece
    # holds it, the extreme of its branch (centre + sign * half extent of the ellipse).
    c_half = np.sqrt(
        np.where(xd, a * a * sa * sa + b * b * ca * ca, a * a * ca * ca + b * b * sa * sa)
    )
    c_s = np.where(xd, sy, sx)
    c_e = np.where(xd, ey, ex)
    c_ext = c_centre + sign * c_half
    c_lo = np.minimum(np.minimum(c_s, c_e), c_ext)
    c_hi = np.maximum(np.maximum(c_s, c_e), c_ext)
    n_c = np.where(xd, grid.ny, grid.nx)
    clip = (c_lo < -0.49) | (c_hi > n_c - 0.51)
    ellipse = (c_alpha != 0.0) | (beta != -1.0)
    kind = (
        _CLIP * clip.astype(np.intp)
        + _ELLIPSE * ellipse
        + _X_DRIVEN * xd
        + _UP * up
        + _PLUS * (sign > 0)
    )
    return _Plan(
        arc=geom.arc[row],
        pre=pre,
        n=n,
        last=last,
        complex_arc=complex_row[row],
        u0=first - d_centre,
        beta=beta,
        gamma=gamma,
        c_alpha=c_alpha,
        c_offset=c_centre + 1.5,
        c_max=np.where(xd, grid.ny + 1, grid.nx + 1).astype(np.float64),
        d_key0=(first.astype(np.intp) + 1) * d_mult,
        kind=kind,
        width=w,
        start_key=_padded_key(sx, sy, grid),
        end_key=_padded_key(ex, ey, grid),
    )


def _ranges(starts: IntArray, lengths: IntArray) -> IntArray:
    """Concatenation of ``arange(s, s + n)`` for each pair (vectorised)."""
    before = np.cumsum(lengths) - lengths
    total = int(lengths.sum())
    return np.arange(total, dtype=np.intp) + np.repeat(starts - before, lengths)


_BLOCK_FIELDS = ("u0", "beta", "gamma", "c_alpha", "c_offset", "c_max", "d_key0", "n")

# Bits of a block's kind: all its pieces share them, so they become scalars.
_CLIP, _ELLIPSE, _X_DRIVEN, _UP, _PLUS = 1, 2, 4, 8, 16
_KINDS = 32


def _fill_block(
    par: dict[str, NDArray[Any]],
    width: int,
    kind: int,
    w: int,
    trash: int,
    out: IntArray,
    scratch: tuple[FloatArray, FloatArray],
) -> None:
    """Flat keys of the interior samples of a block of pieces into ``out`` (rows, width).

    ``par`` holds the per-piece parameters of the block's rows, which are sorted by
    sample count ``n``. All rows share ``kind`` (bits: may need clipping, ellipse rather
    than circle, x drives, driver increases, + branch of the root), so those cost no
    per-sample work. Slots past a row's ``n`` get ``trash``. ``scratch`` is reused memory
    of at least ``out.size`` elements (fresh temporaries cost a page fault per 4 KiB).
    """

    def col(name: str) -> NDArray[Any]:
        return par[name][:, None]

    shape = out.shape
    size = out.size
    u = scratch[0][:size].reshape(shape)
    q = scratch[1][:size].reshape(shape)
    kf = np.arange(width, dtype=np.float64)
    ki = np.arange(width, dtype=np.intp)
    if kind & _UP:
        np.add(col("u0"), kf, out=u)
    else:
        np.subtract(col("u0"), kf, out=u)
    np.multiply(u, u, out=q)
    if kind & _ELLIPSE:
        q *= col("beta")
        q += col("gamma")
    else:  # circle: beta = -1
        np.subtract(col("gamma"), q, out=q)
    # q > 0 on every piece (it stays clear of the vertical tangents); only the padding
    # slots past n may give NaN, and they are overwritten below.
    with np.errstate(invalid="ignore"):
        np.sqrt(q, out=q)
        if kind & _ELLIPSE:
            u *= col("c_alpha")
            if kind & _PLUS:  # off + alpha u + sqrt
                q += u
            else:  # off - (sqrt - alpha u)
                q -= u
        # A row-driven piece inside the grid: key = floor(q) + driver key, an integer
        # added before the floor, so the whole key is made in float (one fewer pass).
        fold = not kind & (_X_DRIVEN | _CLIP)
        off = par["c_offset"] + par["d_key0"] if fold else par["c_offset"]
        if kind & _PLUS:
            q += off[:, None]
        else:
            np.subtract(off[:, None], q, out=q)
        if kind & _CLIP:
            np.maximum(q, 0.0, out=q)
            np.minimum(q, col("c_max"), out=q)
        if fold:
            q += kf * (w if kind & _UP else -w)
        np.copyto(out, q, casting="unsafe")  # truncation = floor: q >= 0
    if not fold:
        d_mult = 1
        if kind & _X_DRIVEN:
            out *= w
        else:
            d_mult = w
        out += col("d_key0")
        out += ki * (d_mult if kind & _UP else -d_mult)
    n = par["n"]
    n_min = int(n[0])
    if n_min < width:
        tail = out[:, n_min:]
        np.putmask(tail, ki[None, n_min:] >= n[:, None], trash)


@dataclass(frozen=True)
class _BatchKeys:
    keys: IntArray  # buffer of padded flat keys (repeats and padding hold the trash key)
    row_base: IntArray  # buffer position of each piece's first interior sample
    start_pos: IntArray  # buffer position of each piece's start point (-1 if none)
    end_pos: IntArray


def _batch_keys(plan: _Plan, p0: int, p1: int, trash: int) -> _BatchKeys:
    """Keys of all samples of pieces ``[p0, p1)`` (whole arcs), each arc's repeats trashed."""
    n = plan.n[p0:p1]
    pre = plan.pre[p0:p1]
    npc = p1 - p0
    w = int(plan.width)
    live = np.flatnonzero(n > 0)
    wi_live = np.searchsorted(_WIDTHS, n[live])
    group = wi_live * _KINDS + plan.kind[p0:p1][live]
    perm = np.lexsort((n[live], group))
    order = live[perm]
    group = group[perm]
    gathered = {name: getattr(plan, name)[order + p0] for name in _BLOCK_FIELDS}
    widths = _WIDTHS[group // _KINDS]
    n_interior = int(widths.sum())
    n_pre = int(pre.sum())
    keys = np.empty(n_interior + n_pre + npc, dtype=np.intp)
    row_base = np.full(npc, -1, dtype=np.intp)
    pos = 0
    cuts = np.concatenate([[0], np.flatnonzero(np.diff(group)) + 1, [order.shape[0]]])
    if order.shape[0] == 0:
        cuts = cuts[:1]
    biggest = max(_CHUNK, int(widths.max()) if widths.size else 0)
    scratch = (np.empty(biggest), np.empty(biggest))
    for g0, g1 in itertools.pairwise(cuts.tolist()):
        width = int(widths[g0])
        kind = int(group[g0] % _KINDS)
        per = max(1, _CHUNK // width)
        for b0 in range(int(g0), int(g1), per):
            b1 = min(b0 + per, int(g1))
            rows_local = order[b0:b1]
            nr = b1 - b0
            block = keys[pos : pos + nr * width].reshape(nr, width)
            par = {name: v[b0:b1] for name, v in gathered.items()}
            _fill_block(par, width, kind, w, trash, block, scratch)
            row_base[rows_local] = pos + width * np.arange(nr, dtype=np.intp)
            pos += nr * width
    start_pos = np.full(npc, -1, dtype=np.intp)
    has_pre = pre.astype(bool)
    start_pos[has_pre] = pos + np.arange(n_pre, dtype=np.intp)
    keys[pos : pos + n_pre] = plan.start_key[p0:p1][has_pre]
    pos += n_pre
    end_pos = pos + np.arange(npc, dtype=np.intp)
    keys[pos : pos + npc] = plan.end_key[p0:p1]
    _trash_repeats(plan, p0, p1, keys, row_base, start_pos, end_pos, trash)
    return _BatchKeys(keys=keys, row_base=row_base, start_pos=start_pos, end_pos=end_pos)


def _trash_repeats(
    plan: _Plan,
    p0: int,
    p1: int,
    keys: IntArray,
    row_base: IntArray,
    start_pos: IntArray,
    end_pos: IntArray,
    trash: int,
) -> None:
    """Send every repeat of a cell within one arc to ``trash`` (in place).

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
    seq[_ranges(off + pre, head)] = _ranges(row_base, head)
    seq[_ranges(off + pre + head, tail)] = _ranges(row_base + n - tail, tail)
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
            [_ranges(row_base[cx], n[cx]), start_pos[cx][pre[cx] > 0], end_pos[cx]]
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


def _batches(plan: _Plan) -> Iterator[tuple[int, int]]:
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

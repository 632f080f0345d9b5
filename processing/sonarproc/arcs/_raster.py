"""The connected-chain rasteriser behind :mod:`sonarproc.arcs` (private; use that package).

Each reading's arc (see :mod:`sonarproc.arcs._geometry`) is drawn as a minimal
8-connected chain of cells, the way a midpoint circle algorithm draws one, but
vectorised over all arcs at once (no Python loop per arc, per piece or per sample):

1. Each arc is cut into pieces at the points where its tangent is at 45 degrees. On a
   "flat" piece (``|dy/dx| <= 1``) the chain takes one cell per grid column, on a "steep"
   piece one cell per row; the other coordinate comes from the closed-form conic
   ``v = alpha u +- sqrt(beta u^2 + gamma)``. The exact end points of every piece (beam
   limits and the 45 degree points) are cells of the chain too, which closes the joints.
2. The cells must be those of exact arithmetic (a rounding slip near a 45-degree point
   would open a gap), but float32 is three times cheaper per sample. So v is computed in
   float32 with a proven per-piece error bound eps (:func:`_f32_error_bound`), and the
   few samples whose v lies within eps of a cell edge (about 0.2 %) are recomputed in
   float64; rows whose bound is too loose go wholly through float64. Keys are sums of
   integers, exact in float32 below 2**24.
3. Pieces are sorted by kind (circle or ellipse, axis, direction, branch, needs
   clipping, float64) and sample count into blocks of nearly equal lengths, so each
   block is a handful of broadcast numpy operations on a 2-D array in reused memory that
   stays in cache.
4. Within a piece the cells are distinct (one per column or row). A cell can repeat
   only next to a piece's ends, and on an arc whose tangent turns by at most 45 degrees
   two samples in one cell lie within about 1.5 cells of arc; so the repeats are found
   by comparing each end sample with the few before it along the arc. Other arcs (wide
   beams, thin ellipses, two-piece joint regions) get an exact sort-based check.
5. Keys are flat cell indices ``iy * nx + ix``; cells outside the grid and padding slots
   take the trash key ``nx * ny``. On a piece the computed coordinate moves by at most
   one cell per sample, so samples near a piece end that lies far outside the grid are
   surely outside and are not made at all (:func:`_plan_part`).
6. :func:`accumulate` scatters each block with ``np.add.at`` while the block is in
   cache, into a uint16 count map where a tile bound (:func:`_overlap_bound`) proves no
   cell reaches 2**16 arcs (else uint32); it keeps aside only the samples that may
   repeat, and takes the repeats off again. :func:`batch_keys` (for
   :func:`sonarproc.arcs.arc_cells`) writes all keys to one buffer and trashes the
   repeats there. Arcs are processed in batches of about ``_BATCH`` samples.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs._geometry import TWO_PI, ArcGeometry, mod_2pi, unit_vectors
from sonarproc.grid import Grid

#: Arcs whose tangent may turn more than this (rad) get the exact (sorting) repeat check.
_SIMPLE_TURNING = np.pi / 4
#: Cells of a simple arc repeat at most this many places apart in its boundary sequence.
_LAG = 8
#: Interior samples at each end of a piece that may repeat a cell of the arc.
_EDGE = 2
#: Samples per generation block (its temporaries stay in a core's L2 cache).
_CHUNK = 1 << 17
#: Samples per batch of whole arcs: bounds the key buffer of :func:`batch_keys`.
_BATCH = 1 << 25
#: Pieces of about this many samples or fewer share a block whatever their count.
_SMALL = 8
#: Rows whose float32 error bound (cells) exceeds this are computed in float64.
_F32_MAX_ERROR = 0.05
#: Unit roundoff of float32.
_U32 = 2.0**-24
#: Flat keys below this are made in float32 (which holds integers up to 2**24 exactly).
_F32_KEY_LIMIT = 1 << 24
#: Side (cells) of the tiles on which :func:`_overlap_bound` counts arcs.
_TILE = 64
#: Arcs per chunk of :func:`plan_pieces`.
_PLAN_CHUNK = 8192
#: Rounds of skipping samples outside the grid from the ends of clipped pieces.
_TRIM_ROUNDS = 3

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class RasterPlan:
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
    kind: IntArray  # block kind bits (_CLIP, _ELLIPSE, _X_DRIVEN, _UP, _PLUS, _F64)
    start_key: IntArray
    end_key: IntArray
    par: FloatArray  # (pieces, len(_PAR)) sampling parameters, one row a piece
    width: int  # grid width
    overlap: int  # upper bound of the count of any cell

    def __len__(self) -> int:
        return int(self.n.shape[0])

    def __getattr__(self, name: str) -> FloatArray:
        """A column of :attr:`par` by its name in ``_PAR``."""
        if name in _PAR:
            return self.par[:, _PAR.index(name)]
        raise AttributeError(name)


#: Columns of :attr:`RasterPlan.par`; the first eight are those the float32 blocks use.
_PAR = (
    "u0",  # driver coordinate of the first interior sample minus the centre's
    "beta",
    "gamma",
    "c_alpha",
    "c_frac",  # c_offset - floor(c_offset), in [0, 1); c_offset = centre's coordinate + 0.5
    "c_int",  # floor(c_offset)
    "c_max",  # last index of the computed axis
    "row_key",  # key part of a row that is not floor(v) (an integer)
    "d_key0",  # flat-key part of the first interior sample's driver index (an integer)
    "eps",  # bound of the float32 error of the computed coordinate
)
_N32 = 8


def _flat_key(gx: FloatArray, gy: FloatArray, grid: Grid) -> IntArray:
    """Flat key ``iy * nx + ix`` of continuous grid coordinates; the trash key outside."""
    ix = np.floor(gx + 0.5)
    iy = np.floor(gy + 0.5)
    out = (ix < 0) | (ix >= grid.nx) | (iy < 0) | (iy >= grid.ny)
    key = (np.where(out, 0, iy) * grid.nx + np.where(out, 0, ix)).astype(np.intp)
    key[out] = grid.nx * grid.ny
    return key


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


def plan_pieces(geom: ArcGeometry, grid: Grid) -> RasterPlan:
    """Cut every arc into pieces and set up their sampling (vectorised, no loop per arc).

    Runs on chunks of ``_PLAN_CHUNK`` arcs: some 150 array operations per chunk, whose
    arrays then stay in cache.
    """
    parts = [
        _plan_part(geom[i : i + _PLAN_CHUNK], grid) for i in range(0, len(geom), _PLAN_CHUNK)
    ] or [_plan_part(geom, grid)]
    par = np.concatenate([np.stack([part.pop(c) for c in _PAR], axis=1) for part in parts])
    f = {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}
    overlap = _overlap_bound(f.pop("x_lo"), f.pop("x_hi"), f.pop("y_lo"), f.pop("y_hi"), grid)
    return RasterPlan(**f, par=par, width=grid.nx, overlap=overlap)


def _plan_part(geom: ArcGeometry, grid: Grid) -> dict[str, NDArray[Any]]:
    """The fields of :class:`RasterPlan` (but ``width``, ``overlap``) for some arcs, and the
    pieces' boxes ``x_lo, x_hi, y_lo, y_hi`` (grid coordinates)."""
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
    offr = np.take(off, iv_row, axis=0)
    j0 = (offr[:, 0] < t).astype(np.intp) + (offr[:, 1] < t) + (offr[:, 2] < t) + (offr[:, 3] < t)
    idx = j0[:, None] + np.arange(4)[None, :]
    wrap = idx >= 4
    src = (4 * iv_row)[:, None] + np.where(wrap, idx - 4, idx)
    rel = off.ravel()[src] + np.where(wrap, TWO_PI, 0.0) - t[:, None]
    ln = length[:, None]
    inside = rel < ln
    c_lo, s_lo = unit_vectors(lo)
    c_hi, s_hi = unit_vectors(lo + length)
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
    # Two intervals, or (on either) a tangent that may turn more than _SIMPLE_TURNING.
    both = two & np.isfinite(geom.length[:, 0])
    turning = np.fmax(geom.turning[:, 0], geom.turning[:, 1])
    complex_row = (turning > _SIMPLE_TURNING) | both

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
    w = grid.nx
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
    # |dc/dd| <= 1 on a piece, so a sample is surely outside the grid while its driver is
    # nearer an end of the piece than that end is outside: skip those (with a margin).
    out_s = np.maximum(np.maximum(-0.5 - c_s, c_s - (n_c - 0.5)), 0.0)
    out_e = np.maximum(np.maximum(-0.5 - c_e, c_e - (n_c - 0.5)), 0.0)
    skip0 = np.maximum(np.floor(out_s - np.abs(first - ds)) - 1.0, 0.0)
    skip1 = np.maximum(np.floor(out_e - np.abs(de - lastd)) - 1.0, 0.0)
    skip0 = np.minimum(skip0, n)
    first = first + step * skip0
    n = np.maximum(n - skip0 - skip1, 0.0)
    # Then from the computed coordinate of the first and last samples themselves, a few
    # times over: sample j after one that is D outside is outside while j < D.
    cut = np.flatnonzero(clip & (n > 0))
    for _ in range(_TRIM_ROUNDS):
        if cut.size == 0:
            break
        nc = n[cut]
        fc = first[cut]
        st = step[cut]
        for at_end in (False, True):
            u = fc + (st * (nc - 1) if at_end else 0.0) - d_centre[cut]
            with np.errstate(invalid="ignore"):
                v = (
                    c_centre[cut]
                    + c_alpha[cut] * u
                    + sign[cut] * np.sqrt(np.maximum(beta[cut] * u * u + gamma[cut], 0.0))
                )
            away = np.maximum(np.maximum(-0.5 - v, v - (n_c[cut] - 0.5)), 0.0)
            k = np.minimum(np.where(away > 1e-6, np.ceil(away - 1e-6), 0.0), nc)
            if not at_end:
                fc = fc + st * k
            nc = nc - k
        first[cut] = fc
        n[cut] = nc
        cut = cut[nc > 0]
    n = n.astype(np.intp)
    ellipse = (c_alpha != 0.0) | (beta != -1.0)
    u0 = first - d_centre
    d_key0 = first.astype(np.intp) * d_mult
    c_offset = c_centre + 0.5
    c_int = np.floor(c_offset)
    row_key = np.where(clip, d_key0, c_int * np.where(xd, w, 1) + d_key0)
    eps = _f32_error_bound(u0, u0 + step * (n - 1), beta, gamma, c_alpha)
    f64 = ~(eps <= _F32_MAX_ERROR)
    kind = (
        _CLIP * clip.astype(np.intp)
        + _ELLIPSE * ellipse
        + _X_DRIVEN * xd
        + _UP * up
        + _PLUS * (sign > 0)
        + _F64 * f64
    )
    return dict(
        arc=geom.arc[row],
        pre=pre,
        n=n,
        last=last,
        complex_arc=complex_row[row],
        u0=u0,
        beta=beta,
        gamma=gamma,
        c_alpha=c_alpha,
        c_max=np.where(xd, grid.ny - 1, grid.nx - 1).astype(np.float64),
        d_key0=d_key0,
        kind=kind,
        start_key=_flat_key(sx, sy, grid),
        end_key=_flat_key(ex, ey, grid),
        c_frac=c_offset - c_int,
        c_int=c_int,
        row_key=row_key.astype(np.float64),
        eps=eps,
        x_lo=np.where(xd, np.minimum(sx, ex), c_lo),
        x_hi=np.where(xd, np.maximum(sx, ex), c_hi),
        y_lo=np.where(xd, c_lo, np.minimum(sy, ey)),
        y_hi=np.where(xd, c_hi, np.maximum(sy, ey)),
    )


def _overlap_bound(
    x_lo: FloatArray, x_hi: FloatArray, y_lo: FloatArray, y_hi: FloatArray, grid: Grid
) -> int:
    """An upper bound of any cell's count: the most piece boxes over one tile of cells.

    A piece's cells lie in its box (grid coordinates, widened by a cell); the boxes are
    added onto tiles of ``_TILE`` cells with a summed 2-D difference array.
    """
    if x_lo.shape[0] == 0:
        return 0
    nty = -(-grid.ny // _TILE)
    ntx = -(-grid.nx // _TILE)

    def tiles(lo: FloatArray, hi: FloatArray, nt: int) -> tuple[IntArray, IntArray]:
        with np.errstate(invalid="ignore"):
            a = np.clip(np.floor((lo - 1.0) / _TILE), 0, nt - 1)
            b = np.clip(np.floor((hi + 1.0) / _TILE), 0, nt - 1)
        return np.nan_to_num(a).astype(np.intp), np.nan_to_num(b, nan=nt - 1).astype(np.intp)

    tx0, tx1 = tiles(x_lo, x_hi, ntx)
    ty0, ty1 = tiles(y_lo, y_hi, nty)
    d = np.zeros((nty + 1) * (ntx + 1), dtype=np.int64)
    w = ntx + 1
    np.add.at(d, ty0 * w + tx0, 1)
    np.add.at(d, ty0 * w + tx1 + 1, -1)
    np.add.at(d, (ty1 + 1) * w + tx0, -1)
    np.add.at(d, (ty1 + 1) * w + tx1 + 1, 1)
    counts = np.cumsum(np.cumsum(d.reshape(nty + 1, w), axis=0), axis=1)
    return int(counts.max())


def _f32_error_bound(
    u_first: FloatArray, u_last: FloatArray, beta: FloatArray, gamma: FloatArray, alpha: FloatArray
) -> FloatArray:
    """Bound (cells) of the error of ``v = f + alpha u +- sqrt(beta u^2 + gamma)`` in float32.

    ``f`` is in [0, 1) and ``u`` runs from ``u_first`` to ``u_last`` by steps of 1; the
    inputs are float64 values rounded to float32 and every operation rounds once (unit
    roundoff ``e``). With ``U = max |u|`` the rounded ``u`` is off by at most ``2 e U``,
    the radicand ``Q`` by ``dQ <= 7 e |beta| U^2 + 2 e gamma``; ``Q`` is concave in ``u``
    (``beta < 0``), so its least value on the piece is at an end, and the square root is
    off by at most ``dQ / (1.8 sqrt(Q_min)) + e sqrt(gamma)``. ``alpha u`` adds
    ``4 e |alpha| U``; the rounding of ``f`` and of ``f + eps`` (the shift of
    :func:`_fill_block32`) ``2 e``; the two sums ``2 e (1 + |alpha| U + sqrt(gamma))``.
    The total, times 1.1 for the second-order terms, is returned; ``inf`` where ``Q_min``
    is not well clear of ``dQ``. ``test_float32_error_bound_holds`` checks it.
    """
    e = _U32
    big_u = np.maximum(np.abs(u_first), np.abs(u_last))
    with np.errstate(invalid="ignore", divide="ignore"):
        q_min = np.minimum(beta * u_first * u_first, beta * u_last * u_last) + gamma
        d_q = e * (7.0 * np.abs(beta) * big_u * big_u + 2.0 * np.abs(gamma))
        root = np.sqrt(np.abs(gamma))
        au = np.abs(alpha) * big_u
        # |sqrt(Q + d) - sqrt(Q)| = |d| / (sqrt(Q + d) + sqrt(Q)) <= |d| / (1.8 sqrt(Q))
        # when |d| < Q / 4.
        d_root = d_q / (1.8 * np.sqrt(np.maximum(q_min, 0.0))) + e * root
        bound = 1.1 * (d_root + 4.0 * e * au + 2.0 * e + 2.0 * e * (1.0 + au + root))
        bad = ~(q_min > 4.0 * d_q)
    bound[bad] = np.inf
    return np.asarray(bound, dtype=np.float64)


def ranges(starts: IntArray, lengths: IntArray) -> IntArray:
    """Concatenation of ``arange(s, s + n)`` for each pair (vectorised)."""
    before = np.cumsum(lengths) - lengths
    total = int(lengths.sum())
    return np.arange(total, dtype=np.intp) + np.repeat(starts - before, lengths)


# Bits of a block's kind: all its pieces share them, so they become scalars.
_CLIP, _ELLIPSE, _X_DRIVEN, _UP, _PLUS, _F64 = 1, 2, 4, 8, 16, 32


def _fill_block(
    par: dict[str, NDArray[Any]],
    width: int,
    kind: int,
    w: int,
    trash: int,
    out: IntArray,
    scratch: tuple[FloatArray, FloatArray],
) -> None:
    """Flat keys of a block's interior samples, in float64 (the general fallback).

    ``par`` holds the per-piece parameters of the block's rows. All rows share ``kind``
    (bits: may need clipping, ellipse rather than circle, x drives, driver increases, +
    branch of the root), so those cost no per-sample work. Slots past a row's ``n`` hold
    garbage. ``scratch`` is reused memory of at least ``out.size`` elements.
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
    # slots past n may give NaN.
    np.sqrt(q, out=q)
    if kind & _ELLIPSE:
        u *= col("c_alpha")
        if kind & _PLUS:  # off + alpha u + sqrt
            q += u
        else:  # off - (sqrt - alpha u)
            q -= u
    if kind & _PLUS:
        q += col("c_offset")
    else:
        np.subtract(col("c_offset"), q, out=q)
    if kind & _CLIP:  # outside the grid: q < 0 or q > c_max, i.e. q (q - c_max) > 0
        np.floor(q, out=q)
        np.subtract(q, col("c_max"), out=u)
        u *= q
        outside = u > 0.0
    np.copyto(out, q, casting="unsafe")  # truncation = floor: q is integral here or >= 0
    d_mult = 1
    if kind & _X_DRIVEN:
        out *= w
    else:
        d_mult = w
    out += col("d_key0")
    out += ki * (d_mult if kind & _UP else -d_mult)
    if kind & _CLIP:
        np.putmask(out, outside, trash)


def _fill_block32(
    par: dict[str, NDArray[Any]],
    par64: dict[str, NDArray[Any]],
    width: int,
    kind: int,
    w: int,
    f32_keys: bool,
    eps: float,
    trash: int,
    out: IntArray,
    scratch: tuple[NDArray[np.float32], NDArray[np.float32], NDArray[np.float32]],
    flags: BoolArray,
    ik: NDArray[np.int32],
) -> None:
    """As :func:`_fill_block`, with float32 arithmetic and exact float64 repair.

    The computed coordinate is ``v = frac + alpha u +- sqrt(beta u^2 + gamma)`` relative
    to the integer ``c_int``; its float32 error is below the rows' bound ``eps``
    (:func:`_f32_error_bound`), so ``floor(v)`` is exact wherever the fraction of v is at
    least ``eps`` from an integer. The few samples closer than that are recomputed in
    float64: the cells are those of the float64 computation. Keys are sums of integers;
    below 2**24 float32 holds them exactly (``f32_keys``), otherwise they are made in int64.
    """

    def col(name: str) -> NDArray[Any]:
        return par[name][:, None]

    shape = out.shape
    size = out.size
    u = scratch[0][:size].reshape(shape)
    q = scratch[1][:size].reshape(shape)
    t = scratch[2][:size].reshape(shape)
    risky = flags[:size].reshape(shape)
    kf = np.arange(width, dtype=np.float32)
    up = bool(kind & _UP)
    if up:
        np.add(col("u0"), kf, out=u)
    else:
        np.subtract(col("u0"), kf, out=u)
    np.multiply(u, u, out=q)
    if kind & _ELLIPSE:
        q *= col("beta")
        q += col("gamma")
    else:  # circle: beta = -1
        np.subtract(col("gamma"), q, out=q)
    np.sqrt(q, out=q)
    if kind & _ELLIPSE:
        u *= col("c_alpha")
        if kind & _PLUS:
            q += u
        else:
            q -= u
    # v + eps: floor(v) is floor(v + eps) unless the fraction of v + eps is below 2 eps.
    f_eps = col("c_frac") + np.float32(eps)
    if kind & _PLUS:
        q += f_eps
    else:
        np.subtract(f_eps, q, out=q)
    np.floor(q, out=t)
    q -= t  # the fraction (exact)
    np.less(q, np.float32(2.0 * eps), out=risky)
    flags[size : -(-size // 8) * 8] = False
    # Find the flagged samples eight at a time (np.flatnonzero on bools is slow).
    words = flags[: -(-size // 8) * 8].view(np.uint64)
    hit = np.flatnonzero(words != 0)
    if hit.size:
        cand = ((hit * 8)[:, None] + np.arange(8)).reshape(-1)
        _repair(par64, width, kind, cand[flags[cand]], t)
    if kind & _CLIP:  # outside the grid: t < 0 or t > c_max, i.e. t (t - c_max) > 0
        t += col("c_int")
        outside = flags[:size].reshape(shape)  # the repair is done with the flags
        np.subtract(t, col("c_max"), out=q)
        q *= t
        np.greater(q, np.float32(0.0), out=outside)
    d_step = (1 if kind & _X_DRIVEN else w) * (1 if up else -1)
    if f32_keys:  # exact integers in float32, then int32 (cheaper than float to int64)
        if kind & _X_DRIVEN:
            t *= np.float32(w)
        k32 = ik[:size].reshape(shape)
        np.add(t, col("row_key"), out=k32, casting="unsafe")
        k32 += np.arange(0, d_step * width, d_step, dtype=np.int32)[:width]
        np.copyto(out, k32)
    else:
        np.copyto(out, t, casting="unsafe")
        if kind & _X_DRIVEN:
            out *= w
        out += par64["row_key"].astype(np.intp)[:, None]
        out += np.arange(width, dtype=np.intp) * d_step
    if kind & _CLIP:  # the keys made from cells outside are garbage: trash them
        np.putmask(out, outside, trash)


def _repair(
    par64: dict[str, NDArray[Any]], width: int, kind: int, idx: IntArray, t: NDArray[np.float32]
) -> None:
    """Recompute ``floor(v)`` in float64 at the flat positions ``idx`` of ``t`` (in place)."""
    r, k = np.divmod(idx, width)
    u = par64["u0"][r] + (k if kind & _UP else -k)
    if kind & _ELLIPSE:
        q = par64["beta"][r] * u * u + par64["gamma"][r]
    else:
        q = par64["gamma"][r] - u * u
    s = np.sqrt(q)  # NaN only in padding slots (the caller ignores invalid values)
    if kind & _ELLIPSE:
        s = s + par64["c_alpha"][r] * u if kind & _PLUS else s - par64["c_alpha"][r] * u
    v = par64["c_frac"][r] + s if kind & _PLUS else par64["c_frac"][r] - s
    t.reshape(-1)[idx] = np.floor(v)


@dataclass(frozen=True)
class _Block:
    rows: IntArray  # piece indices (local to the batch) of the block's rows
    width: int
    kind: int
    keys: IntArray  # (rows, width) padded flat keys; slots past a row's n hold trash


def _blocks(plan: RasterPlan, p0: int, p1: int, trash: int) -> Iterator[_Block]:
    """Generation blocks of the pieces ``[p0, p1)`` with interior samples.

    Pieces are sorted by kind and sample count; a block takes consecutive pieces of one
    kind whose counts are within about 1/8 of the first (or all at most ``_SMALL``), and
    about ``_CHUNK`` samples. The yielded keys live in reused memory.
    """
    n = plan.n[p0:p1]
    live = np.flatnonzero(n > 0)
    if live.size == 0:
        return
    kinds = plan.kind[p0:p1][live]
    perm = np.argsort(kinds * (int(n.max()) + 1) + n[live])
    order = live[perm]
    kinds = kinds[perm]
    ns = n[order]
    g64 = np.take(plan.par, order + p0, axis=0)  # (much faster than fancy indexing)
    g32 = g64[:, :_N32].astype(np.float32)
    chunk = max(int(_CHUNK), 1)
    biggest = max(chunk, int(ns.max()))
    s64 = (np.empty(biggest), np.empty(biggest))
    s32 = (
        np.empty(biggest, dtype=np.float32),
        np.empty(biggest, dtype=np.float32),
        np.empty(biggest, dtype=np.float32),
    )
    flags = np.zeros(biggest + 8, dtype=bool)
    ik = np.empty(biggest, dtype=np.int32)
    keys = np.empty(biggest, dtype=np.intp)
    w = int(plan.width)
    f32_keys = trash + 2 * w < _F32_KEY_LIMIT
    ks = np.arange(biggest, dtype=np.intp)
    cuts = [*(np.flatnonzero(np.diff(kinds)) + 1).tolist(), int(order.shape[0])]
    g0 = 0
    for g1 in cuts:
        kind = int(kinds[g0])
        i = g0
        while i < g1:
            n_i = int(ns[i])
            w_cap = max(n_i + n_i // 8 + 1, _SMALL)
            j = i + int(np.searchsorted(ns[i:g1], w_cap, side="right"))
            j = min(j, i + max(1, chunk // w_cap))
            width = int(ns[j - 1])
            out = keys[: (j - i) * width].reshape(j - i, width)
            p64 = {name: g64[i:j, c] for c, name in enumerate(_PAR)}
            # Padding slots past n may take NaN (the root of a negative) till trashed.
            with np.errstate(invalid="ignore"):
                if kind & _F64:
                    p64["c_offset"] = p64["c_int"] + p64["c_frac"]
                    p64["d_key0"] = p64["d_key0"].astype(np.intp)
                    _fill_block(p64, width, kind, w, trash, out, s64)
                else:
                    p32 = {name: g32[i:j, c] for c, name in enumerate(_PAR[:_N32])}
                    eps = float(p64["eps"].max())
                    _fill_block32(
                        p32, p64, width, kind, w, f32_keys, eps, trash, out, s32, flags, ik
                    )
            n_min = n_i
            if n_min < width:  # padding slots past a row's n go to the trash bin
                tail = out[:, n_min:]
                np.putmask(tail, ks[n_min:width] >= ns[i:j, None], trash)
            yield _Block(rows=order[i:j], width=width, kind=kind, keys=out)
            i = j
        g0 = g1


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
    for blk in _blocks(plan, p0, p1, trash):
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
        for blk in _blocks(plan, p0, p1, trash):
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

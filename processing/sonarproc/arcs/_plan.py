"""Cutting arcs into pieces for the connected-chain rasteriser (private; see :mod:`sonarproc.arcs`).

Each arc is cut at the points where its tangent is at 45 degrees. On a "flat" piece
(``|dy/dx| <= 1``) the chain takes one cell per grid column, on a "steep" piece one cell per
row; the other coordinate comes from the closed-form conic ``v = alpha u +- sqrt(beta u^2 +
gamma)``, whose parameters (in grid units) :func:`plan_pieces` sets up for every piece at
once. The exact end points of every piece (beam limits and the 45 degree points) are cells
of the chain too, which closes the joints. On a piece the computed coordinate moves by at
most one cell per sample, so samples near a piece end that lies far outside the grid are
surely outside and are not planned at all.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs._bounds import f32_error_bound, overlap_bound
from sonarproc.arcs._geometry import TWO_PI, ArcGeometry, mod_2pi, unit_vectors
from sonarproc.grid import Grid

__all__ = [
    "CLIP",
    "ELLIPSE",
    "F64",
    "N32",
    "PAR",
    "PLUS",
    "UP",
    "X_DRIVEN",
    "RasterPlan",
    "plan_pieces",
]

#: Arcs whose tangent may turn more than this (rad) get the exact (sorting) repeat check.
_SIMPLE_TURNING = np.pi / 4
#: Rows whose float32 error bound (cells) exceeds this are computed in float64.
_F32_MAX_ERROR = 0.05
#: Arcs per chunk of :func:`plan_pieces`.
_PLAN_CHUNK = 8192
#: Rounds of skipping samples outside the grid from the ends of clipped pieces.
_TRIM_ROUNDS = 3

# Bits of a piece's kind: all pieces of a generation block share them, so they become scalars.
CLIP, ELLIPSE, X_DRIVEN, UP, PLUS, F64 = 1, 2, 4, 8, 16, 32

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
    kind: IntArray  # block kind bits (CLIP, ELLIPSE, X_DRIVEN, UP, PLUS, F64)
    start_key: IntArray
    end_key: IntArray
    par: FloatArray  # (pieces, len(PAR)) sampling parameters, one row a piece
    width: int  # grid width
    overlap: int  # upper bound of the count of any cell

    def __len__(self) -> int:
        return int(self.n.shape[0])

    def __getattr__(self, name: str) -> FloatArray:
        """A column of :attr:`par` by its name in ``PAR``."""
        if name in PAR:
            return self.par[:, PAR.index(name)]
        raise AttributeError(name)


#: Columns of :attr:`RasterPlan.par`; the first eight are those the float32 blocks use.
PAR = (
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
N32 = 8


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
    par = np.concatenate([np.stack([part.pop(c) for c in PAR], axis=1) for part in parts])
    f = {name: np.concatenate([part[name] for part in parts]) for name in parts[0]}
    overlap = overlap_bound(f.pop("x_lo"), f.pop("x_hi"), f.pop("y_lo"), f.pop("y_hi"), grid)
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
    eps = f32_error_bound(u0, u0 + step * (n - 1), beta, gamma, c_alpha)
    f64 = ~(eps <= _F32_MAX_ERROR)
    kind = (
        CLIP * clip.astype(np.intp)
        + ELLIPSE * ellipse
        + X_DRIVEN * xd
        + UP * up
        + PLUS * (sign > 0)
        + F64 * f64
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

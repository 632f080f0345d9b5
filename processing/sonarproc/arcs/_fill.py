"""Generation blocks of the rasteriser: every interior sample's cell key (private).

The cells must be those of exact arithmetic (a rounding slip near a 45-degree point would
open a gap), but float32 is three times cheaper per sample. So v is computed in float32
with a proven per-piece error bound eps (:func:`sonarproc.arcs._bounds.f32_error_bound`),
and the few samples whose v lies within eps of a cell edge (about 0.2 %) are recomputed
in float64; rows whose bound is too loose go wholly through float64. Keys are sums of
integers, exact in float32 below 2**24. Pieces are sorted by kind (circle or ellipse,
axis, direction, branch, needs clipping, float64) and sample count into blocks of nearly
equal lengths, so each block is a handful of broadcast numpy operations on a 2-D array in
reused memory that stays in cache.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sonarproc.arcs._plan import (
    CLIP,
    ELLIPSE,
    F64,
    N32,
    PAR,
    PLUS,
    UP,
    X_DRIVEN,
    BoolArray,
    FloatArray,
    IntArray,
    RasterPlan,
)

__all__ = ["Block", "blocks"]

#: Samples per generation block (its temporaries stay in a core's L2 cache).
_CHUNK = 1 << 17
#: Pieces of about this many samples or fewer share a block whatever their count.
_SMALL = 8
#: Flat keys below this are made in float32 (which holds integers up to 2**24 exactly).
_F32_KEY_LIMIT = 1 << 24


def fill_block(
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
    if kind & UP:
        np.add(col("u0"), kf, out=u)
    else:
        np.subtract(col("u0"), kf, out=u)
    np.multiply(u, u, out=q)
    if kind & ELLIPSE:
        q *= col("beta")
        q += col("gamma")
    else:  # circle: beta = -1
        np.subtract(col("gamma"), q, out=q)
    # q > 0 on every piece (it stays clear of the vertical tangents); only the padding
    # slots past n may give NaN.
    np.sqrt(q, out=q)
    if kind & ELLIPSE:
        u *= col("c_alpha")
        if kind & PLUS:  # off + alpha u + sqrt
            q += u
        else:  # off - (sqrt - alpha u)
            q -= u
    if kind & PLUS:
        q += col("c_offset")
    else:
        np.subtract(col("c_offset"), q, out=q)
    if kind & CLIP:  # outside the grid: q < 0 or q > c_max, i.e. q (q - c_max) > 0
        np.floor(q, out=q)
        np.subtract(q, col("c_max"), out=u)
        u *= q
        outside = u > 0.0
    np.copyto(out, q, casting="unsafe")  # truncation = floor: q is integral here or >= 0
    d_mult = 1
    if kind & X_DRIVEN:
        out *= w
    else:
        d_mult = w
    out += col("d_key0")
    out += ki * (d_mult if kind & UP else -d_mult)
    if kind & CLIP:
        np.putmask(out, outside, trash)


def fill_block32(
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
    """As :func:`fill_block`, with float32 arithmetic and exact float64 repair.

    The computed coordinate is ``v = frac + alpha u +- sqrt(beta u^2 + gamma)`` relative
    to the integer ``c_int``; its float32 error is below the rows' bound ``eps``
    (:func:`f32_error_bound`), so ``floor(v)`` is exact wherever the fraction of v is at
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
    up = bool(kind & UP)
    if up:
        np.add(col("u0"), kf, out=u)
    else:
        np.subtract(col("u0"), kf, out=u)
    np.multiply(u, u, out=q)
    if kind & ELLIPSE:
        q *= col("beta")
        q += col("gamma")
    else:  # circle: beta = -1
        np.subtract(col("gamma"), q, out=q)
    np.sqrt(q, out=q)
    if kind & ELLIPSE:
        u *= col("c_alpha")
        if kind & PLUS:
            q += u
        else:
            q -= u
    # v + eps: floor(v) is floor(v + eps) unless the fraction of v + eps is below 2 eps.
    f_eps = col("c_frac") + np.float32(eps)
    if kind & PLUS:
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
        repair(par64, width, kind, cand[flags[cand]], t)
    if kind & CLIP:  # outside the grid: t < 0 or t > c_max, i.e. t (t - c_max) > 0
        t += col("c_int")
        outside = flags[:size].reshape(shape)  # the repair is done with the flags
        np.subtract(t, col("c_max"), out=q)
        q *= t
        np.greater(q, np.float32(0.0), out=outside)
    d_step = (1 if kind & X_DRIVEN else w) * (1 if up else -1)
    if f32_keys:  # exact integers in float32, then int32 (cheaper than float to int64)
        if kind & X_DRIVEN:
            t *= np.float32(w)
        k32 = ik[:size].reshape(shape)
        np.add(t, col("row_key"), out=k32, casting="unsafe")
        k32 += np.arange(0, d_step * width, d_step, dtype=np.int32)[:width]
        np.copyto(out, k32)
    else:
        np.copyto(out, t, casting="unsafe")
        if kind & X_DRIVEN:
            out *= w
        out += par64["row_key"].astype(np.intp)[:, None]
        out += np.arange(width, dtype=np.intp) * d_step
    if kind & CLIP:  # the keys made from cells outside are garbage: trash them
        np.putmask(out, outside, trash)


def repair(
    par64: dict[str, NDArray[Any]], width: int, kind: int, idx: IntArray, t: NDArray[np.float32]
) -> None:
    """Recompute ``floor(v)`` in float64 at the flat positions ``idx`` of ``t`` (in place)."""
    r, k = np.divmod(idx, width)
    u = par64["u0"][r] + (k if kind & UP else -k)
    if kind & ELLIPSE:
        q = par64["beta"][r] * u * u + par64["gamma"][r]
    else:
        q = par64["gamma"][r] - u * u
    s = np.sqrt(q)  # NaN only in padding slots (the caller ignores invalid values)
    if kind & ELLIPSE:
        s = s + par64["c_alpha"][r] * u if kind & PLUS else s - par64["c_alpha"][r] * u
    v = par64["c_frac"][r] + s if kind & PLUS else par64["c_frac"][r] - s
    t.reshape(-1)[idx] = np.floor(v)


@dataclass(frozen=True)
class Block:
    rows: IntArray  # piece indices (local to the batch) of the block's rows
    width: int
    kind: int
    keys: IntArray  # (rows, width) padded flat keys; slots past a row's n hold trash


def blocks(plan: RasterPlan, p0: int, p1: int, trash: int) -> Iterator[Block]:
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
    g32 = g64[:, :N32].astype(np.float32)
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
            p64 = {name: g64[i:j, c] for c, name in enumerate(PAR)}
            # Padding slots past n may take NaN (the root of a negative) till trashed.
            with np.errstate(invalid="ignore"):
                if kind & F64:
                    p64["c_offset"] = p64["c_int"] + p64["c_frac"]
                    p64["d_key0"] = p64["d_key0"].astype(np.intp)
                    fill_block(p64, width, kind, w, trash, out, s64)
                else:
                    p32 = {name: g32[i:j, c] for c, name in enumerate(PAR[:N32])}
                    eps = float(p64["eps"].max())
                    fill_block32(
                        p32, p64, width, kind, w, f32_keys, eps, trash, out, s32, flags, ik
                    )
            n_min = n_i
            if n_min < width:  # padding slots past a row's n go to the trash bin
                tail = out[:, n_min:]
                np.putmask(tail, ks[n_min:width] >= ns[i:j, None], trash)
            yield Block(rows=order[i:j], width=width, kind=kind, keys=out)
            i = j
        g0 = g1

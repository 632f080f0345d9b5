"""Binary morphology on arc maps with the 3x3 square template (Baskent & Barshan, sec. 3.1).

Every operation takes a binary map (bool, or any integer array where non-zero is set) and
returns a new bool array of the same shape; cells outside the map count as 0. All of them
reduce to the 3x3 box sum (the cell plus its 8 neighbours), computed as two separable
passes of in-place adds on shifted views of a uint8 array, in horizontal strips that stay
in cache:

- ``neighbour_count = box - img``
- ``thinning(n)``: a set cell stays set when at least n of its 8 neighbours are set
  (``img & (box > n)``); ``pruning`` is n = 1, ``erosion`` is n = 8;
- ``dilation``: a cell is set when any cell of its 3x3 block is set (``box > 0``);
- ``opening`` = dilation(erosion), ``closing`` = erosion(dilation).

Chains of operations are written ``"closing,thinning:3"`` (:func:`parse_ops`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sonarproc.errors import ParameterError

__all__ = [
    "OPS",
    "Op",
    "apply_ops",
    "box_count",
    "closing",
    "dilation",
    "erosion",
    "neighbour_count",
    "opening",
    "parse_ops",
    "pruning",
    "thinning",
]

BoolArray = NDArray[np.bool_]
U8Array = NDArray[np.uint8]

#: Rows per strip: a few strips of ~4000 uint8 columns fit in L2 cache.
_STRIP = 64


def _as_u8(img: ArrayLike) -> U8Array:
    """A 2-D 0/1 uint8 view or copy of a binary map."""
    a = np.asarray(img)
    if a.ndim != 2:
        raise ValueError(f"expected a 2-D map, got shape {a.shape}")
    if a.dtype == np.bool_:
        return np.ascontiguousarray(a).view(np.uint8)
    if not (np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)):
        raise TypeError(f"expected a binary (bool or numeric) map, got dtype {a.dtype}")
    return (a != 0).view(np.uint8)


def _box_strip(u8: U8Array, r0: int, r1: int, hsum: U8Array, out: U8Array) -> None:
    """3x3 box sum of rows ``[r0, r1)`` into ``out[: r1 - r0]`` (outside counts 0).

    ``hsum`` is scratch of at least ``r1 - r0 + 2`` rows.
    """
    ny = u8.shape[0]
    h0 = max(r0 - 1, 0)
    h1 = min(r1 + 1, ny)
    src = u8[h0:h1]
    h = hsum[: h1 - h0]
    h[...] = src
    h[:, 1:] += src[:, :-1]
    h[:, :-1] += src[:, 1:]
    o = out[: r1 - r0]
    k = r0 - h0  # row of r0 inside h (0 or 1)
    o[...] = h[k : k + (r1 - r0)]
    if k == 1:
        o += h[0 : r1 - r0]
    else:
        o[1:] += h[0 : r1 - r0 - 1]
    top = k + (r1 - r0)  # row after r1 - 1 inside h
    if top < h.shape[0]:
        o += h[k + 1 : top + 1]
    else:
        o[:-1] += h[k + 1 : top]


def _box_apply(img: ArrayLike, finish: Callable[[U8Array, U8Array, BoolArray], None]) -> BoolArray:
    """Run ``finish(box_strip, img_strip, out_strip)`` over strips of the 3x3 box sum."""
    u8 = _as_u8(img)
    ny, nx = u8.shape
    out = np.empty((ny, nx), dtype=np.bool_)
    if ny == 0 or nx == 0:
        return out
    hsum = np.empty((_STRIP + 2, nx), dtype=np.uint8)
    box = np.empty((_STRIP, nx), dtype=np.uint8)
    for r0 in range(0, ny, _STRIP):
        r1 = min(r0 + _STRIP, ny)
        _box_strip(u8, r0, r1, hsum, box)
        finish(box[: r1 - r0], u8[r0:r1], out[r0:r1])
    return out


def box_count(img: ArrayLike) -> U8Array:
    """Number of set cells in each cell's 3x3 block (itself included), uint8.

    Examples
    --------
    >>> box_count(np.eye(3, dtype=bool)).tolist()
    [[2, 2, 1], [2, 3, 2], [1, 2, 2]]
    """
    u8 = _as_u8(img)
    out = np.empty(u8.shape, dtype=np.uint8)
    ny = u8.shape[0]
    if u8.size:
        hsum = np.empty((_STRIP + 2, u8.shape[1]), dtype=np.uint8)
        for r0 in range(0, ny, _STRIP):
            r1 = min(r0 + _STRIP, ny)
            _box_strip(u8, r0, r1, hsum, out[r0:r1])
    return out


def neighbour_count(img: ArrayLike) -> U8Array:
    """Number of set 8-neighbours of every cell (cells outside the map count 0), uint8.

    Examples
    --------
    >>> neighbour_count(np.ones((2, 3), dtype=bool)).tolist()
    [[3, 5, 3], [3, 5, 3]]
    """
    out = box_count(img)
    out -= _as_u8(img)
    return out


def thinning(img: ArrayLike, n: int) -> BoolArray:
    """Keep a set cell when at least ``n`` of its 8 neighbours are set (1 <= n <= 8).

    Raises
    ------
    ValueError
        If n is not an integer in 1..8.

    Examples
    --------
    >>> m = np.array([[1, 1, 0, 0], [1, 1, 0, 1]], dtype=bool)
    >>> thinning(m, 3).astype(int).tolist()
    [[1, 1, 0, 0], [1, 1, 0, 0]]
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= 8:
        raise ValueError(f"thinning needs an integer n with 1 <= n <= 8, got {n!r}")
    thr = int(n)

    def finish(box: U8Array, src: U8Array, dst: BoolArray) -> None:
        np.greater(box, thr, out=dst)
        dst &= src.view(np.bool_)

    return _box_apply(img, finish)


def pruning(img: ArrayLike) -> BoolArray:
    """Remove isolated cells: thinning with n = 1.

    Examples
    --------
    >>> pruning(np.array([[1, 0, 1, 1]])).astype(int).tolist()
    [[0, 0, 1, 1]]
    """
    return thinning(img, 1)


def erosion(img: ArrayLike) -> BoolArray:
    """Keep a set cell when all 8 neighbours are set (outside the map counts as unset).

    Examples
    --------
    >>> erosion(np.ones((3, 4), dtype=bool)).astype(int).tolist()
    [[0, 0, 0, 0], [0, 1, 1, 0], [0, 0, 0, 0]]
    """

    def finish(box: U8Array, src: U8Array, dst: BoolArray) -> None:
        np.equal(box, 9, out=dst)

    return _box_apply(img, finish)


def dilation(img: ArrayLike) -> BoolArray:
    """Set every cell whose 3x3 block holds a set cell.

    Examples
    --------
    >>> dilation(np.array([[0, 0, 0, 0], [0, 1, 0, 0]])).astype(int).tolist()
    [[1, 1, 1, 0], [1, 1, 1, 0]]
    """

    def finish(box: U8Array, src: U8Array, dst: BoolArray) -> None:
        np.not_equal(box, 0, out=dst)

    return _box_apply(img, finish)


def opening(img: ArrayLike) -> BoolArray:
    """Erosion then dilation: removes features thinner than the template.

    Examples
    --------
    >>> m = np.zeros((5, 6), dtype=bool); m[1:4, 1:4] = True; m[2, 5] = True
    >>> int(opening(m).sum())
    9
    """
    return dilation(erosion(img))


def closing(img: ArrayLike) -> BoolArray:
    """Dilation then erosion: fills one-cell gaps and holes.

    Examples
    --------
    >>> m = np.zeros((5, 7), dtype=bool); m[1:4, 1:6] = True; m[2, 3] = False
    >>> bool(closing(m)[2, 3])
    True
    """
    return erosion(dilation(img))


@dataclass(frozen=True)
class Op:
    """One morphological operation of a chain: a name and, for thinning, n."""

    name: str
    n: int | None = None

    def __str__(self) -> str:
        return self.name if self.n is None else f"{self.name}:{self.n}"


#: Operation names accepted by :func:`parse_ops`, and whether they take ``:n``.
OPS: dict[str, bool] = {
    "erosion": False,
    "dilation": False,
    "opening": False,
    "closing": False,
    "pruning": False,
    "thinning": True,
}

_SIMPLE: dict[str, Callable[[ArrayLike], BoolArray]] = {
    "erosion": erosion,
    "dilation": dilation,
    "opening": opening,
    "closing": closing,
    "pruning": pruning,
}


def _allowed() -> str:
    return ", ".join(f"{k}:N" if v else k for k, v in OPS.items())


def parse_ops(spec: str) -> list[Op]:
    """Parse a comma-separated chain such as ``"closing,thinning:3"``.

    Names are case-insensitive and may carry spaces around them; an empty spec is an
    empty chain.

    Raises
    ------
    ValueError
        Naming the bad token and the allowed names, for an unknown name, a missing or bad
        n for thinning (1..8), or an n given to an operation that takes none.

    Examples
    --------
    >>> [str(op) for op in parse_ops("closing, thinning:3")]
    ['closing', 'thinning:3']
    """
    ops: list[Op] = []
    if not spec.strip():
        return ops
    for raw in spec.split(","):
        token = raw.strip()
        name, sep, arg = token.partition(":")
        name = name.strip().lower()
        arg = arg.strip()
        if name not in OPS:
            raise ParameterError(
                "ops", f"unknown morphological operation {token!r}; allowed: {_allowed()}"
            )
        if OPS[name]:
            if not sep or not arg:
                raise ParameterError(
                    "ops", f"{token!r}: {name} needs n, e.g. {name}:3 (1 <= n <= 8)"
                )
            try:
                n = int(arg)
            except ValueError:
                raise ParameterError(
                    "ops", f"{token!r}: n must be an integer 1..8, got {arg!r}"
                ) from None
            if not 1 <= n <= 8:
                raise ParameterError("ops", f"{token!r}: n must be in 1..8, got {n}")
            ops.append(Op(name, n))
        else:
            if sep:
                raise ParameterError(
                    "ops", f"{token!r}: {name} takes no argument; allowed: {_allowed()}"
                )
            ops.append(Op(name))
    return ops


def apply_ops(img: ArrayLike, ops: Sequence[Op] | str) -> BoolArray:
    """Apply a chain of operations in order (a spec string is parsed first).

    An empty chain returns the binary map itself (as a new bool array).

    Examples
    --------
    >>> m = np.zeros((5, 7), dtype=bool); m[1:4, 1:6] = True; m[2, 3] = False
    >>> int(apply_ops(m, "closing,thinning:8").sum())
    3
    """
    chain = parse_ops(ops) if isinstance(ops, str) else list(ops)
    out = _as_u8(img).view(np.bool_).copy()
    for op in chain:
        if op.name == "thinning":
            if op.n is None:
                raise ValueError("thinning needs n (1 <= n <= 8)")
            out = thinning(out, op.n)
        elif op.name in _SIMPLE:
            if op.n is not None:
                raise ValueError(f"{op.name} takes no n, got {op.n}")
            out = _SIMPLE[op.name](out)
        else:
            raise ValueError(f"unknown morphological operation {op.name!r}; allowed: {_allowed()}")
    return out

"""Count-map operations for the ``--ops`` chain: arc votes, beyond the paper's binary map.

The paper processes the *binary* arc map (a cell is set when at least one arc crosses
it). When many arcs are drawn (hundreds of sensor pairs a metre or two from the surface)
that map is saturated in a band around the surface: nearly every cell there is crossed
by some arc, and thinning keeps whole blobs. The *count* map (how many distinct arcs
cross each cell, :func:`sonarproc.arcs.rasterize_arcs`) still shows the surface sharply,
because the arcs are tangent to it where they reflected and only cross it elsewhere.
These operations use the counts:

* ``vote:K`` keeps the set cells crossed by at least ``K`` arcs (``K >= 1``; ``vote:1``
  changes nothing). ``vote:auto`` picks ``K`` from the counts alone
  (:func:`auto_vote_threshold`), no ground truth.
* ``ridge`` (or ``ridge:P``, ``1 <= P <= 100``, default 50) keeps, in each column, the set
  cells whose count is at least ``P`` % of the largest count among that column's set
  cells: the crest of the votes, one or a few cells thick.

They chain with the paper's operations (:mod:`sonarproc.morphology`) in any order, e.g.
``"vote:auto,ridge"`` or ``"vote:3,thinning:2"``; each works on the current binary map
and, for ``vote``/``ridge``, on the counts of its set cells. A chain without them is
exactly the paper's: :func:`apply_chain` then calls :func:`sonarproc.morphology.apply_ops`
on ``counts > 0``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sonarproc.errors import ParameterError
from sonarproc.morphology._binary import OPS, Op, apply_ops, parse_ops

__all__ = [
    "AUTO_FRACTION",
    "CountOp",
    "apply_chain",
    "auto_vote_threshold",
    "parse_chain",
    "ridge",
    "uses_counts",
    "vote",
]

BoolArray = NDArray[np.bool_]

#: ``vote:auto`` keeps cells crossed by at least this fraction of the typical crest count.
AUTO_FRACTION = 0.25
#: ... and never fewer than this many arcs (a cell crossed by one arc is no evidence).
AUTO_MIN_VOTES = 2
#: The "typical crest count": this percentile of the per-column maximum counts.
AUTO_PERCENTILE = 90.0
#: Default ``ridge`` level (% of the column's largest count).
RIDGE_PERCENT = 50


@dataclass(frozen=True)
class CountOp:
    """``vote`` (arg = K, or ``None`` for ``vote:auto``) or ``ridge`` (arg = percent)."""

    name: str
    arg: int | None

    def __str__(self) -> str:
        if self.name == "vote":
            return f"vote:{'auto' if self.arg is None else self.arg}"
        return f"ridge:{self.arg}"


ChainOp = Op | CountOp


def _allowed() -> str:
    paper = ", ".join(f"{k}:N" if v else k for k, v in OPS.items())
    return f"{paper}, vote:K, vote:auto, ridge, ridge:P"


def _count_op(token: str) -> CountOp | None:
    name, sep, arg = token.partition(":")
    name, arg = name.strip().lower(), arg.strip().lower()
    if name == "vote":
        if not sep or not arg:
            raise ParameterError(
                "ops", f"{token!r}: vote needs K or auto, e.g. vote:3 or vote:auto"
            )
        if arg == "auto":
            return CountOp("vote", None)
        try:
            k = int(arg)
        except ValueError:
            raise ParameterError("ops", f"{token!r}: K must be an integer >= 1 or auto") from None
        if k < 1:
            raise ParameterError("ops", f"{token!r}: K must be >= 1, got {k}")
        return CountOp("vote", k)
    if name == "ridge":
        if not sep:
            return CountOp("ridge", RIDGE_PERCENT)
        try:
            p = int(arg)
        except ValueError:
            raise ParameterError("ops", f"{token!r}: P must be an integer percent 1..100") from None
        if not 1 <= p <= 100:
            raise ParameterError("ops", f"{token!r}: P must be in 1..100, got {p}")
        return CountOp("ridge", p)
    return None


def parse_chain(spec: str) -> list[ChainOp]:
    """Parse an ``--ops`` chain: the paper's operations plus ``vote`` and ``ridge``.

    Raises
    ------
    ValueError
        Naming the bad token and every allowed name.

    Examples
    --------
    >>> [str(op) for op in parse_chain("vote:auto, ridge, thinning:2")]
    ['vote:auto', 'ridge:50', 'thinning:2']
    """
    chain: list[ChainOp] = []
    if not spec.strip():
        return chain
    for raw in spec.split(","):
        token = raw.strip()
        op = _count_op(token)
        if op is not None:
            chain.append(op)
            continue
        try:
            chain.extend(parse_ops(token))
        except ParameterError as err:
            problem = err.problem
            if problem.startswith("unknown morphological operation"):
                problem = f"unknown morphological operation {token!r}; allowed: {_allowed()}"
            raise ParameterError("ops", problem) from None
    return chain


def uses_counts(chain: Sequence[ChainOp] | str) -> bool:
    """True when the chain holds a ``vote`` or ``ridge`` (so it is not the paper's)."""
    ops = parse_chain(chain) if isinstance(chain, str) else chain
    return any(isinstance(op, CountOp) for op in ops)


def auto_vote_threshold(counts: ArrayLike) -> int:
    """``K`` for ``vote:auto``, from the count map alone.

    ``K = max(2, ceil(0.25 * q90))`` where ``q90`` is the 90th percentile of the largest
    count in each column that any arc crosses: a quarter of the typical crest height.
    Cells on the surface are crossed by the arcs that reflected there; cells elsewhere
    only by arcs passing through, so the crest of each column stands well above a
    quarter of the typical crest while the sparse arc flanks do not.

    Examples
    --------
    >>> c = np.zeros((5, 4), dtype=np.uint16); c[2] = [8, 12, 10, 9]; c[0, 1] = 1
    >>> auto_vote_threshold(c)
    3
    """
    c = np.asarray(counts)
    if c.ndim != 2:
        raise ValueError(f"expected a 2-D count map, got shape {c.shape}")
    colmax = c.max(axis=0) if c.size else np.zeros(0)
    colmax = colmax[colmax > 0]
    if colmax.size == 0:
        return AUTO_MIN_VOTES
    q = float(np.percentile(colmax.astype(np.float64), AUTO_PERCENTILE))
    return max(AUTO_MIN_VOTES, math.ceil(AUTO_FRACTION * q - 1e-9))


def vote(mask: ArrayLike, counts: ArrayLike, k: int) -> BoolArray:
    """Keep the set cells of ``mask`` crossed by at least ``k`` arcs.

    Examples
    --------
    >>> vote(np.ones((1, 3), bool), np.array([[1, 2, 3]]), 2).tolist()
    [[False, True, True]]
    """
    m = np.asarray(mask, dtype=bool)
    c = np.asarray(counts)
    if m.shape != c.shape:
        raise ValueError("mask and counts must have one shape")
    return m & (c >= k)


def ridge(mask: ArrayLike, counts: ArrayLike, percent: int = RIDGE_PERCENT) -> BoolArray:
    """Keep, per column, the set cells with count >= ``percent`` % of the column's largest.

    Only the set cells of ``mask`` take part; a column with no set cell stays empty.

    Examples
    --------
    >>> c = np.array([[1, 4], [6, 4], [3, 1]])
    >>> ridge(np.ones((3, 2), bool), c).astype(int).tolist()
    [[0, 1], [1, 1], [1, 0]]
    """
    m = np.asarray(mask, dtype=bool)
    c = np.asarray(counts)
    if m.shape != c.shape:
        raise ValueError("mask and counts must have one shape")
    masked = np.where(m, c, 0).astype(np.float64)
    colmax = masked.max(axis=0, initial=0.0)
    return m & (masked * 100.0 >= percent * colmax[None, :]) & (colmax[None, :] > 0)


def apply_chain(counts: ArrayLike, chain: Sequence[ChainOp] | str) -> BoolArray:
    """Apply an ``--ops`` chain to a count map, starting from the binary map ``counts > 0``.

    Runs of the paper's operations go to :func:`sonarproc.morphology.apply_ops` unchanged,
    so a chain without ``vote``/``ridge`` gives exactly the paper's processed map.

    Examples
    --------
    >>> c = np.zeros((5, 5), dtype=np.uint16); c[1:4, 1:4] = 1; c[2, 2] = 5
    >>> int(apply_chain(c, "thinning:3").sum()), int(apply_chain(c, "vote:2").sum())
    (9, 1)
    """
    ops = parse_chain(chain) if isinstance(chain, str) else list(chain)
    c = np.asarray(counts)
    out = c > 0
    run: list[Op] = []
    for op in ops:
        if isinstance(op, Op):
            run.append(op)
            continue
        if run:
            out = apply_ops(out, run)
            run = []
        if op.name == "vote":
            k = auto_vote_threshold(c) if op.arg is None else op.arg
            out = vote(out, c, k)
        else:
            out = ridge(out, c, RIDGE_PERCENT if op.arg is None else op.arg)
    if run or not ops:
        out = apply_ops(out, run)
    return out

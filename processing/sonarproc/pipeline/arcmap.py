"""The paper's map: arcs drawn on the grid, then the ``ops`` chain.

:func:`build_arc_map` is what ``sonarproc run`` does between the grid and the fit, and
what the ``morphological`` and ``arc-vote`` methods do: the arcs (computed once, in
:func:`sonarproc.pipeline.selection.select_beams`) are rasterised as connected chains, or
paper-style as samples when ``params.arc_step`` is set, then the chain of morphological
and count operations (:mod:`sonarproc.morphology`) keeps the cells to fit.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarproc.arcs import ArcGeometry, rasterize
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import MethodMap
from sonarproc.pipeline.selection import Beams

__all__ = ["build_arc_map", "count_map"]

Stage = Callable[[str], None]


def count_map(arcs: ArcGeometry, grid: Grid, params: RunParams) -> npt.NDArray[np.uint32]:
    """Distinct arcs per cell, drawn the way ``params`` asks (chains, or samples)."""
    if params.arc_step is None:
        return rasterize(arcs, grid)
    return rasterize(arcs, grid, method="sampled", step=params.arc_step)


def build_arc_map(
    beams: Beams, grid: Grid, params: RunParams, stage: Stage | None = None
) -> MethodMap:
    """The arc count map of ``beams`` on ``grid`` and the cells the ``ops`` chain keeps.

    Parameters
    ----------
    beams : Beams
        The readings and their arcs.
    grid : Grid
        The map grid.
    params : RunParams
        ``arc_step`` (how arcs are drawn) and ``ops`` (the chain).
    stage : callable, optional
        Told ``"rasterise"`` and ``"morphology"`` as each starts.

    Returns
    -------
    MethodMap
        ``processed``: the kept cells; ``evidence``: the count map.
    """
    from sonarproc.morphology import apply_chain, parse_chain

    chain = parse_chain(params.ops)
    tell: Stage = stage or (lambda _name: None)
    tell("rasterise")
    counts: npt.NDArray[Any] = count_map(beams.arcs, grid, params)
    tell("morphology")
    return MethodMap(apply_chain(counts, chain), counts)

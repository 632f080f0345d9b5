"""The paper's method as a registry entry, and its count-vote variant.

``morphological`` is ``sonarproc run`` itself: the same builder
(:func:`sonarproc.pipeline.arcmap.build_arc_map`: arcs rasterised to a count map, the
``ops`` chain) through the same seam. ``arc-vote`` is the same pipeline with the
count-map chain ``vote:auto,ridge`` (:mod:`sonarproc.morphology`) instead of the paper's
binary operations.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import ClassVar

from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MapMethod, MethodMap, OptionValue
from sonarproc.morphology import parse_chain
from sonarproc.params import RunParams
from sonarproc.pipeline.arcmap import build_arc_map

__all__ = ["ArcVote", "Morphological"]


class Morphological(MapMethod):
    """Arc map + morphological operations (Baskent & Barshan 1999): ``sonarproc run``.

    Option ``ops``: the operation chain; empty (default) uses the run's ``--ops``.
    """

    name: ClassVar[str] = "morphological"
    summary: ClassVar[str] = "arcs rasterised, morphological --ops chain (the paper)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {"ops": ""}

    def validate(self) -> None:
        if self.options["ops"]:
            parse_chain(str(self.options["ops"]))

    def params_for(self, params: RunParams) -> RunParams:
        ops = str(self.options["ops"])
        return replace(params, ops=ops) if ops else params

    def build(self, beams: Beams, grid: Grid, params: RunParams) -> MethodMap:
        return build_arc_map(beams, grid, params)


class ArcVote(Morphological):
    """The arc count map's crest: ``--ops vote:auto,ridge`` (beyond the paper)."""

    name: ClassVar[str] = "arc-vote"
    summary: ClassVar[str] = "arcs rasterised, count vote and per-column ridge (vote:auto,ridge)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {"ops": "vote:auto,ridge"}

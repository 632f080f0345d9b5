"""The paper's method as a registry entry, and its count-vote variant.

``morphological`` is ``sonarproc run`` itself (:func:`sonarproc.pipeline.process`): arcs
rasterised to a count map, the ``--ops`` chain, the fit. ``arc-vote`` is the same
pipeline with the count-map chain ``vote:auto,ridge`` (:mod:`sonarproc.voting`) instead of
the paper's binary operations.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import replace
from typing import ClassVar

from sonarlog import SonarLog
from sonarproc.arcs import rasterize_arcs
from sonarproc.grid import Grid
from sonarproc.methods.base import Beams, MapMethod, MethodMap, MethodResult, OptionValue
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.voting import apply_chain, parse_chain

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
        counts = rasterize_arcs(*beams.arcs_args, **beams.beam_kwargs, grid=grid)
        return MethodMap(apply_chain(counts, parse_chain(params.ops)), counts)

    def run(self, log_: SonarLog, params: RunParams) -> MethodResult:
        cpu0 = time.process_time()
        result = process(log_, self.params_for(params), cpu_start=cpu0)
        return MethodResult(self.name, dict(self.options), result)


class ArcVote(Morphological):
    """The arc count map's crest: ``--ops vote:auto,ridge`` (beyond the paper)."""

    name: ClassVar[str] = "arc-vote"
    summary: ClassVar[str] = "arcs rasterised, count vote and per-column ridge (vote:auto,ridge)"
    defaults: ClassVar[Mapping[str, OptionValue]] = {"ops": "vote:auto,ridge"}

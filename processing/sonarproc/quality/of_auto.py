"""The truth-free quality of a ``run --auto`` result: the chosen candidate's map, refitted.

``--auto`` picks a candidate (a method, its setting, its fit) and may refit its profile
through the echo points. The quality figures judge the result the same way as any run
(:func:`sonarproc.quality.measure_quality`): the explained fraction from the result's
own curves; the held-out residual from the chosen candidate's map built and fitted
again without a tenth of the firings (its fit as scored, without the echo refit, which
itself chooses by held-out readings).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from sonarlog import SonarLog
from sonarproc.grid import Grid
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import MethodMap, Stage
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams
from sonarproc.quality.measure import Quality, measure_quality

if TYPE_CHECKING:
    from sonarproc.auto.score import AutoChoice, Score
    from sonarproc.methods import MethodResult
    from sonarproc.pipeline.run import Aligned

__all__ = ["measure_auto_quality", "run_auto_measured"]


def measure_auto_quality(
    log_: SonarLog, base: RunParams, chosen: Score, result: RunResult
) -> Quality:
    """The quality of ``result``, the run of the scored candidate ``chosen`` on ``log_``
    with base parameters ``base``."""
    from sonarproc.auto.select import candidate_map
    from sonarproc.auto.separation import profile_map

    cm = candidate_map(log_, base, chosen)
    candidate = chosen.candidate
    method = candidate.make()

    def build(beams: Beams, grid: Grid, _p: RunParams, _stage: Stage | None = None) -> MethodMap:
        mmap = method.build(beams, grid, method.params_for(base))
        if candidate.family != "surfaces":
            mmap, _ = profile_map(mmap, grid)
        return mmap

    return measure_quality(log_, cm.params, build, cm.beams, cm.grid, cm.mmap, result)


def run_auto_measured(
    log_: SonarLog, params: RunParams, aligned: Aligned | None = None
) -> tuple[MethodResult, Score, AutoChoice]:
    """``--auto`` as ``run`` does it: the poses aligned first where that helps (with
    ``params.align``; ``aligned``, the align stage the caller already ran on ``log_``, is
    used instead of running it again), the choice (:func:`sonarproc.auto.run_auto`), then
    the chosen run's ``alignment`` and ``quality`` filled in."""
    from sonarproc.auto import run_auto
    from sonarproc.pipeline.run import align_stage

    if aligned is None and params.align:
        aligned = align_stage(log_)
    if aligned is not None:
        log_ = aligned.log
    chosen_run, chosen, choice = run_auto(log_, params)
    chosen_run.run.alignment = None if aligned is None else aligned.record
    chosen_run.run.quality = measure_auto_quality(log_, params, chosen, chosen_run.run)
    return chosen_run, chosen, choice

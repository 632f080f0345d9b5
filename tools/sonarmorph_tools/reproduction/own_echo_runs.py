"""The runs behind the own-echo study: each scenario simulated with own echoes and with pairs.

:data:`PAPER_TIMING` holds the sensor counts and t_CPU the paper reports for its
random-sensor Figs. 10-12. :func:`run_own_echo` simulates each of those scenarios twice,
``pairs: own`` and ``pairs: all`` (:func:`simulate_variant`), over a few seeded draws of
the random array (:data:`DRAWS`), runs the paper's n and m on each log :data:`REPEATS`
times (t_CPU: the median) and keeps, per variant, a :class:`VariantRun`: the arcs, arc
cells, t_CPU and, on the shipped draw, e, f_c and E1. The section that compares them is
:mod:`sonarmorph_tools.reproduction.own_echo`.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from sonarmorph_tools.reproduction.outcome import Outcome
from sonarmorph_tools.reproduction.paper import PAPER
from sonarproc.params import RunParams
from sonarproc.pipeline import run_file

__all__ = [
    "DRAWS",
    "PAIRS",
    "PAPER_TIMING",
    "REPEATS",
    "PaperTiming",
    "VariantRun",
    "log_slope",
    "run_own_echo",
    "simulate_variant",
]

#: Array seeds of the draws (``None``: the scenario's own seed, the draw of every other table).
DRAWS: tuple[int | None, ...] = (None, 1, 2, 3)
#: Runs of each log; t_CPU is their median.
REPEATS = 3
#: The two variants: each sensor hears its own echo only, or every pair listens.
PAIRS = ("own", "all")


@dataclass(frozen=True)
class PaperTiming:
    """The paper's sensor count and t_CPU for one random-sensor figure, and where they are."""

    scenario: str
    figure: str
    sensors: int
    t_cpu_s: float
    where: str


#: Figs. 10-12: the sensor counts and t_CPU the paper reports (Sec. 3.3.3's figures).
PAPER_TIMING: tuple[PaperTiming, ...] = (
    PaperTiming("fig10b", "Fig. 11a", 100, 0.49,
                "Fig. 10 caption (b): \"using 100 sensors scattered and oriented randomly\"; "
                "Fig. 11 caption (a): n = 2 thinning of Fig. 10b, \"t_CPU = 0.49 sec\""),
    PaperTiming("fig10c", "Fig. 11b", 150, 0.73,
                "Fig. 10 caption (c): \"150 sensors are used\"; Fig. 11 caption (b): n = 5 "
                "thinning of Fig. 10c, \"t_CPU = 0.73 sec\""),
    PaperTiming("fig12", "Fig. 12c", 400, 0.51,
                "Fig. 12 caption (b): \"using 400 sensors scattered and oriented randomly\"; "
                "(c): n = 6 thinning, \"t_CPU = 0.51 sec\""),
)  # fmt: skip


@dataclass(frozen=True)
class VariantRun:
    """One scenario with one choice of listening pairs.

    ``outcome`` and ``map_cells`` are of the shipped draw; ``arcs``, ``arc_cells``,
    ``t_cpu_s`` and ``raster_s`` (wall time of drawing the arcs) are means over the draws
    (the times of each draw: the medians of its repeats).
    """

    scenario: str
    pairs: str
    sensors: int
    outcome: Outcome
    map_cells: int
    arcs: float
    arc_cells: float
    t_cpu_s: float
    raster_s: float = 0.0


def simulate_variant(scenario: Path, pairs: str, out: Path, *, seed: int | None = None) -> None:
    """Simulate a scenario YAML with ``pairs`` (``own`` or ``all``) into the log ``out``."""
    import yaml

    from sonarproc.simulate import write_result
    from sonarsim import simulate
    from sonarsim.scenario import scenario_from_dict

    data = yaml.safe_load(scenario.read_text(encoding="utf-8"))
    scn = scenario_from_dict(
        {**data, "pairs": pairs}, base_dir=scenario.parent, source=str(scenario), seed=seed
    )
    write_result(simulate(scn), out, robot=f"sonarsim:{scn.name}")


def log_slope(y0: float, y1: float, x0: float, x1: float) -> float | None:
    """The log-log slope ln(y1 / y0) / ln(x1 / x0); ``None`` where undefined.

    Examples
    --------
    >>> round(log_slope(0.49, 0.73, 100, 150), 3)
    0.983
    >>> round(log_slope(0.49, 0.73, 100**2, 150**2), 3)
    0.492
    """
    if min(y0, y1, x0, x1) <= 0 or x0 == x1:
        return None
    return math.log(y1 / y0) / math.log(x1 / x0)


def run_own_echo(
    scenario_dir: Path,
    tmp: Path,
    *,
    cell: float,
    draws: Sequence[int | None] = DRAWS,
    repeats: int = REPEATS,
    only: Sequence[str] | None = None,
    reports: Path | None = None,
) -> list[VariantRun]:
    """Both variants of every scenario of :data:`PAPER_TIMING` (or of those in ``only``).

    ``reports``: also write the report (maps, fit) of each variant's shipped draw to
    ``reports/SCENARIO-own`` and ``reports/SCENARIO-all``.
    """
    out: list[VariantRun] = []
    for timing in PAPER_TIMING:
        scenario = scenario_dir / f"{timing.scenario}.yaml"
        if (only and timing.scenario not in only) or not scenario.is_file():
            continue
        paper = PAPER[timing.scenario]
        params = RunParams(cell=cell, ops=paper.ops, order=paper.order)
        for pairs in PAIRS:
            arcs, arc_cells, times, raster = [], [], [], []
            outcome, map_cells = None, 0
            for seed in draws:
                logpath = tmp / f"{timing.scenario}-{pairs}-{seed}.h5"
                simulate_variant(scenario, pairs, logpath, seed=seed)
                runs = [run_file(logpath, params) for _ in range(repeats)]
                r = runs[0]
                arcs.append(r.counts["readings_used"])
                arc_cells.append(r.counts["arc_cells"])
                times.append(statistics.median(x.t_cpu_s for x in runs))
                raster.append(statistics.median(x.timings_s.get("rasterise", 0.0) for x in runs))
                if seed is None:
                    span = run_file(logpath, replace(params, span="points"))
                    outcome = replace(Outcome.of(r, span), t_cpu_s=times[-1])
                    map_cells = int(r.counts["map_cells_set"])
                    if reports is not None:
                        from sonarproc.report import write_report

                        write_report(r, reports / f"{timing.scenario}-{pairs}")
            if outcome is None:
                raise ValueError("draws must hold None, the scenario's own seed")
            out.append(
                VariantRun(
                    timing.scenario,
                    pairs,
                    timing.sensors,
                    outcome,
                    map_cells,
                    statistics.fmean(arcs),
                    statistics.fmean(arc_cells),
                    statistics.fmean(times),
                    statistics.fmean(raster),
                )
            )
    return out

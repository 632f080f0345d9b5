"""Run every study of ``docs/reproduction.md`` and return its text (:func:`reproduce`)."""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

from sonarmorph_tools.reproduction.discussion import DISCUSSION
from sonarmorph_tools.reproduction.document import render_markdown
from sonarmorph_tools.reproduction.figures import run_auto, run_paper
from sonarmorph_tools.reproduction.multi_surface import SCENARIOS as MULTI_SURFACE
from sonarmorph_tools.reproduction.multi_surface import run_multi_surface
from sonarmorph_tools.reproduction.outcome import AutoOutcome, Outcome, outcome_line
from sonarmorph_tools.reproduction.own_echo import run_own_echo
from sonarmorph_tools.reproduction.paper import ARC_STEPS_DEG, TABLES, PaperRow, paper_row
from sonarmorph_tools.reproduction.paper_tables import run_table
from sonarmorph_tools.reproduction.sampled import SampledRow, binary_cells, sampled_runs
from sonarproc.params import RunParams

__all__ = ["reproduce"]

log = logging.getLogger(__name__)


def reproduce(
    scenario_dir: Path,
    *,
    cell: float = 0.01,
    reports: Path | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    done: Callable[[str], None] | None = None,
    only: Sequence[str] | None = None,
    ring: bool = True,
) -> str:
    """Simulate and run every scenario; return the markdown.

    ``progress(name, k, total)`` hears which scenario or study starts; ``done(line)`` gets
    one human line per finished scenario (:func:`outcome_line`); ``only`` limits the run
    to the scenarios of those names (and then records no ring log); ``ring=False`` leaves
    the ring log out of the multi-surface table.
    """
    import yaml

    from sonarproc.simulate import simulate_to_log

    rows: list[tuple[str, PaperRow, Outcome, str]] = []
    autos: list[tuple[str, PaperRow, AutoOutcome]] = []
    tables: list[tuple[str, list[tuple[PaperRow, Outcome]]]] = []
    sampled: list[SampledRow] = []
    sampled_t1: list[SampledRow] = []
    with tempfile.TemporaryDirectory(prefix="sonarproc-reproduce-") as tmp_name:
        tmp = Path(tmp_name)
        # the multi-surface scenes have no curve y = f(x) to compare: their own table
        scenarios = [s for s in sorted(scenario_dir.glob("*.yaml")) if s.stem not in MULTI_SURFACE]
        if only:
            scenarios = [s for s in scenarios if s.stem in only]
        total = len(scenarios) + 2
        for k, scenario in enumerate(scenarios):
            name = scenario.stem
            if progress is not None:
                progress(name, k, total)
            paper = paper_row(name)
            desc = str((yaml.safe_load(scenario.read_text()) or {}).get("description", ""))
            logpath = tmp / f"{name}.h5"
            simulate_to_log(scenario, logpath)
            result, outcome = run_paper(logpath, paper, cell=cell)
            rows.append((name, paper, outcome, desc))
            params = RunParams(cell=cell, ops=paper.ops, order=paper.order)
            outs, cells = sampled_runs(logpath, params, ARC_STEPS_DEG)
            sampled.append(SampledRow(f"{name} ({paper.figure})", paper, Outcome.of(result),
                                      outs, (binary_cells(result), *cells)))  # fmt: skip
            log.debug("%s: %s", name, result.metrics)
            if done is not None:
                done(outcome_line(name, paper, Outcome.of(result)))
            auto, auto_outcome = run_auto(logpath, paper, cell=cell)
            autos.append((name, paper, auto_outcome))
            if reports is not None:
                from sonarproc.report import write_report

                write_report(result, reports / name)
                write_report(auto, reports / f"{name}-auto")
            if name in TABLES:
                title, study = TABLES[name]
                outcomes = run_table(logpath, study, cell=cell)
                tables.append((title, outcomes))
                if name == "fig02":
                    for p, o in outcomes:
                        params = RunParams(cell=cell, ops=p.ops, order=p.order)
                        outs, _cells = sampled_runs(logpath, params, ARC_STEPS_DEG)
                        sampled_t1.append(SampledRow(p.figure, p, o, outs))
        if progress is not None:
            progress("own echo", total - 2, total)
        own_echo = run_own_echo(scenario_dir, tmp, cell=cell, only=only, reports=reports)
        if progress is not None:
            progress("surfaces", total - 1, total)
        surfaces, echoes = run_multi_surface(
            scenario_dir, tmp, cell=cell, ring=ring and not only, only=only, reports=reports
        )
    return render_markdown(
        rows, tables, cell=cell, auto=autos, discussion=DISCUSSION, sampled=sampled,
        sampled_table1=sampled_t1, own_echo=own_echo, surfaces=surfaces,
        surface_echoes=echoes,
    )  # fmt: skip

"""Where ``--auto`` stands: its error against every candidate's, judged by the truth.

For one log, :func:`auto_row` runs ``--auto`` (which never sees the truth) and every
candidate of :data:`sonarproc.auto.CANDIDATES` at every setting it tries, and reports
E1 (by the truth) of auto's pick and of the best candidate. The table of
``docs/methods.md`` (:mod:`sonarproc.studies.methods_table`) and a test use it.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from sonarlog import SonarLog
from sonarproc.auto import CANDIDATES, run_auto
from sonarproc.auto.candidates import spline_lambda
from sonarproc.errors import NothingToMapError
from sonarproc.metrics import bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline.mapping import evaluate_map
from sonarproc.pipeline.selection import plan_grid, select_beams

__all__ = ["auto_row", "candidate_errors"]


def candidate_errors(log_: SonarLog, base: RunParams) -> dict[str, float]:
    """E1 (m, by the truth) of every candidate at every setting: ``{"name@setting": E1}``."""
    beams, counts = select_beams(log_, base)
    grid = plan_grid(log_, base, beams)
    out: dict[str, float] = {}
    built: dict[str, Any] = {}
    for c in CANDIDATES:
        method = c.make()
        key = f"{c.method}{sorted(c.options.items())}"
        if key not in built:
            try:
                built[key] = method.build(beams, grid, method.params_for(base))
            except (NothingToMapError, ValueError):
                built[key] = None
        mmap = built[key]
        if mmap is None or not mmap.processed.any():
            continue
        ix, iy = np.nonzero(mmap.processed.T)
        bins = bin_stats(ix, grid.to_world(iy, ix)[1], grid.centres_x(), presorted=True)
        mc = float(bins.count[bins.count > 0].mean())
        for setting in c.settings:
            lam = spline_lambda(setting, mc, grid.cell)
            params = method.params_for(c.params(base, setting, lam=lam))
            r = evaluate_map(
                log_, params, grid, mmap, robot_xy=beams.robot_xy, counts=counts,
                cpu_start=time.process_time(),
            )  # fmt: skip
            e1 = r.metrics.E1_m
            out[f"{c.name}@{setting:g}"] = np.inf if e1 is None else float(e1)
    return out


def auto_row(log_: SonarLog, base: RunParams | None = None) -> dict[str, Any]:
    """Auto's pick and E1, the best candidate's, their ratio, and auto's run time."""
    base = base or RunParams()
    t0 = time.perf_counter()
    res, chosen, choice = run_auto(log_, base)
    wall = time.perf_counter() - t0
    errors = candidate_errors(log_, replace(base))
    best = min(errors, key=lambda k: errors[k])
    e1 = res.run.metrics.E1_m
    auto_e1 = np.inf if e1 is None else float(e1)
    return {
        "choice": f"{chosen.candidate.name}@{chosen.setting:g}",
        "auto_E1_m": auto_e1,
        "residual_m": chosen.residual_m,
        "best": best,
        "best_E1_m": errors[best],
        "ratio": auto_e1 / errors[best] if errors[best] > 0 else np.inf,
        "auto_s": wall,
        "errors": errors,
        "record": choice.to_json(chosen),
    }

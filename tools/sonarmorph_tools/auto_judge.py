"""Where ``--auto`` stands: its error against every candidate's, judged by the truth.

For one log, :func:`auto_row` runs ``--auto`` (which never sees the truth) and every
candidate of :data:`sonarproc.auto.CANDIDATES` at every setting it tries, and reports
the error (by the truth) of auto's pick and of the best candidate. The error is the
paper's E1 (columns with points) where the truth is one profile ``y(x)``, and the
surfaces metric ``precision_m`` (mean distance of the fitted curves to the truth,
:func:`sonarproc.surfaces.surface_metrics`) where it is several surfaces (a room, a
corridor): E1 means nothing there. The table of ``docs/methods.md``
(:mod:`sonarmorph_tools.methods_table`) and a test use it.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from sonarlog import SonarLog
from sonarproc.auto import CANDIDATES, run_auto
from sonarproc.auto.candidates import spline_lambda
from sonarproc.errors import NothingToMapError
from sonarproc.fit import FitFailure
from sonarproc.metrics import bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.pipeline.mapping import evaluate_map
from sonarproc.pipeline.result import RunResult
from sonarproc.pipeline.selection import Beams, plan_grid, select_beams
from sonarproc.surfaces import seen_truth, surface_metrics, truth_points

__all__ = ["Judge", "auto_row", "candidate_errors", "candidate_runs", "simulated_scenarios"]


class Judge:
    """The truth's verdict on a run: E1 for a profile, ``precision_m`` for several surfaces."""

    def __init__(self, log_: SonarLog, beams: Beams) -> None:
        truth = None if log_.truth is None else np.asarray(log_.truth, dtype=np.float64)
        self.truth = truth
        self.metric = "E1_m" if truth is None or not np.isnan(truth).any() else "precision_m"
        self.seen: npt.NDArray[np.bool_] | None = None
        if self.metric == "precision_m" and truth is not None:
            tp = beams.poses
            pts = np.concatenate(truth_points(truth))
            self.seen = seen_truth(
                pts, tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, beams.path,
                tx_half_beamwidth=tp.tx_half_beamwidth, rx_half_beamwidth=tp.rx_half_beamwidth,
            )  # fmt: skip

    def error(self, r: RunResult) -> tuple[float, float | None]:
        """The run's error (m; inf where undefined) and, for surfaces, its completeness."""
        if self.metric == "E1_m":
            e1 = r.metrics.E1_m
            return (np.inf if e1 is None else float(e1)), None
        if r.surfaces is not None and r.surfaces.surfaces:
            lines = r.surfaces.polylines()
        elif not isinstance(r.fit, FitFailure):
            lines = [r.fit.sample(r.grid.cell)]
        else:
            return np.inf, None
        assert self.truth is not None
        m = surface_metrics(lines, self.truth, seen=self.seen)
        p = np.inf if m.precision_m is None else float(m.precision_m)
        return p, m.completeness


def candidate_runs(log_: SonarLog, base: RunParams) -> dict[str, RunResult]:
    """Every candidate at every setting run on every reading: ``{"name@setting": run}``.

    A ``surfaces`` setting whose map is one function of x is left out (the y(x)
    candidates cover it); so is a method that leaves nothing on the map.
    """
    beams, counts = select_beams(log_, base)
    grid = plan_grid(log_, base, beams)
    out: dict[str, RunResult] = {}
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
                cpu_start=time.process_time(), beams=beams,
            )  # fmt: skip
            if c.family == "surfaces" and (r.surfaces is None or not r.surfaces.surfaces):
                continue  # one function of x: the y(x) candidates cover it
            out[f"{c.name}@{setting:g}"] = r
    return out


def candidate_errors(
    log_: SonarLog, base: RunParams, runs: dict[str, RunResult] | None = None
) -> dict[str, float]:
    """The error (m, by the truth) of every candidate at every setting: ``{"name@setting": e}``.

    ``runs``: :func:`candidate_runs` of the same log, if already made.
    """
    if runs is None:
        runs = candidate_runs(log_, base)
    judge = Judge(log_, select_beams(log_, base)[0])
    return {k: judge.error(r)[0] for k, r in runs.items()}


def auto_row(log_: SonarLog, base: RunParams | None = None) -> dict[str, Any]:
    """Auto's pick and error, the best candidate's, their ratio, and auto's run time."""
    base = base or RunParams()
    t0 = time.perf_counter()
    res, chosen, choice = run_auto(log_, base)
    wall = time.perf_counter() - t0
    runs = candidate_runs(log_, base)
    errors = candidate_errors(log_, base, runs)
    beams, _ = select_beams(log_, base)
    judge = Judge(log_, beams)
    best = min(errors, key=lambda k: errors[k])
    auto_e, completeness = judge.error(res.run)
    setting = "" if chosen.candidate.family == "surfaces" else f"@{chosen.setting:g}"
    return {
        "choice": f"{chosen.candidate.name}{setting}",
        "metric": judge.metric,
        "auto_error_m": auto_e,
        "auto_completeness": completeness,
        "residual_m": chosen.residual_m,
        "best": best.removesuffix("@0") if best.startswith("surfaces@") else best,
        "best_error_m": errors[best],
        # the columns each profile is judged on (E1 over its own columns with points)
        "auto_columns": _judged_columns(res.run),
        "best_columns": _judged_columns(runs[best]),
        "ratio": auto_e / errors[best] if errors[best] > 0 else np.inf,
        "auto_s": wall,
        "errors": errors,
        "record": choice.to_json(chosen),
    }


def _judged_columns(r: RunResult) -> int | None:
    """The columns a profile's E1 is judged on (those with points); None for surfaces."""
    if r.surfaces is not None and r.surfaces.surfaces:
        return None
    occ = np.flatnonzero(r.bins.occupied)
    return int(occ[-1] - occ[0] + 1) if occ.size else 0


def simulated_scenarios(
    *scenario_dirs: Path, only: Collection[str] | None = None
) -> Iterator[tuple[str, SonarLog]]:
    """Simulate each scenario YAML of ``scenario_dirs`` (sorted by name) and yield its log.

    ``only``: the names (file stems) to simulate, if not all. The logs are written to a
    temporary folder that is removed when the iteration ends.
    """
    from sonarproc.simulate import simulate_to_log

    ymls = sorted((y for d in scenario_dirs for y in d.glob("*.yaml")), key=lambda y: y.stem)
    if only is not None:
        ymls = [y for y in ymls if y.stem in only]
    with tempfile.TemporaryDirectory() as tmp:
        for yml in ymls:
            path = Path(tmp) / f"{yml.stem}.h5"
            simulate_to_log(yml, path)
            yield yml.stem, load_log(path)

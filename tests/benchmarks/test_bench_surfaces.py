"""Benchmark: the surface stage (ridge, extraction, fits) against the whole run.

The log is the one of :mod:`test_bench_run`: an hour of a 16-sonar ring wandering in a
20 m x 20 m room, 90 000 readings, mapped at 1 cm (2000 x 2000 cells). The whole run is
``sonarproc.pipeline.process`` on it (in this process, best of three); the surface
stage is :func:`sonarproc.surfaces.ridge_nms` on the processed map then
:func:`sonarproc.surfaces.find_surfaces`, timed on the same map. Target: extraction +
fits add at most 20 % to the whole run. Also prints the metrics time (seen truth), and
the ratio the target speaks of with default options: ``process`` with ``fit = "auto"``
(ridge, extraction, fits, echo refits) over ``process`` with ``fit = "poly"``, and the
same for the whole ``sonarproc run`` a user types (a fresh process each: imports, reading
the log, the run and the report directory; best of five, on the log without truth, with
the modules' bytecode cached as in an installed package).
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from benchroom import ROOM, RUN, run_child, write_room_log

from sonarlog import read_log
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.surfaces import find_surfaces, ridge_nms, seen_truth, surface_metrics, truth_points

TARGET = 0.20

# the room log of the whole-run benchmark (a sibling test module: load it by path)


def _best(fn, repeat: int = 3) -> tuple[float, object]:  # type: ignore[no-untyped-def]
    out = None
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _installed_env(tmp: Path) -> dict[str, str]:
    """The environment of a user's install: modules' bytecode cached (pip compiles it).

    Without a cache every run compiles every module it imports, and the surface modules
    a default run imports would count their compilation at every run.
    """
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
    return env


def _cli_runs(log: Path, tmp: Path, fits: tuple[str, ...], repeat: int = 5) -> dict[str, float]:
    """Best wall seconds of ``sonarproc run LOG --fit FIT`` per fit, runs interleaved.

    One untimed run of each fills the bytecode cache; the timed runs alternate between
    the fits, so that the machine's drift falls on all alike.
    """
    env = _installed_env(tmp)
    best = {fit: float("inf") for fit in fits}
    for k in range(repeat + 1):
        for fit in fits:
            out = tmp / fit
            out.mkdir(parents=True, exist_ok=True)
            args = ["-c", RUN, "run", str(log), "--out", str(out), "--cell", "0.01",
                    "--bbox", f"0,{ROOM:g},0,{ROOM:g}", "--fit", fit, "--json"]  # fmt: skip
            wall, _, _, _ = run_child(args, out, env)
            if k:
                best[fit] = min(best[fit], wall)
    return best


@pytest.mark.benchmark
def test_bench_whole_cli_run(tmp_path: Path) -> None:
    log = tmp_path / "hour-no-truth.h5"
    write_room_log(log, 1.0, truth=False)
    best = _cli_runs(log, tmp_path, ("poly", "auto"))
    poly, auto = best["poly"], best["auto"]
    print(
        f"\nsonarproc run (fresh process, bytecode cached, no truth): fit poly {poly:.2f} s, "
        f"default (fit auto) {auto:.2f} s"
        f"\n  surfaces add {(auto - poly) / poly:.2f} of the whole run (target <= {TARGET:.2f})"
    )


@pytest.mark.benchmark
def test_bench_surface_stage(tmp_path: Path) -> None:
    path = tmp_path / "hour.h5"
    n = write_room_log(path, 1.0)
    lg = read_log(path)
    params = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM), ops="vote:2", fit="polar")
    defaults = RunParams(cell=0.01, bbox=(0.0, ROOM, 0.0, ROOM))
    blind = replace(lg, truth=None)  # a robot's log: no truth, so no surface metrics
    t_poly, _ = _best(lambda: process(blind, replace(defaults, fit="poly")), 1)
    t_auto, _ = _best(lambda: process(blind, replace(defaults, fit="auto")), 1)
    print(
        f"\ndefault options, no truth: fit auto {t_auto:.2f} s, fit poly {t_poly:.2f} s: "
        f"surfaces add {(t_auto - t_poly) / t_poly:.2f} of process() (a diagnostic: the "
        f"target, <= {TARGET:.2f}, is on the whole sonarproc run)"
    )
    whole, res = _best(lambda: process(lg, params))
    assert res is not None
    counts, processed, grid = res.counts_map, res.processed, res.grid  # type: ignore[attr-defined]
    t_ridge, thin = _best(lambda: ridge_nms(processed, counts))
    t_find, found = _best(lambda: find_surfaces(thin, grid, counts))
    tp = lg.transducer_poses(lg.readings[np.isfinite(lg.readings["tof"])])
    r = lg.readings[np.isfinite(lg.readings["tof"])]
    pts = np.concatenate(truth_points(lg.truth))
    t0 = time.perf_counter()
    seen = seen_truth(pts, tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, lg.path_lengths(r),
                      tx_half_beamwidth=tp.tx_half_beamwidth,
                      rx_half_beamwidth=tp.rx_half_beamwidth)  # fmt: skip
    m = surface_metrics(found.polylines(), lg.truth, seen=seen)  # type: ignore[attr-defined]
    t_metrics = time.perf_counter() - t0
    stage = t_ridge + t_find
    print(
        f"\nsurfaces: {n} readings, {grid.nx} x {grid.ny} cells, "  # type: ignore[attr-defined]
        f"{int(processed.sum())} kept cells, {len(found.surfaces)} surfaces"
    )  # type: ignore[attr-defined]
    print(f"  whole run (process, vote:2, polar fit) {whole:.2f} s")
    print(
        f"  ridge {t_ridge:.3f} s + find_surfaces {t_find:.3f} s = {stage:.3f} s: "
        f"ratio to the whole run {stage / whole:.3f} (a diagnostic of the map-only stage: "
        "on long logs the run finds the walls from the readings first)"
    )
    print(
        f"  metrics (seen truth over {pts.shape[0]} truth points + precision/completeness) "
        f"{t_metrics:.2f} s: precision {m.precision_m} m, completeness {m.completeness}"
    )

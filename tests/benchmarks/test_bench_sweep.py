"""Benchmark: parameter-sweep throughput, one worker and two, against today's per-run path.

A fixed small grid (3 thinning depths x 3 orders x 4 seeds = 36 runs) on the fig12
scenario (400 random sensors, about 10 000 readings per seed). Three figures, each the
best of two cold runs (no log or map cached from an earlier one):

- the floor, the per-run path the sweep had before it shared work: each seed simulated
  once, then every combination a whole ``sonarproc run`` of its own (selection, grid,
  arcs, morphology, fit), in this process;
- one worker: :func:`sonarproc.sweep.run_sweep` in this process, the count map of each
  seed built once and shared by its nine combinations;
- two workers: the same on a local pool of two processes (their start-up included).

The ratios: one worker over the floor (the sharing), two workers over one (2.0 is the
ceiling on two cores; start-up, the pool's hand-over and other load on the machine take
some of it). The three tables must agree. With Dask installed, a two-worker
``LocalCluster`` figure is printed too (its start-up, a few seconds, included).
"""

from __future__ import annotations

import importlib.util
import os
import time
from pathlib import Path
from typing import Any

import pytest

from sonarproc.engines import Engine
from sonarproc.sweep import combinations, parse_grid, run_sweep
from sonarproc.sweep.runner import _load, _row
from sonarproc.sweep.shared import clear_shared

SCENARIO = Path(__file__).resolve().parents[2] / "configs" / "scenarios" / "fig12.yaml"
GRID = "seed=0..3;ops=thinning:2|thinning:4|thinning:6;order=6|8|10"

Rows = list[dict[str, Any]]


def _per_run_path() -> Rows:
    """The sweep's rows the way it made them before sharing: a whole run per combination."""
    combos = combinations([str(SCENARIO)], parse_grid(GRID))
    rows: Rows = []
    loaded: tuple[Any, Any] = (None, None)
    for c in combos:
        if loaded[0] != c.values["seed"]:
            loaded = (c.values["seed"], _load(c.input, {"seed": c.values["seed"]}))
        rows.append(_row(c, loaded[1], None))
    return rows


def _sweep(workers: int, engine: Engine) -> Rows:
    return run_sweep([str(SCENARIO)], GRID, jobs=workers, engine=engine).rows


def _best_rate(run: Any, *args: Any) -> tuple[float, float, Rows]:
    """Best of two cold runs: runs per wall second, runs per CPU second of this process
    (meaningful for the in-process runs only: a pool's work is in its workers), rows."""
    best = best_cpu = 0.0
    rows: Rows = []
    for _ in range(2):
        clear_shared()
        t0, c0 = time.perf_counter(), time.process_time()
        rows = run(*args)
        best = max(best, len(rows) / (time.perf_counter() - t0))
        best_cpu = max(best_cpu, len(rows) / max(time.process_time() - c0, 1e-9))
    clear_shared()
    return best, best_cpu, rows


def _strip(rows: Rows) -> Rows:
    return [{k: v for k, v in r.items() if k != "t_cpu_s"} for r in rows]


@pytest.mark.benchmark
def test_bench_sweep_workers() -> None:
    load0 = os.getloadavg()[0]
    floor, floor_cpu, rows0 = _best_rate(_per_run_path)
    one, one_cpu, rows1 = _best_rate(_sweep, 1, Engine("local"))
    two, _, rows2 = _best_rate(_sweep, 2, Engine("local"))
    assert _strip(rows0) == _strip(rows1) == _strip(rows2)
    print(
        f"\nsweep throughput on {len(rows1)} runs (fig12, cpus={os.cpu_count()}): "
        f"per-run path {floor:.2f} runs/s, 1 worker {one:.2f} runs/s "
        f"(ratio {one / floor:.2f}x, target >= 2; per CPU second {floor_cpu:.2f} -> "
        f"{one_cpu:.2f} runs, {one_cpu / floor_cpu:.2f}x), 2 workers {two:.2f} runs/s "
        f"(ratio {two / one:.2f}x over 1 worker, target >= 1.7) "
        f"(load average {load0:.1f} before, {os.getloadavg()[0]:.1f} after)"
    )
    if importlib.util.find_spec("distributed") is not None:
        dask2, _, rows3 = _best_rate(_sweep, 2, Engine("dask"))
        assert _strip(rows3) == _strip(rows1)
        print(
            f"sweep on a 2-worker dask LocalCluster (start-up included): {dask2:.2f} runs/s "
            f"(ratio {dask2 / one:.2f}x over 1 local worker)"
        )

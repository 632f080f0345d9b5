"""Benchmark: parameter-sweep throughput with ``--jobs 1`` against ``--jobs 2``.

A fixed small grid (3 thinning depths x 3 orders x 4 seeds = 36 runs) on the fig12
scenario (400 random sensors, about 10 000 readings per seed, each seed simulated once
per task). Each figure is the best of two runs of :func:`sonarproc.sweep.run_sweep`;
the ratio is combinations per second with two jobs over one job (2.0 is the ceiling on
two cores; worker start-up and uneven tasks take some of it). The two tables must agree.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from sonarproc.sweep import run_sweep

SCENARIO = Path(__file__).resolve().parents[2] / "configs" / "scenarios" / "fig12.yaml"
GRID = "seed=0..3;ops=thinning:2|thinning:4|thinning:6;order=6|8|10"


def _best_rate(jobs: int) -> tuple[float, list[dict[str, object]]]:
    best = 0.0
    rows: list[dict[str, object]] = []
    for _ in range(2):
        result = run_sweep([str(SCENARIO)], GRID, jobs=jobs)
        best = max(best, len(result.rows) / result.wall_s)
        rows = result.rows
    return best, rows


@pytest.mark.benchmark
def test_bench_sweep_jobs() -> None:
    one, rows1 = _best_rate(1)
    two, rows2 = _best_rate(2)

    def strip(rows: list[dict[str, object]]) -> list[dict[str, object]]:
        return [{k: v for k, v in r.items() if k != "t_cpu_s"} for r in rows]

    assert strip(rows1) == strip(rows2)
    print(
        f"\nsweep throughput on {len(rows1)} runs (fig12, cpus={os.cpu_count()}): "
        f"--jobs 1 {one:.2f} runs/s, --jobs 2 {two:.2f} runs/s, ratio {two / one:.2f}x "
        f"(load average {os.getloadavg()[0]:.1f})"
    )

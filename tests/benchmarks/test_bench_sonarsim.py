"""Benchmark: the Fig. 12 scenario with every sensor pair bistatic (goal: < 5 s, one core).

Prints the simulation time and its ratio to a floor measured in the same run: one
vectorised numpy pass (an add) over the same number of pair x segment elements, which is
the least any per-pair, per-segment search must touch.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from sonarsim import load_scenario, simulate

ROOT = Path(__file__).resolve().parents[2]


def _best(fn: object, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()  # type: ignore[operator]
        best = min(best, time.perf_counter() - t0)
    return float(best)


@pytest.mark.benchmark
def test_bench_fig12_all_pairs() -> None:
    scn = load_scenario(ROOT / "configs/scenarios/fig12.yaml")
    assert scn.pairs == "all"
    n = len(scn.array)
    n_seg = len(scn.world.segments)
    pairs = n * n
    result = simulate(scn)
    t_sim = _best(lambda: simulate(scn))

    rng = np.random.default_rng(0)
    per_sensor = rng.random((n, n_seg))
    out = np.empty((n, n_seg))

    def floor() -> None:
        for t in range(n):  # one add per (pair, segment) element
            np.add(per_sensor[t], per_sensor, out=out)

    t_floor = _best(floor)
    print(
        f"\nsonarsim fig12 all pairs: {pairs} pairs x {n_seg} segments "
        f"({pairs * n_seg / 1e6:.0f} M elements), {result.readings.size} echoes: "
        f"{t_sim:.3f} s (goal < 5 s); floor (one numpy add per element) {t_floor:.3f} s; "
        f"ratio {t_sim / t_floor:.1f}x"
    )

"""Benchmark: the first-echo model on a profile, each reading's window against the whole curve.

``--auto`` predicts every held-out reading's path from fitted profiles, and its echo refit
searches every reading's echo point on them, with
:func:`sonarproc.methods.echo_model.first_echo`. On a profile y(x) each reading looks only
at the samples within its beams' x range; the baseline, measured in the same run (best of
five), is the same curve in the other order (x decreasing), which is searched whole. The
inputs are a bistatic log's sizes: 6000 readings of random pairs 0-1.5 m below a 7 m wave
sampled every 1 cm, beams 50-130 degrees, 25 degrees each side.
"""

from __future__ import annotations

import numpy as np
import pytest
from benchtiming import best_of

from sonarproc.methods.echo_model import first_echo


@pytest.mark.benchmark
def test_bench_first_echo_windows() -> None:
    rng = np.random.default_rng(0)
    xs = np.arange(0.0, 7.0, 0.01)
    curve = np.column_stack((xs, 2.0 + 0.1 * np.sin(2 * np.pi * xs / 1.5)))
    n = 6000
    t = np.column_stack((rng.uniform(0.0, 7.0, n), rng.uniform(0.0, 1.5, n)))
    r = t + np.column_stack((rng.uniform(-0.5, 0.5, n), rng.uniform(-0.1, 0.1, n)))
    ht = rng.uniform(np.radians(50), np.radians(130), n)
    hr = ht + rng.uniform(-0.2, 0.2, n)
    half = np.full(n, np.radians(25.0))

    def windowed() -> object:
        return first_echo(t, ht, half, r, hr, half, curve)

    def whole() -> object:
        return first_echo(t, ht, half, r, hr, half, curve[::-1])

    path, _ = first_echo(t, ht, half, r, hr, half, curve)
    ref, _ = first_echo(t, ht, half, r, hr, half, curve[::-1])
    assert np.array_equal(np.isnan(path), np.isnan(ref))
    t_win, t_whole = best_of(windowed), best_of(whole)
    print(
        f"\nfirst_echo, {n} bistatic readings x {xs.size} profile samples: windows "
        f"{t_win:.3f} s, whole curve {t_whole:.3f} s, ratio {t_win / t_whole:.2f}"
    )

"""Benchmark: the surfaces' dense GCV smoothing spline against scipy's (the floor).

A curved surface's spline is fitted to its cells averaged in bins of arc length, at most
:data:`~sonarproc.surfaces.fitting.models.MAX_SPLINE_BINS` of them, two series (x and y)
per surface. Timed: :func:`sonarproc.fit.smoothing_spline` on both series at once against
:func:`scipy.interpolate.make_smoothing_spline` on each, both choosing the smoothing by
generalised cross-validation, at 20 and at 64 bins (best of seven, in the same run). The
kernel stays only while the ratio (ours over scipy's) is at most 0.5; the largest
distance between the two splines is printed too.
"""

from __future__ import annotations

import numpy as np
import pytest
from benchtiming import best_of
from scipy.interpolate import make_smoothing_spline

from sonarproc.fit import smoothing_spline
from sonarproc.surfaces.fitting.models import MAX_SPLINE_BINS


@pytest.mark.benchmark
def test_bench_surface_splines_against_scipy() -> None:
    rng = np.random.default_rng(0)
    print("\nsurface splines (x(s), y(s)), GCV smoothing:")
    for n in (20, MAX_SPLINE_BINS):
        s = np.linspace(0.0, 3.0, n) + rng.uniform(0.0, 0.01, n)
        x = np.cos(s) + rng.normal(0.0, 0.01, n)
        y = np.sin(2.0 * s) + rng.normal(0.0, 0.01, n)
        w = rng.integers(1, 9, n).astype(np.float64)
        both = np.stack((x, y), axis=1)
        ours = best_of(lambda b=both, s=s, w=w: smoothing_spline(s, b, w), repeat=7)
        theirs = best_of(
            lambda s=s, x=x, y=y, w=w: [make_smoothing_spline(s, v, w=w) for v in (x, y)],
            repeat=7,
        )
        fine = np.linspace(s[0], s[-1], 400)
        got = smoothing_spline(s, both, w)(fine)
        want = np.column_stack([make_smoothing_spline(s, v, w=w)(fine) for v in (x, y)])
        gap = float(np.hypot(*(got - want).T).max())
        print(f"  {n} bins: ours {ours * 1e3:.2f} ms, scipy {theirs * 1e3:.2f} ms "
              f"(ratio {ours / theirs:.3f}); splines at most {gap * 1e3:.2f} mm apart")  # fmt: skip
        assert gap < 0.005

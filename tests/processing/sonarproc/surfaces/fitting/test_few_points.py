"""A few echo points: a model with more parameters than the line must earn them.

With fewer echo points than it takes to measure their own scatter, the floor of the model
criterion is the range noise the caller states (the refinement's range tolerance as an
RMS). A handful of noisy echo points of a straight wall then give a line, not an arc
threading their noise; a handful on a pillar, bent far beyond the noise, still give an
arc.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sonarproc.surfaces.echoes.openings import STRAIGHT_SHARE
from sonarproc.surfaces.extraction.extract import SurfaceCells
from sonarproc.surfaces.fitting.batch import MIN_SCATTER_POINTS, fit_surfaces
from sonarproc.surfaces.fitting.models import SurfaceFit

CELL = 0.01
MARGIN = 0.03  # the last refinement round's range tolerance (m)
NOISE = STRAIGHT_SHARE * MARGIN
RANGE_SIGMA = 0.01  # range noise (m)
QUANTUM = 0.0254  # the range quantum (m): an inch


def _points(x: np.ndarray, y: np.ndarray) -> SurfaceCells:
    s = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    return SurfaceCells(x, y, s, np.ones_like(x), False)


def _wall_points(n: int, seed: int) -> SurfaceCells:
    """``n`` echo points of the wall y = 2 from sensors on y = 0 over 0.6 m, their
    ranges with 1 cm of noise, quantised to an inch."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 0.6, n)
    r = 2.0 + rng.normal(0.0, RANGE_SIGMA, n)
    return _points(x, np.round(r / QUANTUM) * QUANTUM)


@pytest.mark.parametrize("n", range(5, MIN_SCATTER_POINTS))
def test_a_few_noisy_echo_points_of_a_straight_wall_give_a_line(n: int) -> None:
    """5-9 points, 20 seeds each: the line, every time, within the noise of y = 2."""
    groups = [_wall_points(n, seed) for seed in range(20)]
    fits = fit_surfaces(groups, cell=CELL, scatter=NOISE)
    assert [f.model if isinstance(f, SurfaceFit) else "failed" for f in fits] == ["line"] * 20
    for f in fits:
        assert isinstance(f, SurfaceFit)
        assert np.abs(f.polyline[:, 1] - 2.0).max() < 0.06


def test_a_few_echo_points_round_a_pillar_still_give_an_arc() -> None:
    """8 points over a quarter of a 0.3 m pillar (sagitta 4 cm, beyond the noise): an arc
    of its radius."""
    phi = np.linspace(0.0, math.pi / 2, 8)
    rng = np.random.default_rng(0)
    r = 0.3 + rng.normal(0.0, 0.003, 8)
    (fit,) = fit_surfaces([_points(r * np.cos(phi), r * np.sin(phi))], cell=CELL, scatter=NOISE)
    assert isinstance(fit, SurfaceFit) and fit.model == "arc"
    assert fit.params["radius"] == pytest.approx(0.3, abs=0.01)

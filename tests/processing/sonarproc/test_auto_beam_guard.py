"""``--auto``'s beam-range guard: a fit may not lie where the sound would have echoed first."""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.auto import CANDIDATES, Score
from sonarproc.auto.beam_guard import (
    GUARD_LENGTH_CELLS,
    beam_contradictions,
    first_echoes,
    fit_guard_excess,
)
from sonarproc.fit import PolyFit, SplineFit, fit_spline
from sonarproc.methods.testing import beams_facing
from sonarproc.pipeline.selection import Beams

CELL = 0.01


def _wall_beams(seed: int = 0, n: int = 80) -> Beams:
    """``n`` monostatic sensors below the wall y = 1.5 m (x in [0, 4] m), each firing
    once, looking up within 0.3 rad of the normal; 3 mm range noise."""
    rng = np.random.default_rng(seed)
    xs = np.linspace(-3.0, 7.0, 10001)
    wall = np.column_stack((xs, np.full_like(xs, 1.5)))
    at = np.column_stack((rng.uniform(0.0, 4.0, n), rng.uniform(0.0, 0.5, n)))
    beams, _ = beams_facing(at, np.pi / 2 + rng.uniform(-0.3, 0.3, n), wall)
    beams.path[:] += 2 * rng.normal(0.0, 0.003, beams.path.size)
    beams.readings["t"] = np.arange(beams.path.size)
    return beams


def _bulge(x: np.ndarray, depth: float) -> np.ndarray:
    """The wall, ``depth`` (m) nearer the sensors over x in [1.2, 2.8] m."""
    return 1.5 - depth * np.exp(-(((x - 2.0) / 0.5) ** 8))


def _profile(depth: float) -> SplineFit:
    x = np.linspace(0.0, 4.0, 401)
    fit = fit_spline(x, _bulge(x, depth), np.ones(x.size), lam=1e-9)
    assert isinstance(fit, SplineFit)
    return fit


def test_a_fit_in_front_of_the_wall_the_readings_saw_beyond_is_contradicted() -> None:
    beams = _wall_beams()
    wall = PolyFit(0, np.array([1.5]), (0.0, 4.0))
    assert fit_guard_excess(wall, beams, CELL) == 0.0
    # 10 cm in front over 1.6 m: the readings there would have heard it first
    front = fit_guard_excess(_profile(0.10), beams, CELL)
    assert 0.5 < front < 1.8
    # 10 cm behind the wall: the sound did not get there, and says nothing against it
    assert fit_guard_excess(_profile(-0.10), beams, CELL) == 0.0
    # within the noise (3 mm): no contradiction
    assert fit_guard_excess(_profile(0.005), beams, CELL) <= GUARD_LENGTH_CELLS * CELL


def test_one_firing_or_a_few_spurious_echoes_do_not_contradict_the_wall() -> None:
    beams = _wall_beams(seed=1)
    wall = PolyFit(0, np.array([1.5]), (0.0, 4.0))
    spurious = np.random.default_rng(2).random(beams.path.size) < 0.1
    beams.path[spurious] += 1.0  # echoes from beyond the wall: a tenth of the readings
    assert fit_guard_excess(wall, beams, CELL) == 0.0
    # every reading one firing: whatever they say is one pose's word
    front = _profile(0.10).sample(CELL)
    rows = first_echoes(beams)
    early = np.ones(rows.size, dtype=bool)
    assert beam_contradictions(front, beams, 0.003, rows, early).contradicted.any()
    beams.readings["t"] = 0.0
    assert not beam_contradictions(front, beams, 0.003, rows, early).contradicted.any()


def test_score_excludes_the_setting_the_first_echoes_contradict() -> None:
    """The setting 10 cm in front of the wall has the lower held-out residual; the guard
    leaves the one along the wall (without the guard, the front one is chosen)."""
    beams = _wall_beams(seed=3)
    spline = next(c for c in CANDIDATES if c.family == "spline")
    front_setting, wall_setting = spline.settings[0], spline.settings[-1]
    s = Score(spline)
    s.losses = {front_setting: [np.full(50, 0.002)], wall_setting: [np.full(50, 0.003)]}
    s.base_losses = [np.full(50, 0.01)]
    s.finish(CELL)
    assert s.setting == front_setting and s.excluded is None
    s.guard = {
        front_setting: fit_guard_excess(_profile(0.10), beams, CELL),
        wall_setting: fit_guard_excess(PolyFit(0, np.array([1.5]), (0.0, 4.0)), beams, CELL),
    }
    s.finish(CELL)
    assert s.setting == wall_setting and s.excluded is None
    assert s.residual_m == pytest.approx(0.003) and s.guard_m == 0.0
    s.guard[wall_setting] = s.guard[front_setting]
    s.finish(CELL)
    assert s.excluded is not None and s.excluded.startswith("the first echoes contradict")

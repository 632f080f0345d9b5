"""Seeded random scenes: reproducible, physically sensible, every kind drawn."""

from __future__ import annotations

import numpy as np
import pytest

from sonarsim import simulate
from sonarsim.random_scenes import (
    ARRAY_KINDS,
    RANGE_LIMITS,
    SURFACE_KINDS,
    random_scenario,
    random_scenario_dict,
)


def test_same_seed_same_scene_other_seed_other_scene() -> None:
    assert random_scenario_dict(11) == random_scenario_dict(11)
    assert random_scenario_dict(11) != random_scenario_dict(12)
    a, b = simulate(random_scenario(11)), simulate(random_scenario(11))
    np.testing.assert_array_equal(a.readings, b.readings)
    np.testing.assert_array_equal(a.truth, b.truth)


def test_a_scene_is_a_yaml_scenario() -> None:
    import yaml

    from sonarsim import scenario_from_dict

    text = yaml.safe_dump(random_scenario_dict(5))
    assert scenario_from_dict(yaml.safe_load(text)).name == "random-5"


def test_every_surface_and_array_kind_is_drawn() -> None:
    kinds = [random_scenario_dict(s)["description"].split(" / ") for s in range(60)]
    assert {k[0] for k in kinds} == set(SURFACE_KINDS)
    assert {k[1] for k in kinds} == set(ARRAY_KINDS)


@pytest.mark.parametrize("seed", range(8))
def test_scenes_are_physically_sensible(seed: int) -> None:
    sim = simulate(random_scenario(seed))
    r = sim.readings
    assert r.size > 20  # the sensors hear the surface
    rng = 0.5 * r["tof"] * sim.speed_of_sound
    # bistatic paths are at most the pair's two ranges; each leg within the limits
    assert rng.min() >= RANGE_LIMITS[0] - 1e-9 and rng.max() <= RANGE_LIMITS[1] + 1e-9
    truth = sim.truth[np.isfinite(sim.truth).all(axis=1)]
    assert truth.shape[1] == 2 and truth.shape[0] > 100
    # one profile y(x): x increasing, and every sensor below the surface's lowest point
    # (the robot never turns in these scenes, so a mount's world y is the pose's y plus it)
    assert np.all(np.diff(truth[:, 0]) >= -1e-9)
    assert np.all(r["theta"] == 0.0)
    assert r["y"].max() + sim.sensors["y"].max() < truth[:, 1].min() - 0.5

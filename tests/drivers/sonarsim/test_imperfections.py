"""Each imperfection's statistics, with fixed seeds."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from sonarsim import imperfections as imp
from sonarsim import scenario_from_dict, simulate
from sonarsim.records import FLAG_CROSSTALK

C = 343.3
WALL_WORLD = {"surfaces": [{"type": "wall", "start": [-50, 3.0], "end": [50, 3.0]}]}


def wall_scenario(n_stops: int = 2000, half: float = 20.0, **extra: Any) -> dict[str, Any]:
    """One upward sensor sliding along under a wall 3 m away (true range 3 m)."""
    base: dict[str, Any] = {
        "world": WALL_WORLD,
        "array": {"type": "explicit", "sensors": [{"x": 0, "y": 0, "heading_deg": 0}]},
        "path": {
            "locations": {"start": [-half, 0], "end": [half, 0], "count": n_stops},
            "turret_deg": 90.0,
        },
        "seed": 5,
    }
    base.update(extra)
    return base


def ranges(data: dict[str, Any]) -> np.ndarray:
    r = simulate(scenario_from_dict(data)).readings
    return np.asarray(r["tof"] * C / 2)


def test_ideal_ranges_are_exact() -> None:
    r = ranges(wall_scenario(50))
    assert r.size == 50
    np.testing.assert_allclose(r, 3.0, atol=1e-12)


def test_gaussian_range_noise_statistics() -> None:
    r = ranges(wall_scenario(imperfections={"range_noise_sigma": 0.02}))
    assert r.size == 2000
    err = r - 3.0
    assert abs(err.mean()) < 3 * 0.02 / np.sqrt(2000)
    assert err.std(ddof=1) == pytest.approx(0.02, rel=0.05)
    # Same seed, same readings; another seed, others.
    again = ranges(wall_scenario(imperfections={"range_noise_sigma": 0.02}))
    np.testing.assert_array_equal(r, again)
    other = ranges(wall_scenario(imperfections={"range_noise_sigma": 0.02}, seed=6))
    assert not np.array_equal(r, other)


def test_quantisation_to_inches() -> None:
    r = ranges(wall_scenario(200, imperfections={"range_noise_sigma": 0.05, "quantise": True}))
    steps = r / 0.0254
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    assert np.unique(np.round(steps)).size > 5
    np.testing.assert_allclose(imp.quantise(np.array([6.0]), 0.0254), [2 * 118 * 0.0254])


def test_dropout_rate() -> None:
    r = ranges(wall_scenario(imperfections={"dropout_probability": 0.3}))
    assert r.size / 2000 == pytest.approx(0.7, abs=0.03)


def test_spurious_rate_and_uniform_ranges() -> None:
    data = wall_scenario(imperfections={"spurious_probability": 0.25})
    data["path"]["turret_deg"] = -90.0  # looking away from the wall: only spurious echoes
    r = ranges(data)
    assert r.size / 2000 == pytest.approx(0.25, abs=0.03)
    assert r.min() >= 0.15 and r.max() <= 10.7
    assert r.mean() == pytest.approx((0.15 + 10.7) / 2, rel=0.08)


def test_crosstalk_moves_late_echo_into_next_window() -> None:
    interval = 0.010  # shorter than the 17.5 ms round trip to the wall
    data = wall_scenario(
        20, 0.1, timing={"firing_interval_s": interval},
        imperfections={"crosstalk": True, "flag_crosstalk": True},
    )  # fmt: skip
    res = simulate(scenario_from_dict(data))
    r = res.readings
    # The first firing hears nothing in its 10 ms window; every later one hears the
    # previous pulse's wall echo, 10 ms late.
    assert r.size == 19
    np.testing.assert_allclose(r["t"], np.arange(1, 20) * interval)
    # (stops are 1 cm apart, so the previous pulse's path is 6 m to within 1e-5 m)
    np.testing.assert_allclose(r["tof"] * C, 6.0 - C * interval, atol=1e-4)
    assert np.all(r["flags"] & FLAG_CROSSTALK)
    # Without crosstalk modelling the true echo is reported.
    data["imperfections"] = {}
    np.testing.assert_allclose(simulate(scenario_from_dict(data)).readings["tof"] * C, 6.0)


def test_crosstalk_unflagged_by_default_and_no_effect_with_long_interval() -> None:
    data = wall_scenario(10, 0.1, timing={"firing_interval_s": 0.010},
                         imperfections={"crosstalk": True})  # fmt: skip
    assert not np.any(simulate(scenario_from_dict(data)).readings["flags"])
    data["timing"] = {"firing_interval_s": 0.062}
    r = simulate(scenario_from_dict(data)).readings
    np.testing.assert_allclose(r["tof"] * C, 6.0)


def test_unit_functions() -> None:
    rng = np.random.default_rng(1)
    assert imp.dropouts(5, 0.0, rng).all()
    with pytest.raises(ValueError):
        imp.dropouts(5, 1.5, rng)
    ch, path = imp.spurious(np.full(4, 0.15), np.full(4, 10.7), 1.0, rng)
    assert ch.tolist() == [0, 1, 2, 3] and np.all((path >= 0.3) & (path <= 21.4))
    np.testing.assert_array_equal(imp.range_noise(np.ones(3), 0.0, rng), np.ones(3))
    late = imp.late_echoes(np.array([1.0, 6.0, 30.0]), C, np.full(3, 0.01), np.full(3, 0.01))
    assert late.tolist() == [False, True, False]
    first = imp.first_per_channel(np.array([2, 0, 2, 0]), np.array([3.0, 2.0, 1.0, 4.0]))
    assert first.tolist() == [1, 2]

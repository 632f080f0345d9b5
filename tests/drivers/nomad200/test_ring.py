"""The ring geometry and line speeds live in nomad200; every other copy agrees with them."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

import nomad200
from nomad200 import BAUD_RATES, ring
from nomad200.emulator import sonar
from sonarsim.arrays import circular_array
from sonarsim.scenario_spec import CircularArray, SensorDefaults
from sonarsim.shipped import shipped_dir


def test_ring_table() -> None:
    assert ring.N_SONARS == 16 and ring.IDS.tolist() == list(range(16))
    np.testing.assert_allclose(np.rad2deg(ring.HEADINGS), 22.5 * np.arange(16))
    np.testing.assert_allclose(np.hypot(ring.MOUNT_X, ring.MOUNT_Y), 0.22)
    np.testing.assert_allclose(np.arctan2(ring.MOUNT_Y, ring.MOUNT_X) % (2 * np.pi), ring.HEADINGS)
    assert pytest.approx(math.radians(12.5)) == ring.HALF_BEAMWIDTH
    assert (ring.MIN_RANGE, ring.MAX_RANGE) == (0.15, 10.7)
    with pytest.raises(ValueError, match="read-only"):
        ring.HEADINGS[0] = 1.0


def test_baud_rates() -> None:
    assert nomad200.BAUD_RATES == BAUD_RATES == (4800, 9600, 19200, 38400)


def test_emulator_fires_along_the_ring() -> None:
    ids = np.arange(16)
    pos, head = sonar.ring_geometry(np.zeros((16, 2)), np.full(16, 0.3), ids)
    np.testing.assert_allclose(head, 0.3 + ring.HEADINGS)
    c, s = math.cos(0.3), math.sin(0.3)
    np.testing.assert_allclose(pos[:, 0], c * ring.MOUNT_X - s * ring.MOUNT_Y)
    np.testing.assert_allclose(pos[:, 1], s * ring.MOUNT_X + c * ring.MOUNT_Y)


def test_sonarsim_defaults_are_the_ring() -> None:
    arr = circular_array()
    np.testing.assert_allclose(arr.x, ring.MOUNT_X, atol=1e-12)
    np.testing.assert_allclose(arr.y, ring.MOUNT_Y, atol=1e-12)
    np.testing.assert_allclose(arr.heading % (2 * np.pi), ring.HEADINGS, atol=1e-12)
    np.testing.assert_allclose(arr.half_beamwidth, ring.HALF_BEAMWIDTH)
    d, c = SensorDefaults(), CircularArray(type="circular")
    assert (c.count, c.radius) == (ring.N_SONARS, ring.RADIUS)
    assert math.radians(d.half_beamwidth_deg) == pytest.approx(ring.HALF_BEAMWIDTH)
    assert (d.min_range, d.max_range) == (ring.MIN_RANGE, ring.MAX_RANGE)


def test_shipped_ring_preset_is_the_ring() -> None:
    doc = yaml.safe_load((shipped_dir("sensors") / "nomad200-ring.yaml").read_text())
    a, s = doc["array"], doc["sensor"]
    assert (a["type"], a["count"], a["radius"]) == ("circular", ring.N_SONARS, ring.RADIUS)
    assert math.radians(a["step_deg"]) == pytest.approx(ring.STEP)
    assert math.radians(s["half_beamwidth_deg"]) == pytest.approx(ring.HALF_BEAMWIDTH)
    assert (s["min_range"], s["max_range"]) == (ring.MIN_RANGE, ring.MAX_RANGE)


def test_shipped_example_sensors_are_the_ring() -> None:
    doc = yaml.safe_load((shipped_dir("sensors") / "example-sensors.yaml").read_text())
    rows = doc["sensors"]
    col = {k: np.array([r[k] for r in rows], dtype=float) for k in rows[0]}
    np.testing.assert_array_equal(col["id"], ring.IDS)
    np.testing.assert_allclose(col["x"], ring.MOUNT_X, atol=1e-6)
    np.testing.assert_allclose(col["y"], ring.MOUNT_Y, atol=1e-6)
    np.testing.assert_allclose(col["heading"], ring.HEADINGS, atol=1e-6)
    np.testing.assert_allclose(col["half_beamwidth"], ring.HALF_BEAMWIDTH, atol=1e-6)
    np.testing.assert_array_equal(col["min_range"], ring.MIN_RANGE)
    np.testing.assert_array_equal(col["max_range"], ring.MAX_RANGE)

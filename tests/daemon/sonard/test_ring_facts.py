"""sonard takes the ring geometry and the line speeds from nomad200."""

from __future__ import annotations

import numpy as np

from nomad200 import BAUD_RATES, ring
from sonard.plan import BAUD_RATES as PLAN_BAUD_RATES
from sonard.plan import Plan
from sonard.ring import ring_sensors


def test_plan_speeds_are_nomad200_s() -> None:
    assert PLAN_BAUD_RATES is BAUD_RATES
    assert Plan.model_fields["max_range"].metadata[-1].le == ring.MAX_RANGE


def test_ring_sensors_are_nomad200_s() -> None:
    t = ring_sensors()
    np.testing.assert_array_equal(t["id"], ring.IDS)
    for name, want in (("x", ring.MOUNT_X), ("y", ring.MOUNT_Y), ("heading", ring.HEADINGS)):
        np.testing.assert_array_equal(t[name], want.astype(t[name].dtype))

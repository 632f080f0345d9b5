"""Readings reach the log in non-decreasing ``t``, with and without pose attachments."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from robots import WORLD

from sonard.cli import main
from sonard.ordering import TimeOrder
from sonarlog import empty_readings, read_log, speed_of_sound_at

pytestmark = pytest.mark.timeout(120)


def _plan(tmp: Path, **over: object) -> Path:
    plan: dict[str, object] = {
        "name": "order",
        "sonars": [0, 2, 14, 1, 15],
        "baud": 38400,
        "steps": [
            {"define_pose": {"x": -0.75, "y": 0.0, "theta": 0, "turret": 90}},
            {"translate": {"distance": 0.3, "speed": 0.2, "mode": "continuous"}},
            {"rotate": {"angle": 30, "speed": 30}},
            {"dwell": {"seconds": 0.5}},
        ],
    }
    plan.update(over)
    path = tmp / "plan.yaml"
    path.write_text(yaml.safe_dump(plan), encoding="utf-8")
    return path


@pytest.mark.parametrize("attachments", [True, False], ids=["attachments", "interpolated"])
def test_logged_t_never_goes_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, attachments: bool
) -> None:
    monkeypatch.setenv("SONARD_LOCK_DIR", str(tmp_path))
    out = tmp_path / "run.h5"
    plan = _plan(tmp_path, pose_attachments=attachments, temperature_c=10.0)
    url = f"nomad://order-{attachments}?world={WORLD}&fast=1"
    assert main(["--port", url, "--plan", str(plan), "--out", str(out)]) == 0
    log = read_log(out)
    t = log.readings["t"]
    assert len(t) > 50
    assert np.all(np.diff(t) >= 0) and log.time_ordered and log.backward_steps == 0
    assert len(np.unique(log.readings["rx"])) == 5
    # the plan's temperature sets the speed of sound, and both are logged
    assert log.attrs["temperature_c"] == 10.0
    assert log.speed_of_sound == pytest.approx(speed_of_sound_at(10.0))


def test_time_order_buffer_sorts_and_holds_back() -> None:
    order = TimeOrder(hold=0.08)
    rows = empty_readings(4)
    rows["t"] = [10.00, 9.96, 10.04, 9.90]
    rows["tx"] = [1, 2, 3, 4]
    out = order.push(rows, now=10.05)
    assert out["t"].tolist() == [9.90, 9.96] and order.held == 2
    late = empty_readings(1)
    late["t"] = 9.95  # older than a reading already released: cannot be placed
    assert len(order.push(late, now=10.2)) == 2 and order.late == 1
    assert len(order.drain()) == 0


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 200),
    seed=st.integers(0, 2**16),
    batch=st.integers(1, 12),
)
def test_time_order_output_is_sorted_and_complete_for_bounded_lateness(
    n: int, seed: int, batch: int
) -> None:
    rng = np.random.default_rng(seed)
    interval = 0.04
    fire = np.cumsum(rng.uniform(0.0, interval, n))  # firing times, some equal gaps of 0
    seen = fire + rng.uniform(0.0, interval, n)  # each reported within one interval
    order = TimeOrder(hold=2 * interval)
    rows = empty_readings(n)
    rows["t"] = fire
    by_seen = np.argsort(seen, kind="stable")
    out = []
    for part in np.array_split(by_seen, max(1, n // batch)):
        if len(part):
            out.append(order.push(rows[part], now=float(seen[part].max())))
    out.append(order.drain())
    got = np.concatenate(out)["t"]
    assert order.late == 0 and len(got) == n
    assert np.all(np.diff(got) >= 0)

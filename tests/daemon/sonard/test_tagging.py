"""Tagging readings with their firing pose, with and without pose attachments."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pytest

from sonard.ring import ring_sensors
from sonard.tagging import Tagger, to_tof
from sonarlog import FLAG_NO_ECHO


@dataclass
class Att:
    x: float
    y: float
    steer: float
    turret: float
    reading_time: float

    @property
    def pose_time(self) -> float:
        return self.reading_time - 0.01


@dataclass
class St:
    clock: float
    x: float | None = 0.0
    y: float | None = 0.0
    steer: float | None = 0.0
    turret: float | None = 0.0
    sonar: dict[int, float | None] = field(default_factory=dict)
    sonar_attachments: dict[int, Any] = field(default_factory=dict)


def test_ring_table() -> None:
    t = ring_sensors()
    assert t["id"].tolist() == list(range(16))
    np.testing.assert_allclose(np.hypot(t["x"], t["y"]), 0.22)
    np.testing.assert_allclose(np.rad2deg(t["heading"]), 22.5 * np.arange(16))
    np.testing.assert_allclose(np.rad2deg(t["half_beamwidth"]), 12.5)
    assert (t["min_range"] == 0.15).all() and (t["max_range"] == 10.7).all()


def test_to_tof_and_flags() -> None:
    tof, flags = to_tof(np.array([1.0, np.nan, 0.1, 10.0]), 343.3)
    np.testing.assert_allclose(tof[[0, 2, 3]], 2 * np.array([1.0, 0.1, 10.0]) / 343.3)
    assert math.isnan(tof[1])
    assert flags.tolist() == [0, FLAG_NO_ECHO, FLAG_NO_ECHO, 0]


def test_attachments_emit_only_new_firings_with_their_pose() -> None:
    tg = Tagger([0, 2], speed_of_sound=343.3, interval=0.04, attachments=True)
    s1 = St(
        clock=1.0,
        sonar={0: 1.0, 2: None},
        sonar_attachments={0: Att(0.1, 0.2, 0.3, 0.4, 0.96), 2: Att(0.0, 0.0, 0.0, 0.0, 0.92)},
    )
    rows, pose = tg.feed(s1, host_time=1000.0)
    assert rows["tx"].tolist() == [0, 2] and (rows["tx"] == rows["rx"]).all()
    assert rows["t"].tolist() == pytest.approx([999.95, 999.91])  # the firing (pose) time
    assert (rows["x"][0], rows["y"][0], rows["theta"][0], rows["turret"][0]) == (0.1, 0.2, 0.3, 0.4)
    assert rows["flags"].tolist() == [0, FLAG_NO_ECHO]
    assert pose["t"][0] == pytest.approx(1000.0)
    # same reading times: nothing new; sonar 2 fired again
    s2 = St(
        clock=1.04,
        sonar={0: 1.0, 2: 2.0},
        sonar_attachments={0: Att(0.1, 0.2, 0.3, 0.4, 0.96), 2: Att(0.5, 0.0, 0.0, 0.0, 1.0)},
    )
    rows, _ = tg.feed(s2, host_time=2000.0)  # host time ignored after the first state
    assert rows["tx"].tolist() == [2]
    assert rows["t"][0] == pytest.approx(999.99)
    assert rows["x"][0] == 0.5
    assert rows["tof"][0] == pytest.approx(4.0 / 343.3)


def test_interpolation_without_attachments() -> None:
    tg = Tagger([0, 1], speed_of_sound=343.3, interval=0.04, attachments=False)
    rows, _ = tg.feed(St(clock=0.0, x=0.0, sonar={0: 1.0, 1: 2.0}), host_time=0.0)
    assert rows["tx"].tolist() == [0, 1]  # first state: everything is new, current pose
    rows, _ = tg.feed(St(clock=0.04, x=0.004, sonar={0: 1.1, 1: 2.0}), host_time=0.0)
    assert rows["tx"].tolist() == [0]  # only the changed range
    assert rows["t"][0] == pytest.approx(0.02)  # middle of the window
    assert rows["x"][0] == pytest.approx(0.002)  # pose interpolated
    rows, _ = tg.feed(St(clock=0.08, x=0.008, sonar={0: 1.1, 1: 2.0}), host_time=0.0)
    assert rows["tx"].tolist() == [1]  # a full cycle passed: sonar 1 fired again, same range
    rows, _ = tg.feed(St(clock=0.12, x=0.012, sonar={0: 1.1, 1: 2.0}), host_time=0.0)
    assert rows["tx"].tolist() == [0]


def test_angles_interpolate_across_the_wrap() -> None:
    tg = Tagger([0], speed_of_sound=343.3, interval=0.04, attachments=False)
    tg.feed(St(clock=0.0, steer=math.pi - 0.1, sonar={0: 1.0}), host_time=0.0)
    rows, _ = tg.feed(St(clock=0.04, steer=-math.pi + 0.1, sonar={0: 1.2}), host_time=0.0)
    assert abs(abs(rows["theta"][0]) - math.pi) < 1e-9


def test_state_without_pose_yields_nothing() -> None:
    tg = Tagger([0], speed_of_sound=343.3, interval=0.04, attachments=False)
    rows, pose = tg.feed(St(clock=0.0, x=None, sonar={0: 1.0}), host_time=0.0)
    assert len(rows) == 0 and len(pose) == 0


def test_plausibility_refuses_impossible_jumps() -> None:
    tg = Tagger([0], speed_of_sound=343.3, interval=0.04, attachments=True)
    a0 = Att(0.0, 0.0, 0.0, 0.0, 0.95)
    tg.feed(St(clock=1.0, sonar={0: 1.0}, sonar_attachments={0: a0}), host_time=0.0)
    assert tg.plausible(St(clock=1.05, x=0.02, sonar={0: 1.0}, sonar_attachments={0: a0}))
    assert not tg.plausible(St(clock=1.05, x=5.0))  # 100 m/s
    assert not tg.plausible(St(clock=0.5))  # clock ran backwards
    far = Att(3.0, 0.0, 0.0, 0.0, 1.04)
    assert not tg.plausible(St(clock=1.05, sonar={0: 1.0}, sonar_attachments={0: far}))
    tg.forget_pose()
    assert tg.plausible(St(clock=1.05, x=5.0))  # after DP anything goes


def test_persistent_change_is_followed() -> None:
    tg = Tagger([0], speed_of_sound=343.3, interval=0.04, attachments=False)
    tg.feed(St(clock=100.0, sonar={0: 1.0}), host_time=0.0)
    verdicts = [tg.plausible(St(clock=1.0 + k)) for k in range(12)]  # robot was reset
    assert not any(verdicts[:10]) and verdicts[10]


def test_a_clock_ahead_of_the_host_is_damaged_until_it_persists() -> None:
    # the reply's clock is 65.536 s on (its third byte one higher) while 40 ms passed on the
    # host: no robot builds a reply after the host read it
    tg = Tagger([0], speed_of_sound=343.3, interval=0.04, attachments=False)
    tg.feed(St(clock=10.0, sonar={0: 1.0}), host_time=1000.0)
    assert tg.clock_runs_ahead(St(clock=75.576), 1000.04)
    assert not tg.plausible(St(clock=75.576), 1000.04)
    assert tg.plausible(St(clock=10.08), 1000.08)
    tg.feed(St(clock=10.08, sonar={0: 1.0}), host_time=1000.08)
    # a host that read the reply late (stopped, loaded) only makes the clock look behind
    assert tg.plausible(St(clock=10.12), 1005.0)
    # a clock that stays ahead (the host slept) is followed after MAX_REJECTS_IN_ROW
    verdicts = [tg.plausible(St(clock=70.0 + 0.04 * k), 1000.12 + 0.04 * k) for k in range(12)]
    assert not any(verdicts[:10]) and verdicts[10]
    tg.feed(St(clock=70.44, sonar={0: 1.0}), host_time=1000.52)
    assert tg.plausible(St(clock=70.48), 1000.56)


def test_a_clock_ahead_with_a_fresh_firing_is_believed() -> None:
    # a fast emulator's virtual clock moved on by lost replies' timeouts: the robot fired
    # meanwhile, and the attachment says so
    tg = Tagger([0, 1], speed_of_sound=343.3, interval=0.04, attachments=True)
    a0 = Att(0.0, 0.0, 0.0, 0.0, 0.95)
    tg.feed(St(clock=1.0, sonar={0: 1.0}, sonar_attachments={0: a0}), host_time=1000.0)
    fresh = Att(0.0, 0.0, 0.0, 0.0, 3.48)
    assert tg.plausible(St(clock=3.5, sonar={0: 1.0}, sonar_attachments={0: fresh}), 1000.01)
    stale = St(clock=3.5, sonar={0: 1.0}, sonar_attachments={0: a0})
    assert not tg.plausible(stale, 1000.01)

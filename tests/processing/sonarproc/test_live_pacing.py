"""The live view's snapshot pacing: the latency promise, the relaxed pace, the CPU ceiling.

The pacer is driven with made-up monotonic times (no clock), so every decision is exact.
"""

from __future__ import annotations

import numpy as np
import pytest

from sonarproc.live.pacing import (
    LATENCY_PROMISE_S,
    MAX_SNAPSHOT_DUTY,
    POLL_S,
    SNAPSHOT_DUTY,
    SnapshotPacer,
)


def _after_snapshot(cpu: float, wall: float, end: float = 10.0) -> SnapshotPacer:
    pacer = SnapshotPacer()
    pacer.taken(end - wall - 1.0)
    pacer.done(end - wall, end, cpu)
    return pacer


def test_nothing_pending_is_never_due() -> None:
    pacer = _after_snapshot(cpu=0.3, wall=0.3)
    assert not pacer.pending
    assert not pacer.due(1e6)
    assert pacer.next_check_s(11.0) == POLL_S


def test_a_cheap_snapshot_keeps_the_relaxed_pace() -> None:
    # 0.05 s of CPU: the relaxed gap (0.05 / 0.12 = 0.42 s, floored at 0.5 s) comes long
    # before any deadline
    pacer = _after_snapshot(cpu=0.05, wall=0.05)
    pacer.taken(10.0)
    assert not pacer.due(10.49)
    assert pacer.due(10.5)


def test_a_costly_snapshot_runs_early_for_the_oldest_reading() -> None:
    # 0.3 s of CPU: the relaxed gap is 2.5 s, the promise would be broken (2.5 + 0.3 > 2)
    cpu = wall = 0.3
    pacer = _after_snapshot(cpu, wall)
    pacer.taken(10.1)
    deadline = 10.1 + LATENCY_PROMISE_S - POLL_S - wall
    assert pacer.deadline() == pytest.approx(deadline)
    assert not pacer.due(deadline - 0.01)
    assert pacer.due(deadline)
    # run at the deadline, taking the expected wall time: mapped within the promise less a
    # poll, the margin for the loop noticing the deadline a poll late
    assert deadline + wall - 10.1 == pytest.approx(LATENCY_PROMISE_S - POLL_S)
    assert deadline - 10.0 < cpu / SNAPSHOT_DUTY


def test_the_longest_recent_wall_time_sets_the_deadline() -> None:
    pacer = _after_snapshot(cpu=0.2, wall=0.9)  # a loaded host stretched it
    for k in range(3):  # three quick ones: the slow one is still among the last four
        pacer.taken(11.0 + k)
        pacer.done(11.5 + k, 11.7 + k, 0.2)
    assert pacer.expected_wall_s() == pytest.approx(0.9)
    pacer.taken(14.0)
    pacer.done(14.5, 14.7, 0.2)  # the fourth: the slow one drops out
    assert pacer.expected_wall_s() == pytest.approx(0.2)


def test_the_cpu_ceiling_holds_even_past_a_deadline() -> None:
    # a 1.5 s snapshot cannot keep a 2 s promise: it waits 1.5 / 0.5 = 3 s anyway
    cpu = wall = 1.5
    pacer = _after_snapshot(cpu, wall)
    pacer.taken(10.0)
    assert pacer.deadline() < 10.0 + cpu / MAX_SNAPSHOT_DUTY
    assert not pacer.due(10.0 + cpu / MAX_SNAPSHOT_DUTY - 0.01)
    assert pacer.due(10.0 + cpu / MAX_SNAPSHOT_DUTY)
    assert pacer.next_check_s(10.0) == POLL_S
    assert pacer.next_check_s(12.9) == pytest.approx(0.1)


def test_next_check_wakes_for_the_deadline() -> None:
    pacer = _after_snapshot(cpu=0.3, wall=0.3)
    pacer.taken(10.1)
    deadline = pacer.deadline()
    assert pacer.next_check_s(deadline - 0.05) == pytest.approx(0.05)
    assert pacer.next_check_s(deadline + 1.0) == 0.0


@pytest.mark.parametrize("cpu", [0.02, 0.1, 0.3, 0.5, 1.0, 2.0])
def test_streaming_readings_latency_and_cpu_share(cpu: float) -> None:
    """Readings every poll for a minute: the worst wait and the share of one core.

    A loop that polls every POLL_S (and sooner for a deadline, as ``follow_live`` does),
    snapshots taking ``cpu`` of CPU and of wall time.
    """
    rng = np.random.default_rng(7)
    pacer = SnapshotPacer()
    now, busy, worst = 0.0, 0.0, 0.0
    waiting: list[float] = []
    while now < 60.0:
        waiting.append(now)
        pacer.taken(now)
        if pacer.due(now):
            pacer.done(now, now + cpu, cpu)
            busy += cpu
            now += cpu
            worst = max(worst, now - waiting[0])
            waiting.clear()
        now += min(POLL_S, max(pacer.next_check_s(now), 1e-3)) + rng.uniform(0, 1e-3)
    share = busy / now
    assert share <= MAX_SNAPSHOT_DUTY / (1 + MAX_SNAPSHOT_DUTY) + 1e-9
    if cpu + cpu / MAX_SNAPSHOT_DUTY <= LATENCY_PROMISE_S - 2 * POLL_S:
        assert worst <= LATENCY_PROMISE_S
        assert share <= max(SNAPSHOT_DUTY, cpu / (LATENCY_PROMISE_S - POLL_S)) + 0.01
    else:  # beyond the ceiling the map lags by its gap, not more
        assert worst <= cpu + cpu / MAX_SNAPSHOT_DUTY + POLL_S + 0.01


def test_bad_duties_are_refused() -> None:
    with pytest.raises(ValueError, match="duty"):
        SnapshotPacer(duty=0.6, max_duty=0.5)
    with pytest.raises(ValueError, match="duty"):
        SnapshotPacer(duty=0.0)

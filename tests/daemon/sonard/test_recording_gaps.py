"""Every firing a reply could show is logged or inside a logged ``gap``, however a run goes.

A scripted robot fires five sonars in turn every 40 ms; its replies carry pose attachments
(the firing time and the echo's). The :class:`ReplyRecorder` gets the replies a run would
get, and the soak's own accounting checks what it queued on the sink.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonard.plan import parse_plan
from sonard.recording import ReplyRecorder
from sonard.soak.accounting import account_firings
from sonarlog import SENSOR_DTYPE, SonarLog
from sonarlog.schema import EVENT_DTYPE

SONARS = [14, 15, 0, 1, 2]
INTERVAL = 0.04
ECHO_S = 0.02  # every echo is in 20 ms after its firing
OFFSET = 1.0e9  # UNIX time of robot clock 0 (the host's clock when the first reply came)


@dataclass
class Att:
    x: float = 0.0
    y: float = 0.0
    steer: float = 0.0
    turret: float = 0.0
    pose_time: float = 0.0
    reading_time: float = 0.0


@dataclass
class State:
    clock: float
    x: float = 0.0
    y: float = 0.0
    steer: float = 0.0
    turret: float = 0.0
    sonar: dict[int, float | None] = field(default_factory=dict)
    sonar_attachments: dict[int, Att] = field(default_factory=dict)


def firings(until: float) -> tuple[np.ndarray, np.ndarray]:
    """(robot time, sonar) of every firing up to ``until``: one every interval, in turn."""
    t = np.arange(1, round(until / INTERVAL) + 1) * INTERVAL
    return np.round(t, 3), np.array([SONARS[k % len(SONARS)] for k in range(len(t))])


def state_at(clock: float) -> State:
    """The reply the robot builds at robot time ``clock``."""
    seen = clock
    t, sid = firings(seen)
    st = State(clock=round(clock, 3))
    for s in SONARS:
        done = t[(sid == s) & (t + ECHO_S <= seen + 1e-9)]
        if len(done):
            f = float(done[-1])
            st.sonar[s] = 1.0
            st.sonar_attachments[s] = Att(pose_time=f, reading_time=round(f + ECHO_S, 3))
    return st


class Sink:
    """What the recorder queues, kept in memory."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.events: list[tuple[float, str, str]] = []

    def readings(self, rows: np.ndarray) -> None:
        if len(rows):
            self.rows.append(rows)

    def poses(self, rows: np.ndarray) -> None:
        pass

    def event(self, kind: str, detail: str = "", t: float | None = None) -> None:
        self.events.append((OFFSET if t is None else t, kind, detail))

    def log(self) -> SonarLog:
        ev = np.zeros(len(self.events), EVENT_DTYPE)
        for i, (t, kind, detail) in enumerate(self.events):
            ev[i] = (t, kind.encode(), detail.encode())
        r = np.concatenate(self.rows)
        return SonarLog(Path("x.h5"), {}, np.zeros(1, SENSOR_DTYPE), r, events=ev)


def recorder() -> tuple[ReplyRecorder, Sink]:
    plan = parse_plan(
        {
            "name": "gaps",
            "sonars": SONARS,
            "interval": INTERVAL,
            "baud": 38400,
            "pose_attachments": True,
            "steps": [{"dwell": {"seconds": 1.0}}],
        },
        "gaps.yaml",
    )
    sink = Sink()
    rec = ReplyRecorder(plan, sink)  # type: ignore[arg-type]
    rec.recording = True
    return rec, sink


def feed(rec: ReplyRecorder, state: Any) -> None:
    rec.record(state, OFFSET + state.clock)


def polls(rec: ReplyRecorder, start: float, stop: float, step: float = INTERVAL) -> None:
    for clock in np.arange(start, stop, step):
        feed(rec, state_at(float(clock)))


def accounted(sink: Sink, until: float) -> tuple[int, int, int]:
    """(firings, unaccounted, extra readings) of the run's firings up to ``until``."""
    t, sid = firings(until)
    acc = account_firings(t, sid, sink.log(), interval=INTERVAL)
    return acc.firings, acc.unaccounted, acc.extra_readings


def test_polls_every_interval_log_every_firing() -> None:
    rec, sink = recorder()
    polls(rec, 0.5, 3.0)
    rec.drain()
    n, lost, extra = accounted(sink, 3.0)
    assert n > 55 and (lost, extra) == (0, 0)
    assert not [e for e in sink.events if e[1] == "gap"]


def test_an_outage_that_ends_in_a_reconnect_is_a_gap() -> None:
    rec, sink = recorder()
    polls(rec, 0.5, 2.0)
    rec.link_lost()
    feed(rec, state_at(3.0))  # the reconnect's ST and configuration replies
    feed(rec, state_at(3.03))
    rec.link_back()
    polls(rec, 3.1, 4.0)
    rec.drain()
    n, lost, extra = accounted(sink, 4.0)
    assert n > 70 and (lost, extra) == (0, 0)


def test_a_stop_while_reconnecting_still_records_the_outage() -> None:
    # SIGTERM during a reconnect: the robot's ST reply (and the configuration replies
    # before it) are logged, but no poll after the link came back closes the outage
    rec, sink = recorder()
    polls(rec, 0.5, 2.0)
    rec.link_lost()
    feed(rec, state_at(2.9))
    feed(rec, state_at(3.0))  # the ST sent on the way out
    rec.drain()
    n, lost, extra = accounted(sink, 3.0)
    assert n > 50 and (lost, extra) == (0, 0)
    gaps = [e for e in sink.events if e[1] == "gap"]
    assert len(gaps) == 1 and gaps[0][2].startswith(f"until {OFFSET + 3.0:.6f}")


def test_readings_dropped_as_late_are_a_gap() -> None:
    rec, sink = recorder()
    # sonar 0's firing at 1.84 s shows up only now, after later readings were logged (a
    # reply that lost it to a glitch the plausibility check let through)
    polls(rec, 0.5, 2.2)
    late = state_at(2.2)
    late.sonar_attachments[0] = Att(pose_time=1.64, reading_time=1.661)
    feed(rec, late)
    polls(rec, 2.24, 3.0)
    rec.drain()
    assert rec.order.late == 1
    gaps = [e for e in sink.events if e[1] == "gap"]
    assert [(g[0], g[2]) for g in gaps] == [
        (OFFSET + 1.64, f"until {OFFSET + 1.64:.6f}: 1 out-of-order readings dropped")
    ]
    assert [e[2] for e in sink.events if e[1] == "late"] == ["1 out-of-order readings dropped"]


def test_a_damaged_clock_leaping_forward_is_dropped() -> None:
    # two damaged bytes that cancel out in the byte-sum checksum: the clock's third byte is
    # one higher (65.536 s on), the rest of the reply is good and arrives on time
    rec, sink = recorder()
    polls(rec, 0.5, 2.0)
    damaged = state_at(2.0)
    damaged.clock = round(2.0 + 65.536, 3)
    rec.record(damaged, OFFSET + 2.0)
    polls(rec, 2.04, 3.0)
    rec.drain()
    assert rec.n_rejected == 1
    assert rec.tagger.offset == OFFSET  # not re-anchored
    assert [e[1] for e in sink.events] == ["clock"]  # no gap, no second anchor
    n, lost, extra = accounted(sink, 3.0)
    assert n > 55 and (lost, extra) == (0, 0)


def test_a_stalled_host_is_a_gap_not_a_damaged_clock() -> None:
    # sonard stopped for 5 s (SIGSTOP) after it read a reply but before it stamped it: the
    # robot's clock moved on 5 s by the next reply, the host's read times agree
    rec, sink = recorder()
    polls(rec, 0.5, 2.0)
    feed(rec, state_at(2.0))
    rec.record(state_at(2.04), OFFSET + 7.04)  # stamped 5 s late
    polls(rec, 7.08, 8.0)
    rec.drain()
    assert rec.n_rejected == 0
    gaps = [e for e in sink.events if e[1] == "gap"]
    assert len(gaps) == 1 and gaps[0][2].startswith(f"until {OFFSET + 7.08:.6f}")

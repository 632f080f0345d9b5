"""What the robot's replies put in the log: tagged readings in time order, poses, events.

:class:`ReplyRecorder` takes every state reply the acquisition loop gets (polls and motion
commands alike), tags it with :class:`sonard.tagging.Tagger`, and queues the new readings
(through :class:`sonard.ordering.TimeOrder`) and the pose on the
:class:`sonard.writer_thread.LogSink`, with the events that explain the log: ``clock``
(robot clock 0 in UNIX time), ``gap`` (firings that may be missing from the log: good
replies too far apart to see every firing, an outage, or out-of-order readings dropped)
and ``late`` (how many out-of-order readings were dropped in all). Readings fired before
the plan's odometry frame was set are not logged (another frame, not a loss).

Every firing sonard could have seen is either logged or inside a ``gap`` event's span,
whichever way the run goes on: an outage the run ends in (a stop while reconnecting) is
recorded when the run ends, up to the last reply whose readings were logged.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from sonard.ordering import TimeOrder
from sonard.plan import Plan
from sonard.tagging import Tagger
from sonard.writer_thread import LogSink

__all__ = ["ReplyRecorder"]

log = logging.getLogger(__name__)


class ReplyRecorder:
    """Tag state replies and queue their readings, poses and events on the log sink.

    Parameters
    ----------
    plan : Plan
        The validated plan (sonars, interval, speed of sound, attachments).
    sink : LogSink
        Where readings, poses and events go.
    """

    def __init__(self, plan: Plan, sink: LogSink) -> None:
        self.sink = sink
        self.tagger = Tagger(
            plan.sonars,
            speed_of_sound=plan.speed_of_sound,
            interval=plan.interval,
            attachments=plan.use_attachments,
        )
        self.gap_s = max(len(plan.sonars) - 1, 1) * plan.interval
        self._last_reply_t: float | None = None
        self._recovering = False
        #: robot time (UNIX) of the latest reply while recovering: how far the outage reaches
        self._outage_end: float | None = None
        # two firing intervals: the latest a reply can report a firing (see sonard.ordering)
        self.order = TimeOrder(hold=2.0 * plan.interval, on_late=self._note_late)
        self.n_rejected = 0
        #: readings and poses are logged only once the plan's frame is set (see run_plan)
        self.recording = False
        self._frame_clock = -float("inf")

    def record(self, state: Any, now: float) -> np.ndarray | None:
        """Tag a state reply received at UNIX time ``now`` and queue what it shows.

        Returns
        -------
        ndarray or None
            The new readings it logged (none before the frame is set), or None when the
            reply is implausible and was dropped.
        """
        if not self.tagger.plausible(state, now):
            self.n_rejected += 1
            log.debug("implausible reply dropped (clock %.3f)", state.clock)
            return None
        offset = self.tagger.offset
        rows, pose = self.tagger.feed(state, now)
        if self.tagger.offset != offset:
            self.sink.event("clock", f"robot clock 0 is UNIX time {self.tagger.offset:.6f}")
        self._note_gap(self.tagger.time_of(float(state.clock)))
        if self.recording:
            if len(rows):
                rows = rows[rows["t"] - (self.tagger.offset or 0.0) >= self._frame_clock]
            self.sink.readings(self.order.push(rows, self.tagger.time_of(float(state.clock))))
            self.sink.poses(pose)
        else:
            rows = rows[:0]
        return rows

    def start_frame(self, clock: float) -> None:
        """A new odometry frame begins at robot ``clock`` (s): log from there on."""
        self.tagger.forget_pose()
        self._frame_clock = clock
        self.recording = True

    def link_lost(self) -> None:
        """The link failed: replies while reconnecting do not end the outage's gap.

        The host-minus-robot lag is learnt anew: a fast emulator's clock moves on by each
        reply timeout of the outage, a restarted one starts again.
        """
        self._recovering = True
        self.tagger.forget_host_lag()

    def link_back(self) -> None:
        """The link is back: the next reply closes the gap; the pose is learnt anew."""
        self._recovering = False
        self._outage_end = None
        self.tagger.forget_pose()

    def _note_gap(self, now: float) -> None:
        """Record a ``gap`` event when good replies were too far apart to see every firing.

        A reply shows each sonar's latest firing only; replies closer than one firing cycle
        minus one interval cannot miss one. Further apart (garbled or lost replies, a
        stall, a reconnect), firings between them may be missing from the log: the event
        (at the last good reply, detail ``until T``) says where.
        """
        if self._recovering:
            # replies while reconnecting do not end the outage (CT/CONF_SN restart the firing
            # cycle, so two replies less than a cycle apart can miss a firing), but their
            # readings are logged: remember how far the outage reaches, for a run that ends
            # before the link is back
            self._outage_end = now if self._outage_end is None else max(self._outage_end, now)
            return
        prev, self._last_reply_t = self._last_reply_t, now
        if self.recording and prev is not None and now - prev > self.gap_s:
            self.sink.event(
                "gap", f"until {now:.6f}: {now - prev:.3f} s without a good reply", prev
            )

    def _note_late(self, t: np.ndarray) -> None:
        """Record a ``gap`` over readings the time order dropped (fired at UNIX times ``t``).

        They cannot be logged without breaking the sorted ``t`` of the log, so the log says
        which firings are missing, like any other outage.
        """
        if self.recording and len(t):
            lo, hi = float(t.min()), float(t.max())
            self.sink.event("gap", f"until {hi:.6f}: {len(t)} out-of-order readings dropped", lo)

    def drain(self) -> None:
        """Queue the readings still held for time ordering (the run is ending).

        An outage still open (the run stopped while reconnecting) is recorded as a ``gap``
        up to the last reply whose readings were logged: no later reply will close it.
        """
        prev, end = self._last_reply_t, self._outage_end
        if self._recovering and self.recording and prev is not None and end is not None:
            if end > prev:
                self.sink.event(
                    "gap", f"until {end:.6f}: {end - prev:.3f} s in an outage at the end", prev
                )
            self._outage_end = None
        self.sink.readings(self.order.drain())
        if self.order.late:
            self.sink.event("late", f"{self.order.late} out-of-order readings dropped")

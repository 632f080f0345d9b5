"""The acquisition loop: the only code that talks to the robot while a plan runs.

:class:`Acquisition` owns the :class:`nomad200.Client`. Every reply the robot sends is a
state packet; each one (polls and motion commands alike) goes through
:class:`sonard.tagging.Tagger`, and the new readings and the pose are queued on the
:class:`sonard.writer_thread.LogSink` (never written here, so a slow disk never stalls the
serial line).

Pacing: polls (GS) go out every ``max(firing interval, line time of one poll)``: the line
time follows from the mask (:func:`sonard.link.poll_seconds`), and a poll per firing
interval sees every firing. The wait between polls is a wait on the stop event, so SIGTERM
is noticed at once.

Faults: a garbled or missing poll reply is skipped (the next poll sees the same readings).
When no good reply arrived for ``LINK_LOST_S`` or the port went away, the loop records a
``fault`` event, sends ST if it can, and reconnects with exponential backoff (0.1 s doubling
to 2 s) until ``fault_timeout_s`` has passed; then it records ``reconnect`` and raises
:class:`Resume` so the current step restarts from its recorded progress, or records
``abort`` and raises :class:`FaultAbort`.
"""

from __future__ import annotations

import logging
import termios
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np
from serial import SerialException

from nomad200 import NomadDisconnected, NomadError
from sonard.link import poll_seconds
from sonard.notify import Notifier
from sonard.ordering import TimeOrder
from sonard.plan import Plan
from sonard.tagging import Tagger
from sonard.writer_thread import LogSink

__all__ = ["Acquisition", "FaultAbort", "Resume", "Stopped"]

log = logging.getLogger(__name__)

#: no good reply for this long (s) means the link is lost
LINK_LOST_S = 1.0
#: errors that mean the port went away (the driver may let a raw termios/OS error through)
LINK_ERRORS = (NomadDisconnected, OSError, termios.error, SerialException)


def is_link_error(exc: BaseException) -> bool:
    """Whether ``exc`` means the port went away, rather than one exchange failing.

    ``NomadTimeout`` is a ``TimeoutError`` and so an ``OSError``, but a missing reply is the
    line's fault, not the port's: it is retried, and only a link silent for longer than
    :data:`LINK_LOST_S` is treated as lost.
    """
    if isinstance(exc, NomadError):
        return isinstance(exc, NomadDisconnected)
    return isinstance(exc, LINK_ERRORS)


#: attempts for a configuration command on a noisy line
CONFIG_TRIES = 20
#: motor status bits: translating, steering, turret
MOVING = 0b111


class Resume(Exception):
    """The link came back after a fault: restart the current step from its progress."""


class Stopped(Exception):
    """A stop was requested (SIGTERM/SIGINT)."""


class FaultAbort(RuntimeError):
    """The link stayed down longer than the fault timeout."""


class ClientLike(Protocol):
    """The :class:`nomad200.Client` methods the daemon uses (SI units)."""

    def open(self) -> None: ...
    def close(self) -> None: ...
    def get_state(self) -> Any: ...
    def stop(self) -> Any: ...
    def configure_mask(self, mask: Any) -> Any: ...
    def configure_sonars(self, order: list[int], interval_s: float) -> Any: ...
    def configure_watchdog(self, seconds: int) -> Any: ...


class Acquisition:
    """Run the serial side of a plan: configure, poll, command, tag, queue.

    Parameters
    ----------
    client : ClientLike
        An unopened or open :class:`nomad200.Client`.
    plan : Plan
        The validated plan (sonars, interval, baud, attachments, fault timeout).
    sink : LogSink
        Where readings, poses and events go.
    stop : threading.Event
        Set by the signal handlers; every wait returns early when it is set.
    notifier : Notifier, optional
        systemd notifications (watchdog pings from the loop).
    fault_timeout_s : float, optional
        Overrides the plan's ``fault_timeout_s``.
    mask_factory : callable, optional
        Builds the CT mask from (sonars, attachments); defaults to :class:`nomad200.StateMask`.
    """

    def __init__(
        self,
        client: Any,
        plan: Plan,
        sink: LogSink,
        *,
        stop: threading.Event,
        notifier: Notifier | None = None,
        fault_timeout_s: float | None = None,
        mask_factory: Callable[[list[int], bool], Any] | None = None,
    ) -> None:
        self.client = client
        self.plan = plan
        self.sink = sink
        self.stop_event = stop
        self.notifier = notifier or Notifier(env={})
        self.fault_timeout_s = plan.fault_timeout_s if fault_timeout_s is None else fault_timeout_s
        self._mask_factory = mask_factory or _default_mask
        self.tagger = Tagger(
            plan.sonars,
            speed_of_sound=plan.speed_of_sound,
            interval=plan.interval,
            attachments=plan.use_attachments,
        )
        self.gap_s = max(len(plan.sonars) - 1, 1) * plan.interval
        self._last_reply_t: float | None = None
        self._recovering = False
        # two firing intervals: the latest a reply can report a firing (see sonard.ordering)
        self.order = TimeOrder(hold=2.0 * plan.interval)
        self.poll_period = max(
            plan.interval, poll_seconds(len(plan.sonars), plan.use_attachments, plan.baud)
        )
        self.state: Any = None
        self.latest: np.ndarray = np.zeros(0)  # readings of the last state fed
        self._next_poll = 0.0
        self._last_good = time.monotonic()
        self.n_faults = 0
        self.n_rejected = 0
        #: readings and poses are logged only once the plan's frame is set (see run_plan)
        self.recording = False
        self._frame_clock = -float("inf")
        #: True when the robot clock runs ahead of real time (emulator --fast): no pacing
        self.virtual_time = False
        self._fast_votes = 0

    # -- life cycle -------------------------------------------------------------------
    def start(self) -> None:
        """Open the port if needed and configure mask, sonars and motion watchdog."""
        if not getattr(self.client, "is_open", False):
            self.client.open()
        self._configure()

    def _configure(self) -> None:
        p = self.plan
        mask = self._mask_factory(list(p.sonars), p.use_attachments)
        self.feed(self._retry(self.client.configure_mask, mask))
        self.feed(
            self._retry(self.client.configure_sonars, order=list(p.sonars), interval_s=p.interval)
        )
        self.feed(self._retry(self.client.configure_watchdog, seconds=p.watchdog))
        self._last_good = time.monotonic()

    def _retry(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
        """Call an idempotent client method, retrying damaged or missing replies."""
        for i in range(CONFIG_TRIES):
            try:
                return fn(*args, **kwargs)
            except NomadError as exc:
                if is_link_error(exc) or i == CONFIG_TRIES - 1:
                    raise
                log.debug("%s failed (%d/%d): %s", fn.__name__, i + 1, CONFIG_TRIES, exc)
                self.check_stop()
        raise AssertionError("unreachable")

    def _note_gap(self, now: float) -> None:
        """Record a ``gap`` event when good replies were too far apart to see every firing.

        A reply shows each sonar's latest firing only; replies closer than one firing cycle
        minus one interval cannot miss one. Further apart (garbled or lost replies, a
        stall, a reconnect), firings between them may be missing from the log: the event
        (at the last good reply, detail ``until T``) says where.
        """
        if self._recovering:
            return  # replies while reconnecting do not end the outage: CT/CONF_SN reset firing
        prev, self._last_reply_t = self._last_reply_t, now
        if self.recording and prev is not None and now - prev > self.gap_s:
            self.sink.event(
                "gap", f"until {now:.6f}: {now - prev:.3f} s without a good reply", prev
            )

    def drain(self) -> None:
        """Queue the readings still held for time ordering (the run is ending)."""
        self.sink.readings(self.order.drain())
        if self.order.late:
            self.sink.event("late", f"{self.order.late} out-of-order readings dropped")

    def stop_robot(self) -> bool:
        """Send ST (best effort: the client retries once); return whether it was answered."""
        try:
            self.feed(self.client.stop())
        except Exception as exc:
            log.debug("ST failed: %s", exc)
            return False
        return True

    # -- feeding ----------------------------------------------------------------------
    def feed(self, state: Any) -> Any:
        """Tag a state reply, queue its readings and pose, and remember it."""
        if state is None:
            return None
        if not self.tagger.plausible(state):
            self.n_rejected += 1
            log.debug("implausible reply dropped (clock %.3f)", state.clock)
            return None
        offset = self.tagger.offset
        rows, pose = self.tagger.feed(state, time.time())
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
        self.latest = rows
        self.state = state
        self._last_good = time.monotonic()
        self.notifier.watchdog()
        return state

    def check_stop(self) -> None:
        """Raise :class:`Stopped` when a stop was requested."""
        if self.stop_event.is_set():
            raise Stopped

    # -- robot commands (typed; every reply is a state and is fed like a poll) -------------
    def set_speed(self, trans: float, steer: float, turret: float) -> Any:
        """SP: speed limits of later moves (m/s, rad/s, rad/s); safe to repeat."""
        return self._send(self.client.set_speed, trans, steer, turret)

    def move_relative(self, trans: float, steer: float, turret: float) -> Any:
        """PR: move by (m, rad, rad); re-sent only when the robot refused it (NAK)."""
        return self._send(self.client.move_relative, trans, steer, turret, idempotent=False)

    def move_velocity(self, v: float, w_steer: float, w_turret: float) -> Any:
        """VM: drive at (m/s, rad/s, rad/s) until the next command; safe to repeat."""
        return self._send(self.client.move_velocity, v, w_steer, w_turret)

    def stop(self) -> Any:
        """ST: stop every motor; safe to repeat."""
        return self._send(self.client.stop)

    def zero(self) -> Any:
        """ZR: zero the odometry frame; not repeated once the robot may have run it."""
        return self._send(self.client.zero, idempotent=False, new_frame=True)

    def define_position(self, x: float, y: float) -> Any:
        """DP: declare the robot position (m); starts a new odometry frame."""
        return self._send(self.client.define_position, x, y, new_frame=True)

    def define_angles(self, steer: float, turret: float) -> Any:
        """DA: declare base and turret headings (rad); starts a new odometry frame."""
        return self._send(self.client.define_angles, steer, turret, new_frame=True)

    def _send(
        self,
        fn: Callable[..., Any],
        *args: float,
        idempotent: bool = True,
        new_frame: bool = False,
    ) -> Any:
        """Call a client command and feed its reply; return the state, or None.

        A timeout or garbled reply is retried when ``idempotent`` (twice). A command that
        is not idempotent is re-sent only when the robot refused it (NAK: it did nothing),
        otherwise this returns None (the caller's closed loop checks the outcome on the next
        poll). A lost link goes through :meth:`recover`. A ``new_frame`` command's reply
        starts the logging: readings fired before it are in the old frame and dropped.
        """
        self.check_stop()
        tries = 3
        for i in range(tries):
            try:
                reply = fn(*args)
                if new_frame and reply is not None:
                    self.tagger.forget_pose()
                    self._frame_clock = reply.clock
                    self.recording = True
                return self.feed(reply)
            except NomadError as exc:
                if is_link_error(exc):
                    self.recover(exc)
                log.debug("%s failed (%d/%d): %s", fn.__name__, i + 1, tries, exc)
                if time.monotonic() - self._last_good > LINK_LOST_S:
                    self.recover(exc)
                self.check_stop()
                if not idempotent and exc.executed is not False:
                    return None  # the robot may have run it: do not run it twice
            except LINK_ERRORS as exc:
                self.recover(exc)
        return None

    def poll(self) -> Any:
        """Wait for the next poll slot, then GS; returns the newest state (maybe an older one)."""
        now = time.monotonic()
        wait = self._next_poll - now
        if not self.virtual_time and wait > 0 and self.stop_event.wait(wait):
            raise Stopped
        self.check_stop()
        self._next_poll = max(self._next_poll + self.poll_period, time.monotonic())
        before = self.state.clock if self.state is not None else None
        host = time.monotonic()
        try:
            if self.feed(self.client.get_state()) is not None and before is not None:
                self._learn_clock_rate(self.state.clock - before, time.monotonic() - host)
        except NomadError as exc:
            log.debug("poll failed: %s", exc)
            if is_link_error(exc) or time.monotonic() - self._last_good > LINK_LOST_S:
                self.recover(exc)
        except LINK_ERRORS as exc:
            self.recover(exc)
        return self.state

    def _learn_clock_rate(self, d_robot: float, d_host: float) -> None:
        """Detect a robot clock that runs ahead of real time (an emulator in fast mode).

        Such a clock only moves with the bytes exchanged, so waiting between polls would
        only slow the run down: polls then go back to back.
        """
        fast = d_robot > 0.005 and d_robot > 3.0 * d_host
        self._fast_votes = min(5, self._fast_votes + 1) if fast else max(0, self._fast_votes - 1)
        virtual = self._fast_votes >= 3
        if virtual != self.virtual_time:
            log.info("robot clock %s real time", "runs ahead of" if virtual else "follows")
            self.virtual_time = virtual

    def wait_robot_time(self, seconds: float) -> None:
        """Poll until the robot clock advanced by ``seconds`` (fast emulators run it faster)."""
        start = self.poll().clock
        guard = time.monotonic() + seconds + 5.0
        while self.state.clock - start < seconds:
            self.poll()
            if time.monotonic() > guard:  # a stalled robot clock must not hang the plan
                log.warning("robot clock stalled at %.3f s", self.state.clock)
                return

    def moving(self) -> bool:
        """Whether the last state shows any motor moving."""
        return bool(self.state is not None and self.state.motor_status & MOVING)

    # -- faults -----------------------------------------------------------------------
    def recover(self, exc: BaseException) -> None:
        """Stop the robot, reconnect with backoff, then raise Resume (or FaultAbort)."""
        self.n_faults += 1
        self._recovering = True
        detail = f"{type(exc).__name__}: {exc}"[:200]
        log.warning("link fault: %s", detail)
        self.sink.event("fault", detail)
        self.notifier.status(f"link fault: {detail}")
        if not is_link_error(exc) and self.stop_robot() and self._reconfigure():
            self._resumed("noisy link")  # the robot answers again: the line was only noisy
        deadline = time.monotonic() + self.fault_timeout_s
        delay = 0.1
        while True:
            self.notifier.watchdog()
            self.check_stop()
            try:
                self.client.close()
            except Exception as close_exc:
                log.debug("close failed: %s", close_exc)
            try:
                self.client.open()
            except Exception as open_exc:
                log.info("reconnect failed: %s", open_exc)
            else:
                if self.stop_robot() and self._reconfigure():
                    self._resumed("reconnected")
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                self.sink.event("abort", f"link down longer than {self.fault_timeout_s:g} s")
                raise FaultAbort(
                    f"link down longer than {self.fault_timeout_s:g} s ({detail})"
                ) from exc
            if self.stop_event.wait(min(delay, remaining)):
                raise Stopped from exc
            delay = min(delay * 2, 2.0)

    def _reconfigure(self) -> bool:
        try:
            self._configure()
        except Exception as exc:
            log.info("reconfigure failed: %s", exc)
            return False
        return True

    def _resumed(self, why: str) -> None:
        self._recovering = False  # the next poll closes the gap the fault opened
        self.tagger.forget_pose()
        log.info("link back (%s); resuming", why)
        self.sink.event("reconnect", why)
        self.notifier.status("running")
        self._next_poll = 0.0
        raise Resume


def _default_mask(sonars: list[int], attachments: bool) -> Any:
    from nomad200 import StateMask

    return StateMask(sonars=frozenset(sonars), pose=True, sonar_pose_attachment=attachments)

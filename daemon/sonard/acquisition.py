"""The acquisition loop: the only code that talks to the robot while a plan runs.

:class:`Acquisition` owns the :class:`nomad200.Client`. Every reply the robot sends is a
state packet; each one (polls and motion commands alike) goes through
:class:`sonard.recording.ReplyRecorder`, which tags it and queues the new readings and the
pose on the :class:`sonard.writer_thread.LogSink` (never written here, so a slow disk
never stalls the serial line).

Pacing: polls (GS) go out every ``max(firing interval, line time of one poll)``: the line
time follows from the mask (:func:`sonard.link.poll_seconds`), and a poll per firing
interval sees every firing. The wait between polls is a wait on the stop event, so SIGTERM
is noticed at once.

Faults: a garbled or missing poll reply is skipped (the next poll sees the same readings).
When no good reply arrived for ``LINK_LOST_S`` or the port went away, the loop records a
``fault`` event, sends ST if it can, and reconnects with exponential backoff (0.1 s doubling
to 2 s, :func:`sonard.link_faults.reconnect`) until ``fault_timeout_s`` has passed; then it
records ``reconnect`` and raises
:class:`Resume` so the current step restarts from its recorded progress, or records
``abort`` and raises :class:`FaultAbort`.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any, Protocol

import numpy as np

from nomad200 import NomadError
from sonard.link import poll_seconds
from sonard.link_faults import (
    LINK_ERRORS,
    LINK_LOST_S,
    FaultAbort,
    Resume,
    Stopped,
    is_link_error,
    reconnect,
)
from sonard.logclock import CLOCK_STEP_S
from sonard.notify import Notifier
from sonard.plan import Plan
from sonard.recording import ReplyRecorder
from sonard.writer_thread import LogSink

__all__ = ["Acquisition", "FaultAbort", "Resume", "Stopped"]

log = logging.getLogger(__name__)

#: attempts for a configuration command on a noisy line
CONFIG_TRIES = 20
#: motor status bits: translating, steering, turret
MOVING = 0b111
#: replies in a row whose robot clock stands still before a robot-time wait gives up (a
#: real robot's millisecond clock moves between two replies: each takes > 1 ms on the line)
FROZEN_CLOCK_REPLIES = 200


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
        self.recorder = ReplyRecorder(plan, sink)
        self.poll_period = max(
            plan.interval, poll_seconds(len(plan.sonars), plan.use_attachments, plan.baud)
        )
        self.state: Any = None
        self.latest: np.ndarray = np.zeros(0)  # readings of the last state fed
        self._next_poll = 0.0
        self._last_good = time.monotonic()
        self.n_faults = 0
        #: the log's UNIX time (never jumps with the system clock, see sonard.logclock)
        self.clock: Callable[[], float] = getattr(sink, "clock", time.time)
        self._wall_step = self._system_clock_step()
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

    @property
    def recording(self) -> bool:
        """Whether readings and poses are logged (once the plan's frame is set, see run_plan)."""
        return self.recorder.recording

    @recording.setter
    def recording(self, value: bool) -> None:
        self.recorder.recording = value

    def drain(self) -> None:
        """Queue the readings still held for time ordering (the run is ending)."""
        self.recorder.drain()

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
        rows = self.recorder.record(state, self.clock())
        if rows is None:
            return None
        self.latest = rows
        self.state = state
        self._last_good = time.monotonic()
        self.notifier.watchdog()
        return state

    def check_stop(self) -> None:
        """Raise :class:`Stopped` when a stop was requested, LogWriteError when the log failed.

        A log that cannot be written (the disk is full) ends the run at once: every later
        reading would be lost, and the log is closed while it still can be.
        """
        if self.stop_event.is_set():
            raise Stopped
        check = getattr(self.sink, "check", None)
        if check is not None:
            check()

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
                    self.recorder.start_frame(reply.clock)
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
        self._note_clock_step()
        return self.state

    def _system_clock_step(self) -> float:
        step = getattr(self.clock, "step", None)
        return float(step()) if step is not None else 0.0

    def _note_clock_step(self) -> None:
        """Record a ``clock_step`` event when the system clock was stepped since the last poll.

        The log's times follow the robot's clock and the monotonic clock, so nothing in the
        log moves; the event says by how much the wall clock now differs from ``t``.
        """
        step = self._system_clock_step()
        if abs(step - self._wall_step) > CLOCK_STEP_S:
            d, self._wall_step = step - self._wall_step, step
            log.warning("system clock stepped by %+.3f s; the log keeps the robot's time", d)
            self.sink.event(
                "clock_step",
                f"system clock stepped by {d:+.3f} s (now {step:+.3f} s from t); "
                "t follows the robot clock",
            )

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
        """Poll until the robot clock advanced by ``seconds`` (fast emulators run it faster).

        Robot time only: a host slowed by other work polls less often but waits the same
        robot time. A clock that stands still for ``FROZEN_CLOCK_REPLIES`` replies in a row
        (no real robot's does) ends the wait with a warning rather than hanging the plan.
        """
        start = last = self.poll().clock
        frozen = 0
        while self.state.clock - start < seconds:
            self.poll()
            frozen = frozen + 1 if self.state.clock <= last else 0
            last = self.state.clock
            if frozen >= FROZEN_CLOCK_REPLIES:
                log.warning("robot clock stalled at %.3f s", self.state.clock)
                return

    def moving(self) -> bool:
        """Whether the last state shows any motor moving."""
        return bool(self.state is not None and self.state.motor_status & MOVING)

    # -- faults -----------------------------------------------------------------------
    def recover(self, exc: BaseException) -> None:
        """Stop the robot, reconnect with backoff, then raise Resume (or FaultAbort)."""
        self.n_faults += 1
        self.recorder.link_lost()
        detail = f"{type(exc).__name__}: {exc}"[:200]
        log.warning("link fault: %s", detail)
        self.sink.event("fault", detail)
        self.notifier.status(f"link fault: {detail}")
        if not is_link_error(exc) and self.stop_robot() and self._reconfigure():
            self._resumed("noisy link")  # the robot answers again: the line was only noisy
        if reconnect(
            self.client,
            restart=lambda: self.stop_robot() and self._reconfigure(),
            stop=self.stop_event,
            timeout_s=self.fault_timeout_s,
            ping=self.notifier.watchdog,
            cause=exc,
        ):
            self._resumed("reconnected")
        self.sink.event("abort", f"link down longer than {self.fault_timeout_s:g} s")
        raise FaultAbort(f"link down longer than {self.fault_timeout_s:g} s ({detail})") from exc

    def _reconfigure(self) -> bool:
        try:
            self._configure()
        except Exception as exc:
            log.info("reconfigure failed: %s", exc)
            return False
        return True

    def _resumed(self, why: str) -> None:
        self.recorder.link_back()
        log.info("link back (%s); resuming", why)
        self.sink.event("reconnect", why)
        self.notifier.status("running")
        self._next_poll = 0.0
        raise Resume


def _default_mask(sonars: list[int], attachments: bool) -> Any:
    from nomad200 import StateMask

    return StateMask(sonars=frozenset(sonars), pose=True, sonar_pose_attachment=attachments)

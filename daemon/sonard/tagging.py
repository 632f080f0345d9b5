"""Turn state replies into pose-tagged, SI sonar readings.

Every state reply holds the latest range of each masked sonar. :class:`Tagger` keeps what
it saw last and emits a reading only for a **new firing**, tagged with the robot pose and
the time of that firing.

With pose attachments (the default when the link is fast enough): each sonar's attachment
carries the pose, the pose's timestamp (the firing) and the reading's timestamp (the echo);
a changed reading timestamp means a new firing, the reading's time is the pose timestamp,
and the pose is exact to the protocol's resolution (0.1 in, 0.1 deg). A sonar that fired
twice between two polls shows only its last firing: the plan refuses a baud rate whose
poll takes longer than a firing cycle, so that does not happen.

Without attachments: a sonar counts as fired again when its range changed, or when a whole
firing cycle (``len(sonars) * interval``) has passed since its last accepted reading. Its
firing time is taken as the middle of the window in which it must have fired,
``(max(t_prev_poll, t_now - cycle), t_now]``, and the pose is interpolated linearly between
the two polls (angles unwrapped). The window is at most one poll period ``w`` long (the
loop polls every firing interval), so the time error is at most ``w/2`` and the pose error
at most ``v * w / 2`` in position and ``omega * w / 2`` in angle: 2 mm and 0.3 deg for
0.1 m/s, 30 deg/s and a 40 ms poll. Standing still the pose is exact. A sonar reading the
same range twice within one cycle is logged once.

Conversion to SI: ranges arrive in metres from the transducer face (the driver converts
inches); the sensors table places each transducer at its face, so
``tof = 2 * range / speed_of_sound`` with no offset. A missing echo (255 on the wire,
``None`` from the driver) is logged with ``flags = FLAG_NO_ECHO`` and ``tof = NaN``; so is
a range below the 0.15 m usable minimum (bit 0 means "out of range" too), keeping its tof.
Times are UNIX seconds: robot clock + an offset fixed at the first reply (re-anchored if
the robot clock ever runs backwards, i.e. the robot was reset).

A reply whose clock runs ahead of the host's is damaged (two bytes that cancel out in the
byte-sum checksum): a robot builds a reply before the host reads it, so in link time its
clock, mapped to UNIX time through the least host-minus-robot lag seen, is never ahead of
the host's. It is dropped, not believed: believing it would log a bogus gap, refuse the
good replies after it as running backwards, and re-anchor the offset.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from sonard.ring import MIN_RANGE
from sonarlog import FLAG_NO_ECHO, POSE_DTYPE, READING_DTYPE

__all__ = ["StateLike", "Tagger", "to_tof"]

#: faster than the robot can move (m/s), for the plausibility check
MAX_SPEED = 1.0
POSE_SLACK_M = 0.01
#: largest believable gap between two replies' clocks (s)
MAX_CLOCK_LEAP_S = 120.0
#: after this many refused replies in a row the next one is believed
MAX_REJECTS_IN_ROW = 10
#: how far a reply's clock may run ahead of the host's clock, beyond one firing cycle (s).
#: In link time it runs ahead by no more than the fastest reply's latency (ms) plus the
#: clocks' drift since (100 ppm: 0.1 ms/s). A fast emulator's virtual clock runs ahead by
#: the link time of the exchanges since the last good reply: a poll (at most one firing
#: cycle, the plan's limit on the baud rate) plus 0.5 s (the reply timeout) for each lost
#: reply; 1 s covers two lost replies. A damaged clock byte moves it by 0.256 s or 65.5 s
#: steps (times the damage): the second byte from 8 steps up, any higher byte always.
MAX_CLOCK_LEAD_S = 1.0


class AttachmentLike(Protocol):
    """The part of :class:`nomad200.PoseAttachment` used here (SI units)."""

    x: float
    y: float
    steer: float
    turret: float
    pose_time: float
    reading_time: float


class StateLike(Protocol):
    """The part of :class:`nomad200.State` used here (SI units; None when not masked)."""

    x: float | None
    y: float | None
    steer: float | None
    turret: float | None
    clock: float
    sonar: Mapping[int, float | None]
    sonar_attachments: Mapping[int, Any]


def to_tof(
    ranges: np.ndarray, speed_of_sound: float, min_range: float = MIN_RANGE
) -> tuple[np.ndarray, np.ndarray]:
    """Convert face ranges (m, NaN = no echo) to round-trip times of flight and flags.

    Parameters
    ----------
    ranges : ndarray
        Ranges in metres from the transducer face; NaN for no echo.
    speed_of_sound : float
        m/s.
    min_range : float
        Ranges below this are flagged out of range (their tof is kept).

    Returns
    -------
    tof : ndarray
        Seconds; NaN for no echo.
    flags : ndarray of uint16
        FLAG_NO_ECHO where there was no echo or the range is below ``min_range``.

    Examples
    --------
    >>> tof, flags = to_tof(np.array([1.7165, np.nan, 0.1]), 343.3)
    >>> tof.round(4).tolist()[0], flags.tolist()
    (0.01, [0, 1, 1])
    """
    r = np.asarray(ranges, dtype=float)
    tof = 2.0 * r / speed_of_sound
    bad = ~np.isfinite(r) | (r < min_range)
    return tof, np.where(bad, FLAG_NO_ECHO, 0).astype(np.uint16)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


class Tagger:
    """Detect new firings in successive states and tag them (see module docstring).

    Parameters
    ----------
    sonars : sequence of int
        The active sonars (firing order).
    speed_of_sound : float
        m/s.
    interval : float
        Firing interval (s), for the no-attachment cycle rule.
    attachments : bool
        Whether states carry sonar pose attachments.
    """

    def __init__(
        self,
        sonars: Sequence[int],
        *,
        speed_of_sound: float,
        interval: float,
        attachments: bool,
    ) -> None:
        self.sonars = np.asarray(list(sonars), dtype=np.int16)
        self.c = float(speed_of_sound)
        self.cycle = len(self.sonars) * float(interval)
        self.attachments = attachments
        self.offset: float | None = None
        self._last_clock: float | None = None
        self._prev_pose: np.ndarray | None = None  # (clock, x, y, theta, turret)
        n = len(self.sonars)
        self._last_stamp = np.full(n, np.nan)  # attachment reading time or accept clock
        self._last_range = np.full(n, np.nan)
        self._seen = np.zeros(n, dtype=bool)
        self._rejects = 0
        #: least (host time - robot clock) of the replies believed: the reply with the least
        #: latency; None until a reply after the start or an outage sets it
        self._host_lag: float | None = None

    def plausible(self, state: StateLike, host_time: float | None = None) -> bool:
        """Whether ``state`` fits the last accepted one (a guard against corrupt replies).

        The protocol's checksum is a byte sum: two damaged bytes can cancel out. A reply is
        refused when its clock runs backwards by less than a reset would (or leaps more than
        ``MAX_CLOCK_LEAP_S``), when the pose moved faster than the robot can, when a pose
        attachment lies outside the last firing cycle before the reply, or, given the UNIX
        time ``host_time`` it arrived at, when its clock runs ahead of the host's (see
        :meth:`clock_runs_ahead`).
        """
        ok = not self.clock_runs_ahead(state, host_time) and self._plausible(state)
        self._rejects = 0 if ok else self._rejects + 1
        if self._rejects > MAX_REJECTS_IN_ROW:  # the robot really changed: follow it
            self.forget_pose()
            self.forget_host_lag()
            ok, self._rejects = True, 0
        return ok

    def clock_runs_ahead(self, state: StateLike, host_time: float | None) -> bool:
        """Whether the clock of ``state``, received at UNIX ``host_time``, is damaged.

        It is when it runs ahead of the host's clock (through the least lag seen) by more
        than ``MAX_CLOCK_LEAD_S`` plus one firing cycle, and no pose attachment vouches for
        it: the robot fires a sonar every interval, so a clock that really moved on comes
        with a firing at most two firing cycles (one to fire, one to report it) before it.
        """
        if host_time is None or self._host_lag is None:
            return False
        clock = float(state.clock)
        if clock + self._host_lag - host_time <= MAX_CLOCK_LEAD_S + self.cycle:
            return False
        fired = [a.pose_time for a in state.sonar_attachments.values() if a.pose_time > 0]
        return not fired or clock - max(fired) > 2.0 * self.cycle

    def forget_host_lag(self) -> None:
        """Learn the host-minus-robot lag anew from the next reply (after an outage)."""
        self._host_lag = None

    def forget_pose(self) -> None:
        """Drop the reference for :meth:`plausible` (after DP, DA, ZR or a reconnect)."""
        self._prev_pose = None

    def _plausible(self, state: StateLike) -> bool:
        clock = float(state.clock)
        last = self._prev_pose
        if last is None or state.x is None or state.y is None:
            return True
        dt = clock - last[0]
        if dt < 0 or dt > MAX_CLOCK_LEAP_S:
            return False
        reach = MAX_SPEED * dt + POSE_SLACK_M
        if math.hypot(state.x - last[1], state.y - last[2]) > reach:
            return False
        for a in state.sonar_attachments.values():
            if a.pose_time == 0 and a.reading_time == 0:
                continue
            age = clock - a.pose_time
            if not -0.001 <= age <= self.cycle + MAX_CLOCK_LEAP_S:
                return False
            if math.hypot(a.x - state.x, a.y - state.y) > MAX_SPEED * age + POSE_SLACK_M:
                return False
        return True

    def time_of(self, clock: float) -> float:
        """UNIX time of a robot clock value (after the first state)."""
        return (self.offset or 0.0) + clock

    def feed(self, state: StateLike, host_time: float) -> tuple[np.ndarray, np.ndarray]:
        """Return (new readings, one pose row) for ``state`` received at ``host_time``.

        Parameters
        ----------
        state : StateLike
            A state reply with pose and the active sonars masked.
        host_time : float
            UNIX time the reply arrived.

        Returns
        -------
        readings : ndarray of READING_DTYPE
        pose : ndarray of POSE_DTYPE, one row (empty if the state has no pose)
        """
        clock = float(state.clock)
        if self.offset is None or (self._last_clock is not None and clock < self._last_clock):
            self.offset = host_time - clock
            self._prev_pose = None
            self._host_lag = None
        self._last_clock = clock
        lag = host_time - clock
        self._host_lag = lag if self._host_lag is None else min(self._host_lag, lag)
        if state.x is None or state.y is None or state.steer is None or state.turret is None:
            return np.zeros(0, READING_DTYPE), np.zeros(0, POSE_DTYPE)
        cur = np.array([clock, state.x, state.y, state.steer, state.turret], dtype=float)
        pose = np.zeros(1, POSE_DTYPE)
        pose["t"] = self.offset + clock
        pose["x"], pose["y"], pose["theta"], pose["turret"] = cur[1:]
        ranges = np.array(
            [np.nan if (r := state.sonar.get(int(s))) is None else r for s in self.sonars]
        )
        if self.attachments:
            rows = self._with_attachments(state, ranges)
        else:
            rows = self._interpolated(cur, ranges)
        self._prev_pose = cur
        return rows, pose

    def _emit(
        self, idx: np.ndarray, ranges: np.ndarray, clocks: np.ndarray, poses: np.ndarray
    ) -> np.ndarray:
        out = np.zeros(len(idx), READING_DTYPE)
        out["t"] = (self.offset or 0.0) + clocks
        out["tx"] = out["rx"] = self.sonars[idx]
        out["tof"], out["flags"] = to_tof(ranges[idx], self.c)
        out["x"], out["y"], out["theta"], out["turret"] = poses.T
        return out

    def _with_attachments(self, state: StateLike, ranges: np.ndarray) -> np.ndarray:
        atts = state.sonar_attachments
        got = [
            (i, a)
            for i, s in enumerate(self.sonars)
            if (a := atts.get(int(s))) is not None and (a.reading_time > 0 or a.pose_time > 0)
        ]  # an all-zero attachment: that sonar has not fired since power-on
        if not got:
            return np.zeros(0, READING_DTYPE)
        idx = np.array([i for i, _ in got])
        vals = np.array(
            [(a.reading_time, a.pose_time, a.x, a.y, a.steer, a.turret) for _, a in got],
            dtype=float,
        )
        stamp = vals[:, 0]
        new = ~self._seen[idx] | (stamp != self._last_stamp[idx])
        self._seen[idx] = True
        self._last_stamp[idx] = stamp
        return self._emit(idx[new], ranges, vals[new, 1], vals[new, 2:])

    def _interpolated(self, cur: np.ndarray, ranges: np.ndarray) -> np.ndarray:
        clock = cur[0]
        same = (ranges == self._last_range) | (np.isnan(ranges) & np.isnan(self._last_range))
        aged = clock - self._last_stamp >= self.cycle - 1e-9
        new = ~self._seen | ~same | aged
        idx = np.flatnonzero(new)
        self._seen[:] = True
        self._last_range = ranges
        prev = self._prev_pose
        if prev is None or clock <= prev[0]:
            self._last_stamp[idx] = clock
            poses = np.repeat(cur[None, 1:], len(idx), axis=0)
            return self._emit(idx, ranges, np.full(len(idx), clock), poses)
        lo = max(prev[0], clock - self.cycle)
        t_fire = 0.5 * (lo + clock)
        self._last_stamp[idx] = t_fire
        f = (t_fire - prev[0]) / (clock - prev[0])
        d = cur[1:] - prev[1:]
        d[2:] = _wrap(d[2:])
        p = prev[1:] + f * d
        poses = np.repeat(p[None, :], len(idx), axis=0)
        return self._emit(idx, ranges, np.full(len(idx), t_fire), poses)

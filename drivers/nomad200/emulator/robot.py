"""The emulated robot between commands: its clock, drive, sonar firings and watchdog.

:class:`Robot` lives on its own clock (real monotonic time, or a
:class:`~nomad200.emulator.clock.VirtualClock`). :meth:`Robot.advance` runs it up to a
time: the axes move (:class:`~nomad200.emulator.motion.Drive`), the sonar ring fires in
the order and at the rate of :meth:`Robot.configure_sonars` (echoes from
:func:`~nomad200.emulator.sonar.simulate_firings`; a reading appears once its echo is in,
or its window closed), and the CONF_TM watchdog stops the motors when no command arrived
for ``watchdog_s`` (:meth:`Robot.command_received`). Everything it reports is in robot
units (:mod:`nomad200.state_types`). The host protocol on top of it, bytes in and bytes
out, is :class:`~nomad200.emulator.model.NomadModel`.
"""

from __future__ import annotations

import logging
import math
from typing import IO, Any

import numpy as np

from nomad200.emulator.clock import Clock, MonotonicClock
from nomad200.emulator.motion import Drive
from nomad200.emulator.sonar import EchoFn, simulate_firings
from nomad200.state_types import DEG10, IN10, NO_ECHO, RawAttachment

__all__ = ["Robot"]

logger = logging.getLogger(__name__)

_Firing = tuple[float, int, tuple[float, float, float, float], RawAttachment]


def _clip16(v: float) -> int:
    return max(-32767, min(32767, round(v)))


def _angle10(v: float) -> int:
    return round(v) % 3600


class Robot:
    """An emulated Nomad 200 between commands.

    Parameters
    ----------
    echo : EchoFn, optional
        Sonar path function (see :mod:`nomad200.emulator.sonar`); ``None`` = no echoes.
    start_pose : tuple of float
        TRUE world pose (x m, y m, theta rad) at power-on.
    start_turret : float, optional
        TRUE world turret heading at power-on (default: theta).
    clock : callable, optional
        Seconds, monotonic; defaults to real time.
    trace : text file, optional
        JSON lines: every command and every sonar firing with the TRUE pose.
    """

    def __init__(
        self,
        *,
        echo: EchoFn | None = None,
        start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        start_turret: float | None = None,
        clock: Clock | None = None,
        trace: IO[str] | None = None,
    ) -> None:
        self.clock: Clock = clock or MonotonicClock()
        self.echo = echo
        self.drive = Drive(start=start_pose, start_turret=start_turret)
        self.trace = trace
        self.t0 = self.clock()
        self.t = self.t0
        self.watchdog_s = 0
        self.last_cmd_t = self.t0
        self._watchdog_armed = False
        self.order: list[int] = []
        self.interval = 0.04
        self._next_fire = math.inf
        self._fire_k = 0
        self._prev_fire: tuple[float, int, np.ndarray, float] | None = None
        self.sonar_raw = [NO_ECHO] * 16
        self.sonar_att: list[RawAttachment] = [(0,) * 9] * 16
        self._pending_readings: list[tuple[int, int, int, RawAttachment]] = []

    # ------------------------------------------------------------ time
    def clock_ms(self, t: float | None = None) -> int:
        """The robot clock (ms since power-on) at time ``t`` (default: model time)."""
        return round(((self.t if t is None else t) - self.t0) * 1000.0) & 0xFFFFFFFF

    def advance(self, t: float | None = None) -> None:
        """Run the robot up to time ``t`` (default: the clock): motion, firings, watchdog."""
        t = self.clock() if t is None else t
        if t <= self.t:
            return
        fires: list[_Firing] = []
        while True:
            wd = (
                self.last_cmd_t + self.watchdog_s
                if self._watchdog_armed and self.watchdog_s
                else math.inf
            )
            nxt = min(t, self._next_fire, wd)
            self.drive.step(nxt - self.t)
            self.t = nxt
            if nxt == wd and wd <= t:
                logger.info("watchdog: no command for %d s, stopping", self.watchdog_s)
                for ax in self.drive.axes:
                    ax.stop()
                self._watchdog_armed = False
                self.emit({"type": "watchdog", "t": self.clock_ms() / 1000.0})
            if nxt == self._next_fire and nxt <= t:
                sid = self.order[self._fire_k % len(self.order)]
                fires.append((nxt, sid, self.drive.world_pose(), self.odometry_attachment(nxt)))
                self._fire_k += 1
                self._next_fire += self.interval
            if nxt >= t:
                break
        if fires:
            self._process_fires(fires)
        if self._pending_readings:
            now_ms = self.clock_ms()
            keep = []
            for rec in self._pending_readings:
                if rec[0] <= now_ms:
                    self.sonar_raw[rec[1]] = rec[2]
                    self.sonar_att[rec[1]] = rec[3]
                else:
                    keep.append(rec)
            self._pending_readings = keep

    def odometry_attachment(self, t: float) -> RawAttachment:
        """The pose attachment of a reading taken at time ``t``: odometry now, clock ``t``."""
        ms = self.clock_ms(t)
        return (*self.pose_words(), *self.velocity_words(), ms, ms)

    def _process_fires(self, fires: list[_Firing]) -> None:
        t = np.array([f[0] for f in fires])
        sid = np.array([f[1] for f in fires], dtype=np.int_)
        xy = np.array([(f[2][0], f[2][1]) for f in fires])
        tur = np.array([f[2][3] for f in fires])
        window = np.full(len(fires), self.interval)
        batch = simulate_firings(self.echo, t, sid, xy, tur, window, self._prev_fire)
        self._prev_fire = (float(t[-1]), int(sid[-1]), xy[-1].copy(), float(tur[-1]))
        for k, (tk, s, wp, att) in enumerate(fires):
            raw = int(batch.raw[k])
            tau = float(batch.tau[k])
            done = self.clock_ms(tk + (tau if math.isfinite(tau) else self.interval))
            # the reading exists once its echo is in (or its window closed)
            self._pending_readings.append((done, s, raw, (*att[:8], done)))
            if self.trace is not None:
                tr = float(batch.true_range[k])
                self.emit(
                    {
                        "type": "firing",
                        "t": self.clock_ms(tk) / 1000.0,
                        "sonar": s,
                        "raw": raw,
                        "range_m": None if raw == NO_ECHO else raw * 0.0254,
                        "echo_range_m": None if not math.isfinite(tau) else tau * 343.3 / 2,
                        "true_range_m": None if not math.isfinite(tr) else tr,
                        "crosstalk": bool(batch.crosstalk[k]),
                        "odom": {
                            "x": att[0] * IN10,
                            "y": att[1] * IN10,
                            "steer": att[2] * DEG10,
                            "turret": att[3] * DEG10,
                        },
                        "world": {"x": wp[0], "y": wp[1], "theta": wp[2], "turret": wp[3]},
                    }
                )

    def emit(self, rec: dict[str, Any]) -> None:
        """Write one trace record (no-op without a trace file)."""
        if self.trace is not None:
            import json

            self.trace.write(json.dumps(rec) + "\n")

    def command_received(self) -> None:
        """A command arrived now: the CONF_TM watchdog starts counting again."""
        self.last_cmd_t = self.t
        self._watchdog_armed = True

    def configure_sonars(self, rate: int, order: tuple[int, ...]) -> None:
        """CONF_SN: fire the sonars ``order`` (up to a 255) every ``rate`` 4 ms ticks."""
        ids: list[int] = []
        for o in order:
            if o == 255:
                break
            if not 0 <= o <= 15:
                raise ValueError(f"sonar id {o} in firing order")
            ids.append(o)
        if rate < 1:
            raise ValueError("sonar rate must be at least 1 (4 ms)")
        self.order = ids
        self.interval = rate * 0.004
        self._fire_k = 0
        self._prev_fire = None
        self._next_fire = self.t + self.interval if ids else math.inf

    # ------------------------------------------------------------ robot units
    def pose_words(self) -> tuple[int, int, int, int]:
        """Odometry x, y (1/10 in), steering and turret angle (1/10 deg, 0..3599)."""
        d = self.drive
        return _clip16(d.x), _clip16(d.y), _angle10(d.steer.pos), _angle10(d.turret.pos)

    def velocity_words(self) -> tuple[int, int, int]:
        """Translation (1/10 in/s), steering and turret velocities (1/10 deg/s)."""
        d = self.drive
        return _clip16(d.trans.vel), _clip16(d.steer.vel), _clip16(d.turret.vel)

"""The Nomad 200 device model: bytes in, bytes out, no transport.

:meth:`NomadModel.feed` takes the bytes the host sent and the (simulated) time they arrived
and returns the replies as ``(time ready, frame)`` pairs. Between commands the robot lives
on its own clock (its base class :class:`~nomad200.emulator.robot.Robot`): axes move, the
sonar ring fires in its configured order and rate, the CONF_TM watchdog stops the motors
when the host falls silent. Time comes from an injected clock (real monotonic time, or a
:class:`~nomad200.emulator.clock.VirtualClock`).

Host packets are parsed as the robot's firmware does (:class:`~nomad200.emulator.rx.HostParser`):
a damaged packet (bad checksum or end byte) and a refused one (a payload of the wrong size,
an unsupported command) are answered with exactly one NAK and have no effect; stray
bytes outside packets are ignored; a packet left incomplete (a byte lost on the line) is
dropped without a reply when the line stays quiet for the inter-byte timeout
(:data:`~nomad200.emulator.rx.GAP_TIMEOUT`).

Sensor mask (CT)
----------------
Every pattern of the seven CT mask bytes is accepted, as by the real robot, and each state
reply carries exactly the fields the mask asks for, in the order of
:mod:`nomad200.state`. Where the firmware's behaviour is not documented the emulator
assumes:

- **Laser.** The emulated robot has no laser. The laser bit still gets its field: a point
  count of 0 and no points (2 bytes), followed, if the laser pose attachment is asked
  for, by a 36-byte attachment of zeros. (Nomadic's ``connect_robot`` asks for the laser
  on every robot, and the host library then reads the count and the points that follow.)
- **Partial groups.** x, y, steering and turret angle, and the three velocities, are
  independent bits: a mask of x and y alone gets 4 bytes of pose. (The host library's
  ``ct()`` takes the turret-velocity bit from the sonar 13 entry of its mask, so partial
  velocity groups happen with ordinary masks.)
- **Idle sensors.** Infrared readings are 15 (nothing near), the bumper 0 (not pressed),
  the compass 0; their pose attachments carry the odometry pose and clock of the reply.
- **Unused bits** (CT byte 5 bits 1-7, byte 6 bits 6-7) are ignored.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import IO, Any

from nomad200.codec import Cmd, Command, MvMode, Packet, decode_command, encode_frame
from nomad200.emulator.clock import Clock
from nomad200.emulator.robot import Robot
from nomad200.emulator.rx import HostParser
from nomad200.emulator.sonar import EchoFn
from nomad200.errors import (
    ChecksumError,
    EndByteError,
    FrameError,
    PayloadError,
    TruncatedPacketError,
)
from nomad200.mask import StateMask
from nomad200.replies import encode_get_rc, encode_get_rv, encode_get_sn
from nomad200.state import RawState, layout_for

__all__ = ["NomadModel"]

_STATE_REPLY = frozenset(
    {
        Cmd.AC, Cmd.SP, Cmd.PR, Cmd.PA, Cmd.VM, Cmd.MV, Cmd.CT, Cmd.GS, Cmd.ST, Cmd.LP,
        Cmd.DP, Cmd.DA, Cmd.WS, Cmd.ZR, Cmd.CONF_SN, Cmd.CONF_TM,
    }
)  # fmt: skip
_NAK = encode_frame(Cmd.NAK)


class NomadModel(Robot):
    """An emulated Nomad 200.

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
    cpu_voltage_raw, motor_voltage_raw : int
        Raw battery bytes reported in every state reply.
    """

    def __init__(
        self,
        *,
        echo: EchoFn | None = None,
        start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0),
        start_turret: float | None = None,
        clock: Clock | None = None,
        trace: IO[str] | None = None,
        cpu_voltage_raw: int = 230,
        motor_voltage_raw: int = 230,
    ) -> None:
        super().__init__(
            echo=echo, start_pose=start_pose, start_turret=start_turret, clock=clock, trace=trace
        )
        self.mask = StateMask()
        self.cpu_v, self.motor_v = cpu_voltage_raw, motor_voltage_raw
        self.rx = HostParser()
        self._last_rx = -math.inf
        self.naks = 0
        self.commands = 0
        self.discarded = 0

    # ------------------------------------------------------------ bytes in, bytes out
    def feed(
        self, data: bytes, t: float | None = None, *, quiet: float | None = None
    ) -> list[tuple[float, bytes]]:
        """Take host bytes that arrived at time ``t``; return ``(ready time, frame)`` replies.

        Parameters
        ----------
        data : bytes
            Bytes that arrived back to back (a transport's read or write).
        t : float, optional
            When the last of them arrived (default: the clock).
        quiet : float, optional
            How long the line was silent before them (default: since the previous feed);
            longer than the inter-byte timeout drops an incomplete packet.
        """
        t = self.clock() if t is None else t
        t = max(t, self.t)
        self.advance(t)
        if quiet is None:
            quiet = t - self._last_rx
        self._last_rx = t
        out: list[tuple[float, bytes]] = []
        for ev in self.rx.feed(data, quiet=quiet):
            if isinstance(ev, ChecksumError | EndByteError):
                self.naks += 1
                out.append((self.t, _NAK))
                self.emit({"type": "nak", "t": self.clock_ms() / 1000.0, "why": str(ev)})
            elif isinstance(ev, TruncatedPacketError):
                self.discarded += 1
                self.emit({"type": "discard", "t": self.clock_ms() / 1000.0, "why": str(ev)})
            elif not isinstance(ev, FrameError):
                out.append(self._handle(ev))
        return out

    def _handle(self, pkt: Packet) -> tuple[float, bytes]:
        try:
            cmd = decode_command(pkt)
            reply = self._execute(cmd)
        except (PayloadError, ValueError) as err:
            self.naks += 1
            self.emit({"type": "nak", "t": self.clock_ms() / 1000.0, "why": str(err)})
            return self.t, _NAK
        return self.t, reply

    def _execute(self, cmd: Command) -> bytes:
        code, a = cmd.code, cmd.args
        d = self.drive
        self.commands += 1
        self.command_received()
        self.emit(
            {"type": "command", "t": self.clock_ms() / 1000.0, "cmd": code.name, "args": list(a)}
        )
        if code == Cmd.CT:
            self.mask = StateMask.from_ct_args(a)
        elif code == Cmd.AC:
            for ax, v in zip(d.axes, a, strict=True):
                ax.acc = min(float(v), ax.max_acc) if v else ax.acc
        elif code == Cmd.SP:
            for ax, v in zip(d.axes, a, strict=True):
                ax.speed = min(float(v), ax.max_speed)
        elif code == Cmd.PR:
            for ax, v in zip(d.axes, a, strict=True):
                ax.set_position(ax.pos + v)
        elif code == Cmd.PA:
            for ax, v in zip(d.axes, a, strict=True):
                ax.set_position(float(v))
        elif code == Cmd.VM:
            for ax, v in zip(d.axes, a, strict=True):
                ax.set_velocity(float(v))
        elif code == Cmd.MV:
            if any(m > max(MvMode) for m in a[0::2]):  # refuse before touching any axis
                raise ValueError(f"bad MV modes {a[0::2]}")
            for i, ax in enumerate(d.axes):
                self._mv(ax, MvMode(a[2 * i]), a[2 * i + 1])
        elif code == Cmd.ST:
            for ax in d.axes:
                ax.stop()
        elif code == Cmd.LP:
            for ax in d.axes:
                ax.limp()
        elif code == Cmd.DP:
            d.define_position(float(a[0]), float(a[1]))
        elif code == Cmd.DA:
            d.define_angles(float(a[0]), float(a[1]))
        elif code == Cmd.ZR:
            t_done = self.t + d.zero()
            self.advance(t_done)
        elif code == Cmd.WS:
            self._wait_stopped(bool(a[0]), bool(a[1]), bool(a[2]), float(a[3]))
        elif code == Cmd.CONF_SN:
            self.configure_sonars(a[0], a[1:])
        elif code == Cmd.CONF_TM:
            self.watchdog_s = a[0]
        elif code == Cmd.GET_SN:
            atts = tuple(self.sonar_att) if self.mask.sonar_pose_attachment else None
            return encode_get_sn(tuple(self.sonar_raw), atts, self.clock_ms())
        elif code == Cmd.GET_RC:
            return encode_get_rc(*self.pose_words())
        elif code == Cmd.GET_RV:
            return encode_get_rv(*self.velocity_words())
        if code not in _STATE_REPLY:  # pragma: no cover - decode_command rejects others
            raise PayloadError(f"unsupported command {code.name}")
        return self.state_frame(int(code))

    def _mv(self, ax: Any, mode: MvMode, v: int) -> None:
        if mode == MvMode.VM:
            ax.set_velocity(float(v))
        elif mode == MvMode.PR:
            ax.set_position(ax.pos + v)
        elif mode == MvMode.PA:
            ax.set_position(float(v))
        elif mode == MvMode.LP:
            ax.limp()
        elif mode == MvMode.AC:
            ax.acc = min(float(abs(v)), ax.max_acc) or ax.acc
        elif mode == MvMode.SP:
            ax.speed = min(float(abs(v)), ax.max_speed)

    def _wait_stopped(self, tr: bool, st: bool, tu: bool, timeout: float) -> None:
        d = self.drive
        end = self.t + timeout
        sel = [ax for ax, f in zip(d.axes, (tr, st, tu), strict=True) if f]
        while self.t < end and any(ax.moving for ax in sel):
            self.advance(min(end, self.t + 0.02))
        # the robot answers on the next 10 ms tick after the axes stopped
        self.advance(min(end, math.ceil(self.t * 100.0) / 100.0))

    # ------------------------------------------------------------ replies
    def raw_state(self) -> RawState:
        """The current state in robot units, laid out for the current mask."""
        m = self.mask
        ids = sorted(m.sonars)
        now = self.odometry_attachment(self.t)  # idle sensors are read "now"
        return RawState(
            ir=(15,) * len(m.irs),
            ir_att=(now,) * len(m.irs) if m.ir_pose_attachment else (),
            sonar=tuple(self.sonar_raw[i] for i in ids),
            sonar_att=tuple(self.sonar_att[i] for i in ids) if m.sonar_pose_attachment else (),
            bumper_att=now,
            pose=self.pose_words(),
            vel=self.velocity_words(),
            compass_att=now,
            motor_status=self.drive.motor_status(),
            clock_ms=self.clock_ms(),
            cpu_voltage=self.cpu_v,
            motor_voltage=self.motor_v,
        )

    def state_frame(self, ptype: int = Cmd.GS) -> bytes:
        """A state reply frame of type ``ptype`` for the current mask and state."""
        return layout_for(self.mask).encode_frame(ptype, self.raw_state())


def model_time_fn(model: NomadModel) -> Callable[[], float]:
    """A callable giving the model's robot clock in seconds (for logs and tests)."""
    return lambda: model.clock_ms() / 1000.0

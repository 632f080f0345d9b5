"""Nomad 200 commands in SI units, over :class:`nomad200.link.Link`.

Metres, radians and seconds in, metres, radians and seconds out: the robot's 1/10 inch and
1/10 degree exist only here and in :mod:`nomad200.state_types`. A value the robot cannot carry
raises ``ValueError`` naming the axis before a byte is sent. State replies are decoded with
the layout of the last CT mask sent (:attr:`Client.mask`), which the client sends again on
every (re)open when ``sync_on_open``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final

from nomad200.codec import Cmd, MvMode
from nomad200.link import Link, open_clients
from nomad200.mask import StateMask
from nomad200.replies import Configuration, SonarScan, decode_get_rc, decode_get_rv, decode_get_sn
from nomad200.state import DEG10, IN10, State, StateLayout, layout_for

__all__ = ["ZR_TIMEOUT", "Client", "open_clients"]

#: seconds a ZR (zeroing) may take
ZR_TIMEOUT: Final = 120.0


def _ticks(value: float, unit: float, what: str, *, unsigned: bool = False) -> int:
    if not math.isfinite(value):
        raise ValueError(f"{what} must be finite, got {value}")
    n = round(value / unit)
    lo = 0 if unsigned else -32767
    if not lo <= n <= 32767:
        raise ValueError(f"{what} = {value} is out of range for the robot ({n} robot units)")
    return n


class Client(Link):
    """A Nomad 200 on a serial port.

    Parameters
    ----------
    port, baud, timeout, retries, exclusive
        As for :class:`nomad200.link.Link`.
    sync_on_open : bool
        Send CT with the current mask when the port opens, so a reopened robot replies in
        the layout the client expects.
    """

    def __init__(
        self,
        port: str,
        *,
        baud: int = 9600,
        timeout: float = 1.0,
        retries: int = 2,
        exclusive: bool = True,
        sync_on_open: bool = True,
    ) -> None:
        super().__init__(port, baud=baud, timeout=timeout, retries=retries, exclusive=exclusive)
        self.sync_on_open = sync_on_open
        self._mask = StateMask()
        self._layout: StateLayout = layout_for(self._mask)

    @property
    def mask(self) -> StateMask:
        """The mask the client decodes state replies with (the last CT sent)."""
        return self._mask

    def _on_open(self) -> None:
        if self.sync_on_open:
            self.configure_mask(self._mask)

    def _state_cmd(
        self, code: Cmd, args: tuple[int, ...] = (), timeout: float | None = None
    ) -> State:
        lay = self._layout
        pkt = self._transact(
            code, args, lay.frame_len, self.timeout if timeout is None else timeout
        )
        return lay.decode(pkt.payload)

    # ------------------------------------------------------------ configuration
    def configure_mask(self, mask: StateMask) -> State:
        """Send CT: choose what every state reply carries. Returns the first such reply."""
        with self._lock:
            self._mask = mask
            self._layout = layout_for(mask)
            return self._state_cmd(Cmd.CT, mask.ct_args())

    def configure_sonars(self, order: Sequence[int], interval_s: float) -> State:
        """Send CONF_SN: fire ``order`` (sonar ids) cyclically, one every ``interval_s``.

        The interval is rounded to the robot's 4 ms steps (1..255 steps).
        """
        rate = round(interval_s / 0.004)
        if not 1 <= rate <= 255:
            raise ValueError(f"sonar interval {interval_s} s is outside 0.004..1.02 s")
        ids = [int(i) for i in order]
        if len(ids) > 16 or any(not 0 <= i <= 15 for i in ids):
            raise ValueError(f"sonar order must list at most 16 ids 0..15, got {ids}")
        ids += [255] * (16 - len(ids))
        return self._state_cmd(Cmd.CONF_SN, (rate, *ids))

    def configure_watchdog(self, seconds: int) -> State:
        """Send CONF_TM: stop the motors if no command arrives for ``seconds`` (0 = off)."""
        if not 0 <= int(seconds) <= 255:
            raise ValueError(f"watchdog must be 0..255 s, got {seconds}")
        return self._state_cmd(Cmd.CONF_TM, (int(seconds),))

    # ------------------------------------------------------------ frames and limits
    def zero(self) -> State:
        """ZR: home steering and turret and set the pose to zero (may take long)."""
        return self._state_cmd(Cmd.ZR, (), max(ZR_TIMEOUT, self.timeout))

    def define_position(self, x: float, y: float) -> State:
        """DP: declare the current position to be (x, y) metres."""
        return self._state_cmd(Cmd.DP, (_ticks(x, IN10, "x"), _ticks(y, IN10, "y")))

    def define_angles(self, steer: float, turret: float) -> State:
        """DA: declare the current steering and turret angles (rad)."""
        return self._state_cmd(
            Cmd.DA, (_ticks(steer, DEG10, "steer"), _ticks(turret, DEG10, "turret"))
        )

    def set_speed(self, trans: float, steer: float, turret: float) -> State:
        """SP: speeds used by position moves (m/s, rad/s, rad/s)."""
        return self._state_cmd(Cmd.SP, self._axes(trans, steer, turret, unsigned=True))

    def set_acceleration(self, trans: float, steer: float, turret: float) -> State:
        """AC: accelerations (m/s^2, rad/s^2, rad/s^2)."""
        return self._state_cmd(Cmd.AC, self._axes(trans, steer, turret, unsigned=True))

    # ------------------------------------------------------------ motion
    def move_relative(self, trans: float, steer: float, turret: float) -> State:
        """PR: move each axis by the given amount (m, rad, rad)."""
        return self._state_cmd(Cmd.PR, self._axes(trans, steer, turret))

    def move_absolute(self, trans: float, steer: float, turret: float) -> State:
        """PA: move each axis to an absolute encoder position (m, rad, rad)."""
        return self._state_cmd(Cmd.PA, self._axes(trans, steer, turret))

    def move_velocity(self, v: float, w_steer: float, w_turret: float) -> State:
        """VM: run at constant velocities (m/s, rad/s, rad/s) until told otherwise."""
        return self._state_cmd(Cmd.VM, self._axes(v, w_steer, w_turret))

    def move(
        self,
        trans: tuple[MvMode, float] = (MvMode.IGNORE, 0.0),
        steer: tuple[MvMode, float] = (MvMode.IGNORE, 0.0),
        turret: tuple[MvMode, float] = (MvMode.IGNORE, 0.0),
    ) -> State:
        """MV: a mode and a value (SI) per axis, e.g. ``trans=(MvMode.VM, 0.2)``."""
        args: list[int] = []
        for (mode, val), unit, name in (
            (trans, IN10, "trans"),
            (steer, DEG10, "steer"),
            (turret, DEG10, "turret"),
        ):
            args += [int(mode), _ticks(val, unit, name)]
        return self._state_cmd(Cmd.MV, tuple(args))

    def stop(self) -> State:
        """ST: decelerate every axis to a stop."""
        return self._state_cmd(Cmd.ST)

    def limp(self) -> State:
        """LP: switch the motors off."""
        return self._state_cmd(Cmd.LP)

    def wait_stopped(
        self,
        timeout_s: float = 30.0,
        *,
        trans: bool = True,
        steer: bool = True,
        turret: bool = True,
    ) -> State:
        """WS: the robot replies once the chosen axes stop or after ``timeout_s`` (1..255 s)."""
        t = min(255, max(1, math.ceil(timeout_s)))
        return self._state_cmd(Cmd.WS, (int(trans), int(steer), int(turret), t), t + 1.0)

    # ------------------------------------------------------------ reads
    def get_state(self) -> State:
        """GS: the current state, laid out by the mask."""
        return self._state_cmd(Cmd.GS)

    def get_sonars(self) -> SonarScan:
        """GET_SN: the latest reading of all 16 sonars (attachments if the mask asks)."""
        att = self._mask.sonar_pose_attachment
        pkt = self._transact(Cmd.GET_SN, (), 16 + (576 if att else 0) + 6, self.timeout)
        return decode_get_sn(pkt.payload, attachments=att)

    def get_configuration(self) -> Configuration:
        """GET_RC: x, y, steering and turret angle."""
        return decode_get_rc(self._transact(Cmd.GET_RC, (), 10, self.timeout).payload)

    def get_velocities(self) -> tuple[float, float, float]:
        """GET_RV: translation (m/s), steering and turret rates (rad/s)."""
        return decode_get_rv(self._transact(Cmd.GET_RV, (), 8, self.timeout).payload)

    @staticmethod
    def _axes(a: float, b: float, c: float, *, unsigned: bool = False) -> tuple[int, int, int]:
        return (
            _ticks(a, IN10, "translation", unsigned=unsigned),
            _ticks(b, DEG10, "steering", unsigned=unsigned),
            _ticks(c, DEG10, "turret", unsigned=unsigned),
        )

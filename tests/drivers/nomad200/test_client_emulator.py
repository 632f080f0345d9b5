"""The real client against the emulator, over a real pty and over the nomad:// URL scheme."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from procs import stop_process

from nomad200 import (
    Client,
    Cmd,
    MvMode,
    NomadDisconnected,
    NomadError,
    NomadNak,
    NomadPortBusy,
    NomadTimeout,
    State,
    StateMask,
)
from nomad200.state import DEG10, IN10, INCH

from .conftest import PortFactory, start_emulator

FULL = StateMask(sonars=frozenset(range(16)), pose=True, velocities=True)
RES_XY = IN10 + 1e-9  # protocol resolution 0.1 in
RES_ANG = DEG10 + 1e-9  # 0.1 deg


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def polls(c: Client, n: int) -> State:
    st = c.get_state()
    for _ in range(n - 1):
        st = c.get_state()
    return st


def test_configure_and_read(make_port: PortFactory, box_world: Path) -> None:
    with Client(make_port(world=box_world, fast=True), baud=38400) as c:
        st = c.configure_mask(FULL)
        assert set(st.sonar) == set(range(16))
        assert (st.x, st.y, st.steer, st.turret) == (0.0, 0.0, 0.0, 0.0)
        assert st.trans_vel == 0.0 and st.motor_status == 0
        assert st.cpu_voltage_raw == 230 and st.motor_voltage_raw == 230
        t0 = st.clock
        assert c.get_state().clock > t0
        st = c.configure_sonars([0, 4, 8, 12], 0.04)
        st = c.configure_watchdog(0)
        assert c.get_configuration() == (0.0, 0.0, 0.0, 0.0)
        assert c.get_velocities() == (0.0, 0.0, 0.0)
        assert c.get_sonars().clock >= st.clock
        st = c.define_position(1.0, -2.0)
        assert st.x == pytest.approx(1.0, abs=RES_XY) and st.y == pytest.approx(-2.0, abs=RES_XY)
        st = c.define_angles(math.radians(10), math.radians(20))
        assert st.steer == pytest.approx(math.radians(10), abs=RES_ANG)
        st = c.zero()
        assert (st.x, st.y, st.steer, st.turret) == (0.0, 0.0, 0.0, 0.0)
        assert c.counters()["timeouts"] == 0


def test_pr_moves_give_the_commanded_pose(make_port: PortFactory, box_world: Path) -> None:
    with Client(make_port(world=box_world, fast=True), baud=38400) as c:
        c.configure_mask(StateMask(pose=True, velocities=True))
        c.set_speed(0.4, math.radians(45), math.radians(45))
        c.set_acceleration(0.5, math.radians(90), math.radians(90))
        st = c.move_relative(0.5, 0.0, 0.0)
        assert st.motor_status & 1
        st = c.wait_stopped(20)
        assert st.motor_status == 0
        assert st.x == pytest.approx(0.5, abs=RES_XY) and st.y == pytest.approx(0.0, abs=RES_XY)
        c.move_relative(0.0, math.radians(90), math.radians(-45))
        st = c.wait_stopped(20)
        assert st.steer == pytest.approx(math.pi / 2, abs=RES_ANG)
        assert wrap(st.turret - math.radians(-45)) == pytest.approx(0.0, abs=RES_ANG)
        c.move_relative(0.3, 0.0, 0.0)
        st = c.wait_stopped(20)
        assert st.x == pytest.approx(0.5, abs=RES_XY) and st.y == pytest.approx(0.3, abs=RES_XY)
        conf = c.get_configuration()
        assert conf.x == st.x and conf.y == st.y


def test_vm_moves_give_the_commanded_pose(make_port: PortFactory, box_world: Path) -> None:
    """VM at v from robot clock t0 to ST at t1 covers v (t1 - t0): the ramps cancel."""
    with Client(make_port(world=box_world, fast=True), baud=38400) as c:
        c.configure_mask(StateMask(pose=True, velocities=True))
        c.set_acceleration(0.5, math.radians(90), math.radians(90))
        v, w = 0.2, math.radians(30)
        t0 = c.move_velocity(v, 0.0, w).clock
        st = polls(c, 150)  # 150 polls at 38400 baud: well past the 0.4 s ramp
        assert st.trans_vel == pytest.approx(v, abs=RES_XY)
        assert st.turret_vel == pytest.approx(w, abs=RES_ANG)
        t1 = c.stop().clock
        st = c.wait_stopped(10)
        assert st.x == pytest.approx(v * (t1 - t0), abs=RES_XY)
        assert st.y == pytest.approx(0.0, abs=RES_XY)
        assert wrap(st.turret - w * (t1 - t0)) == pytest.approx(0.0, abs=RES_ANG)
        # now drive along the new steering heading
        c.move_relative(0.0, math.radians(-90), 0.0)
        c.wait_stopped(10)
        x0 = st.x
        t0 = c.move_velocity(-v, 0.0, 0.0).clock
        polls(c, 120)
        t1 = c.stop().clock
        st = c.wait_stopped(10)
        # steering -90 deg: backwards along -y is +y
        assert st.x == pytest.approx(x0, abs=RES_XY)
        assert st.y == pytest.approx(v * (t1 - t0), abs=RES_XY)


def _expected_inches(wall_distance: float) -> int:
    return round((wall_distance - 0.22) / INCH)


def test_sonar_reads_the_geometric_range(make_port: PortFactory, box_world: Path) -> None:
    """Room x -2..2, y -2..3; robot at the origin: sonar i looks along i * 22.5 deg."""
    with Client(make_port(world=box_world, fast=True), baud=38400) as c:
        c.configure_mask(
            StateMask(sonars=frozenset({0, 4, 8, 12}), pose=True, sonar_pose_attachment=True)
        )
        c.configure_sonars([0, 4, 8, 12], 0.04)
        st = polls(c, 40)
        assert st.sonar_raw == {
            0: _expected_inches(2.0),
            4: _expected_inches(3.0),
            8: _expected_inches(2.0),
            12: _expected_inches(2.0),
        }
        assert st.sonar[0] == pytest.approx(_expected_inches(2.0) * INCH)
        c.move_relative(0.5, 0.0, 0.0)
        c.wait_stopped(10)
        st = polls(c, 40)
        assert st.sonar_raw[0] == _expected_inches(1.5)
        assert st.sonar_raw[8] == _expected_inches(2.5)
        for i, a in st.sonar_attachments.items():
            assert a.x == pytest.approx(st.x, abs=RES_XY), i
            assert a.pose_time <= a.reading_time <= st.clock
        # the robot's turret turned: sonar 0 now sees the +y wall
        c.move_relative(0.0, 0.0, math.radians(90))
        c.wait_stopped(10)
        assert polls(c, 40).sonar_raw[0] == _expected_inches(3.0)


def test_exclusive_lock(make_port: PortFactory, box_world: Path) -> None:
    port = make_port(world=box_world, fast=True)
    with Client(port, baud=38400) as c:
        other = Client(port, baud=38400)
        with pytest.raises(NomadPortBusy):
            other.open()
        assert not other.is_open
        c.get_state()


def test_nak_for_a_refused_packet(make_port: PortFactory, box_world: Path) -> None:
    with Client(make_port(world=box_world, fast=True), baud=38400, retries=1) as c:
        with pytest.raises(NomadNak) as info:
            c._state_cmd(Cmd.CONF_SN, (0, *([255] * 16)))  # rate 0 is refused
        assert c.naks == 2 and c.retry_count == 1
        assert info.value.command == "CONF_SN" and info.value.executed is False
        assert "did not execute it after 2 attempt(s)" in str(info.value)
        c.get_state()


def test_missing_port_and_closed_client(tmp_path: Path) -> None:
    c = Client(str(tmp_path / "nothing"))
    with pytest.raises(NomadDisconnected) as info:
        c.open()
    assert info.value.__cause__ is not None
    with pytest.raises(NomadDisconnected):
        c.get_state()
    with pytest.raises(NomadDisconnected):
        c.reconnect(deadline_s=0.1)


# ---------------------------------------------------------------- faults


def _survive(c: Client, n: int) -> tuple[int, int]:
    ok = failed = 0
    for _ in range(n):
        try:
            c.get_state()
            ok += 1
        except NomadError:
            failed += 1
    return ok, failed


@pytest.mark.parametrize(("fault", "rate"), [("garble", 0.003), ("drop", 0.003)])
def test_survives_garbled_and_dropped_bytes(
    make_port: PortFactory, box_world: Path, fault: str, rate: float
) -> None:
    port = make_port(world=box_world, fast=True, seed=3, **{fault: rate})
    with Client(port, baud=38400, timeout=0.3, retries=3) as c:
        c.configure_mask(FULL)
        ok, failed = _survive(c, 80)
        assert ok >= 78, (ok, failed, c.counters())
        assert c.retry_count > 0
        assert c.frame_errors + c.timeouts > 0
        if fault == "garble":
            assert c.skipped_bytes > 0
        assert c.get_state().motor_status == 0


def test_survives_stalls(make_port: PortFactory, box_world: Path) -> None:
    port = make_port(world=box_world, fast=True, seed=1, stall=0.1, stall_for=0.25)
    with Client(port, baud=38400, timeout=0.15, retries=3) as c:
        ok, failed = _survive(c, 40)
        assert ok >= 38, (ok, failed, c.counters())
        assert c.timeouts > 0 and c.retry_count > 0


def test_survives_unplug_and_replug(make_port: PortFactory, box_world: Path) -> None:
    port = make_port(world=box_world, unplug_at=0.4, unplug_for=0.6)
    with Client(port, baud=38400, timeout=0.3) as c:
        c.configure_mask(StateMask(pose=True))
        c.move_velocity(0.1, 0.0, 0.0)
        with pytest.raises(NomadDisconnected):
            for _ in range(10_000):
                c.get_state()
        assert not c.is_open
        c.reconnect(deadline_s=10)
        assert c.reconnects == 1 and c.mask == StateMask(pose=True)
        st = c.get_state()
        assert st.x is not None and st.x > 0  # same robot, still moving
        c.stop()


def test_timeout_when_nothing_answers(make_port: PortFactory, box_world: Path) -> None:
    port = make_port(world=box_world, fast=True, stall=1.0, stall_for=5)
    c = Client(port, baud=38400, timeout=0.1, retries=0, sync_on_open=False)
    with c:
        with pytest.raises(NomadTimeout):
            c.get_state()
        assert c.timeouts == 1


def test_spy_url_traces_the_traffic(
    tmp_path: Path, box_world: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    link, proc = start_emulator(tmp_path, world=box_world, fast=True, baud=38400)
    try:
        with Client(f"spy://{link}", baud=38400) as c:  # spy writes its hex dump to stderr
            c.get_state()
        text = capsys.readouterr().err.lower()
        assert "01 02 00 07 0a 5c" in text  # the GS request, byte for byte
    finally:
        stop_process(proc)


def test_mv_pa_limp_and_get_sn(make_port: PortFactory, box_world: Path) -> None:
    with Client(make_port(world=box_world, fast=True), baud=38400) as c:
        c.configure_mask(StateMask(pose=True, sonar_pose_attachment=True))
        c.configure_sonars([0], 0.02)
        c.move(trans=(MvMode.PR, 0.1), turret=(MvMode.PA, math.radians(20)))
        st = c.wait_stopped(10)
        assert st.x == pytest.approx(0.1, abs=RES_XY)
        assert st.turret == pytest.approx(math.radians(20), abs=RES_ANG)
        c.move_absolute(0.0, math.radians(5), 0.0)  # translation odometer back to 0
        st = c.wait_stopped(10)
        assert st.x == pytest.approx(0.0, abs=RES_XY)
        assert st.steer == pytest.approx(math.radians(5), abs=RES_ANG)
        c.move_velocity(0.1, 0.0, 0.0)
        st = c.limp()
        assert c.get_velocities() == (0.0, 0.0, 0.0) and c.get_state().motor_status == 0
        scan = c.get_sonars()
        assert set(scan.sonar) == set(range(16)) and scan.sonar_raw[1] == 255
        assert scan.sonar_attachments[0].pose_time > 0  # sonar 0 fired; 1 never did

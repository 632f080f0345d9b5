"""Plan loading and validation."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from sonard.link import poll_bytes, poll_seconds, reply_bytes
from sonard.plan import (
    DefinePose,
    Plan,
    PlanError,
    Translate,
    TurretSweep,
    WallFollow,
    load_plan,
    parse_plan,
)

PLANS = Path(__file__).resolve().parents[3] / "configs" / "plans"


def _plan(**over: object) -> dict[str, object]:
    base: dict[str, object] = {"sonars": [0, 1], "steps": [{"dwell": {"seconds": 1}}]}
    base.update(over)
    return base


@pytest.mark.parametrize("name", ["translate", "turret-sweep", "room"])
def test_shipped_plans_load(name: str) -> None:
    plan = load_plan(PLANS / f"{name}.yaml")
    assert isinstance(plan, Plan)
    assert plan.name == name
    assert plan.interval == pytest.approx(0.040)


def test_translate_plan_is_fig16() -> None:
    plan = load_plan(PLANS / "translate.yaml")
    assert sorted(plan.sonars) == [0, 1, 2, 14, 15]
    dp, tr = plan.steps
    assert isinstance(dp, DefinePose) and isinstance(tr, Translate)
    assert (dp.x, dp.y) == (-0.75, 0.0)
    assert dp.turret == pytest.approx(math.pi / 2)
    assert tr.distance == 1.5 and tr.step == 0.025 and tr.mode == "stop-and-fire"


def test_turret_sweep_in_radians() -> None:
    plan = load_plan(PLANS / "turret-sweep.yaml")
    sweep = plan.steps[1]
    assert isinstance(sweep, TurretSweep)
    assert sweep.from_ == pytest.approx(math.radians(-30))
    assert sweep.to == pytest.approx(math.radians(30))
    assert sweep.step == pytest.approx(math.radians(1))
    assert sweep.speed == pytest.approx(math.radians(60))


def test_room_plan_wall_follow() -> None:
    plan = load_plan(PLANS / "room.yaml")
    wf = plan.steps[-1]
    assert isinstance(wf, WallFollow)
    assert wf.side_sonar == 12 and 12 in plan.sonars
    assert wf.turn_speed == pytest.approx(math.radians(60))


def test_defaults_and_bare_step_names() -> None:
    plan = parse_plan(_plan(steps=["zero", {"dwell": {"seconds": 2}}]))
    assert [s.type for s in plan.steps] == ["zero", "dwell"]
    assert plan.baud == 9600 and plan.speed_of_sound == 343.3
    assert plan.pose_attachments == "auto" and not plan.use_attachments  # 9600 is too slow
    assert parse_plan(_plan(baud=38400)).use_attachments
    assert plan.fault_timeout_s == 30.0


@pytest.mark.parametrize(
    ("over", "needles"),
    [
        ({"baud": 1200}, ["p.yaml", "baud", "4800, 9600, 19200, 38400"]),
        ({"sonars": [0, 16]}, ["p.yaml", "sonars", "0 to 15"]),
        ({"sonars": [3, 3]}, ["sonars", "at most once"]),
        ({"speed_of_sound": 100}, ["speed_of_sound", "300 to 400"]),
        ({"interval": 0.041}, ["interval", "multiple of 0.004"]),
        ({"max_range": 10.7}, ["interval", "minimum 0.064 s", "force: true"]),
        (
            {"steps": [{"translate": {"distance": 1, "step": 0}}]},
            ["steps.0.translate.step", "0.005 to 5"],
        ),
        ({"steps": [{"translate": {"distance": 1}}]}, ["steps.0.translate", "step", "required"]),
        (
            {"steps": [{"turret_sweep": {"from": -30, "to": 30, "step": 500}}]},
            ["steps.0.turret_sweep.step", "0.1 to 180 deg"],
        ),
        ({"steps": [{"jump": {}}]}, ["steps.0", "allowed steps", "translate"]),
        (
            {"steps": [{"dwell": {"seconds": 1, "secs": 1}}]},
            ["steps.0.dwell.secs", "allowed fields: seconds"],
        ),
        ({"steps": []}, ["steps"]),
        ({"bogus": 1}, ["bogus"]),
        ({"steps": [{"wall_follow": {"distance": 0.5, "length": 3}}]}, ["wall_follow", "sonar 4"]),
        ({"sonars": [0, 1, 2], "pose_attachments": True}, ["baud", "too slow", "19200, 38400"]),
    ],
)
def test_errors_name_file_field_and_range(over: dict[str, object], needles: list[str]) -> None:
    with pytest.raises(PlanError) as info:
        parse_plan(_plan(**over), "p.yaml")
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("p.yaml: ")
    for n in needles:
        assert n in msg, msg


def test_force_allows_short_interval() -> None:
    plan = parse_plan(_plan(max_range=10.7, force=True))
    assert plan.interval == pytest.approx(0.04)
    assert plan.min_interval == pytest.approx(0.064)


def test_min_interval_is_echo_travel_time() -> None:
    plan = parse_plan(_plan(max_range=5.0, interval=0.032))
    assert plan.min_interval == pytest.approx(0.032)  # 2*5/343.3 = 29.1 ms -> 8 ticks


def test_load_plan_file_errors(tmp_path: Path) -> None:
    with pytest.raises(PlanError, match="cannot read plan"):
        load_plan(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("sonars: [0\nsteps: x\n")
    with pytest.raises(PlanError, match=r"bad\.yaml.*not valid YAML"):
        load_plan(bad)
    lst = tmp_path / "list.yaml"
    lst.write_text("- 1\n")
    with pytest.raises(PlanError, match="mapping"):
        load_plan(lst)


def test_link_budget() -> None:
    # frame 5 + type 1 + 5 sonars + pose 8 + motor 1 + clock 4 + voltages 2
    assert reply_bytes(5, False) == 26
    assert reply_bytes(5, True) == 26 + 5 * 36
    assert poll_bytes(5, True) == 6 + 206
    assert poll_seconds(5, True, 38400) == pytest.approx(212 * 10 / 38400)

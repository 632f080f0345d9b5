"""run_plan's control flow around link faults, with a scripted stand-in for Acquisition."""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import pytest

from sonard.acquisition import Resume
from sonard.plan import Plan, parse_plan
from sonard.steps import run_plan


class ScriptedAcquisition:
    """Answers polls from a clock it advances itself; raises Resume where the script says."""

    def __init__(self, resume_on: dict[str, int]) -> None:
        self.resume_on = dict(resume_on)
        self.calls: list[str] = []
        self.events: list[tuple[str, str]] = []
        self.recording = False
        self.state = SimpleNamespace(clock=0.0, motor_status=0)
        self.sink = SimpleNamespace(event=self._record_event)
        self.notifier = SimpleNamespace(watchdog_period=0.0, send=lambda _msg: None)

    def _record_event(self, kind: str, detail: str = "") -> None:
        self.events.append((kind, detail))

    def _maybe_resume(self, name: str) -> None:
        if self.resume_on.get(name, 0) > 0:
            self.resume_on[name] -= 1
            raise Resume

    def _command(self, name: str) -> Any:
        self.calls.append(name)
        self._maybe_resume(name)
        return self.state

    def stop(self) -> Any:
        return self._command("stop")

    def zero(self) -> Any:
        return self._command("zero")

    def poll(self) -> Any:
        self.calls.append("poll")
        self.state.clock += 0.04
        self._maybe_resume("poll")
        return self.state

    def wait_robot_time(self, seconds: float) -> None:
        start = self.state.clock
        while self.state.clock - start < seconds:
            self.poll()


def _plan(steps: list[Any]) -> Plan:
    return parse_plan({"name": "t", "sonars": [0], "steps": steps}, "test.yaml")


def test_link_drop_during_a_steps_closing_stop_does_not_escape() -> None:
    acq = ScriptedAcquisition({"stop": 1})
    run_plan(acq, _plan([{"dwell": {"seconds": 0.2}}]))  # type: ignore[arg-type]
    assert acq.calls.count("stop") == 1
    assert ("step", "0 dwell") in acq.events


def test_link_drop_mid_step_resumes_the_step_with_its_progress() -> None:
    acq = ScriptedAcquisition({"poll": 1})
    run_plan(acq, _plan([{"dwell": {"seconds": 0.4}}]))  # type: ignore[arg-type]
    # 0.4 s of robot time at 40 ms a poll, resumed once: no more polls than a clean run + 2
    assert 10 <= acq.calls.count("poll") <= 13
    assert acq.calls[-1] == "stop"


@pytest.mark.parametrize("n_steps", [1, 3])
def test_every_step_ends_with_stop(n_steps: int) -> None:
    acq = ScriptedAcquisition({})
    run_plan(acq, _plan([{"dwell": {"seconds": 0.08}}] * n_steps))  # type: ignore[arg-type]
    assert acq.calls.count("stop") == n_steps


def test_zero_that_is_never_acknowledged_fails_the_plan(monkeypatch: pytest.MonkeyPatch) -> None:
    from sonard.motion import MotionError

    acq = ScriptedAcquisition({})
    monkeypatch.setattr(acq, "zero", lambda: None)
    with pytest.raises(MotionError, match="ZR was not acknowledged"):
        run_plan(acq, _plan(["zero", {"dwell": {"seconds": 0.08}}]))  # type: ignore[arg-type]


class _FlakyClient:
    """Fails ``move_relative`` with the given errors, then acknowledges it (reply None)."""

    def __init__(self, errors: list[Exception]) -> None:
        self.errors = list(errors)
        self.sent = 0

    def move_relative(self, *args: float) -> None:
        self.sent += 1
        if self.errors:
            raise self.errors.pop(0)


def _nak() -> Exception:
    from nomad200 import NomadNak

    err = NomadNak("robot refused PR")
    err.command, err.executed = "PR", False
    return err


def _timeout() -> Exception:
    from nomad200 import NomadTimeout

    err = NomadTimeout("no reply to PR")
    err.command, err.executed = "PR", None
    return err


@pytest.mark.parametrize(
    ("errors", "sent"),
    [
        ([], 1),
        ([_nak()], 2),  # refused: it did nothing, so sending it again is safe
        ([_nak(), _nak()], 3),
        ([_timeout()], 1),  # unknown: it may have moved, so it is not sent twice
        ([_nak(), _timeout()], 2),
    ],
)
def test_non_idempotent_commands_are_resent_only_after_a_refusal(
    errors: list[Exception], sent: int
) -> None:
    import threading

    from sonard.acquisition import Acquisition

    client = _FlakyClient(errors)
    sink = SimpleNamespace(event=lambda *_a, **_k: None)
    acq = Acquisition(client, _plan([{"dwell": {"seconds": 1}}]), sink, stop=threading.Event())  # type: ignore[arg-type]
    acq.move_relative(0.1, 0.0, 0.0)
    assert client.sent == sent


def test_a_link_fault_recovered_in_the_first_poll_does_not_end_the_run() -> None:
    # a loaded host can miss replies for a second in its very first poll: the fault is
    # recovered from (Resume) before any step runs, and the start polls again
    import threading

    from sonard.daemon import _start

    calls: list[str] = []

    class FirstPollFails:
        def start(self) -> None:
            calls.append("start")

        def poll(self) -> Any:
            calls.append("poll")
            if calls.count("poll") == 1:
                raise Resume
            return SimpleNamespace(clock=0.04)

    _start(FirstPollFails(), threading.Event())  # type: ignore[arg-type]
    assert calls == ["start", "poll", "poll"]

"""The held-out residual computed in a forked child while the run fits: the very figures
computed in the run's own process, and the same figures when no child may be forked, when
the child fails, and nothing left running when the result is not measured."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from sonarlog import SonarLog, read_log
from sonarproc.cli import main
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log, process
from sonarproc.pipeline.arcmap import build_arc_map
from sonarproc.pipeline.selection import plan_grid, select_beams
from sonarproc.quality import ahead as ahead_module
from sonarproc.quality.ahead import HeldOutAhead
from sonarproc.quality.measure import held_out, heldout_residual

ROBOND = Path(__file__).resolve().parents[3] / "data" / "real" / "robond"

needs_fork = pytest.mark.skipif(
    sys.platform != "linux" or len(os.sched_getaffinity(0)) < 2,
    reason="the residual is computed ahead on Linux with two cores only",
)


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> SonarLog:
    path = tmp_path_factory.mktemp("ahead") / "room-box.h5"
    assert main(["simulate", "room-box", "--out", str(path), "--seed", "1"]) == 0
    return read_log(path)


@pytest.fixture(scope="module")
def robond() -> SonarLog:
    return load_log(ROBOND / "readings.csv", sensors=ROBOND / "sensors.yaml")


def _inputs(lg: SonarLog) -> tuple:  # type: ignore[type-arg]
    params = RunParams(fit="auto")
    beams, _ = select_beams(lg, params)
    grid = plan_grid(lg, params, beams)
    return beams, grid, params, build_arc_map(beams, grid, params).evidence


@needs_fork
@pytest.mark.parametrize("name", ["room", "robond"])
def test_the_child_gives_the_residual_computed_here(
    name: str, request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: True)
    beams, grid, params, counts = _inputs(request.getfixturevalue(name))
    job = HeldOutAhead.start(build_arc_map, beams, grid, params, counts)
    assert job.forked
    got = job.residual()
    here = heldout_residual(held_out(beams, grid, params, counts), build_arc_map, beams,
                            grid, params)  # fmt: skip
    assert got == here  # every figure to the last bit
    assert got.median_m is not None and got.readings > 100


def test_without_a_fork_the_residual_is_computed_here(
    room: SonarLog, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: False)
    beams, grid, params, counts = _inputs(room)
    job = HeldOutAhead.start(build_arc_map, beams, grid, params, counts)
    assert not job.forked
    here = heldout_residual(held_out(beams, grid, params, counts), build_arc_map, beams,
                            grid, params)  # fmt: skip
    assert job.residual() == here


@needs_fork
def test_a_failed_child_is_replaced_by_the_work_done_here(
    room: SonarLog, monkeypatch: pytest.MonkeyPatch
) -> None:
    parent = os.getpid()
    real = ahead_module.heldout_residual

    def fails_in_the_child(*args, **kwargs):  # type: ignore[no-untyped-def]
        if os.getpid() != parent:
            raise MemoryError("the child ran out of memory")
        return real(*args, **kwargs)

    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: True)
    monkeypatch.setattr(ahead_module, "heldout_residual", fails_in_the_child)
    beams, grid, params, counts = _inputs(room)
    job = HeldOutAhead.start(build_arc_map, beams, grid, params, counts)
    assert job.forked
    assert job.residual() == real(held_out(beams, grid, params, counts), build_arc_map,
                                  beams, grid, params)  # fmt: skip


@needs_fork
@pytest.mark.parametrize("name", ["room", "robond"])
def test_a_run_measures_the_same_quality_with_and_without_the_child(
    name: str, request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch
) -> None:
    lg = request.getfixturevalue(name)
    started: list[HeldOutAhead] = []
    real_start = HeldOutAhead.start.__func__  # type: ignore[attr-defined]

    def counted(cls, *args):  # type: ignore[no-untyped-def]
        job = real_start(cls, *args)
        started.append(job)
        return job

    monkeypatch.setattr(HeldOutAhead, "start", classmethod(counted))
    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: True)
    forked = process(lg, RunParams(fit="auto"))
    assert len(started) == 1 and not started[0].forked  # collected
    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: False)
    here = process(lg, RunParams(fit="auto"))
    assert forked.quality is not None and here.quality is not None
    assert forked.quality.to_json() == here.quality.to_json()
    assert forked.quality.heldout_median_m is not None


@needs_fork
def test_a_result_handed_on_unmeasured_leaves_no_child(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "fig12.h5"
    assert main(["simulate", "fig12", "--out", str(path), "--seed", "1"]) == 0
    pids: list[int] = []
    real_start = HeldOutAhead.start.__func__  # type: ignore[attr-defined]

    def counted(cls, *args):  # type: ignore[no-untyped-def]
        job = real_start(cls, *args)
        assert job._child is not None
        pids.append(job._child.pid)
        return job

    monkeypatch.setattr(HeldOutAhead, "start", classmethod(counted))
    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: True)
    res = process(read_log(path), RunParams(fit="auto"), quality_of_curves=False)
    assert res.surfaces is None and res.quality is None  # one curve: handed on to --auto
    assert len(pids) == 1
    with pytest.raises(ChildProcessError):  # stopped and reaped
        os.waitpid(pids[0], os.WNOHANG)

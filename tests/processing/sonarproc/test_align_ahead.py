"""The align stage in a forked child while the log is mapped as read: the same run as the
stages one after the other, on a log that keeps its poses and on one whose poses are
corrected (mapped again), and nothing lost when the child fails."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from drift import drifted_readings, looped_scenario

from sonarlog import LogWriter, SonarLog, read_log
from sonarproc import forked
from sonarproc.params import RunParams
from sonarproc.pipeline import align_ahead, process, surfacefit
from sonarproc.pipeline.result import RunResult
from sonarproc.quality.ahead import HeldOutAhead
from sonarproc.report.run_report import report_dict
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]

needs_fork = pytest.mark.skipif(
    sys.platform != "linux" or len(os.sched_getaffinity(0)) < 2,
    reason="the log is aligned in a child on Linux with two cores only",
)


def record(result: RunResult) -> dict[str, Any]:
    """report.json of ``result`` but for the times, and the alignment's paths."""
    doc = report_dict(result)
    doc.pop("timings_s")
    doc["metrics"].pop("t_cpu_s")
    assert result.alignment is not None
    doc["paths"] = [result.alignment.raw_path.tolist(), result.alignment.corrected_path.tolist()]
    return doc


def both_ways(
    log: SonarLog, monkeypatch: pytest.MonkeyPatch
) -> tuple[RunResult, RunResult, list[HeldOutAhead]]:
    """The run with the align stage in a child (checked to be forked), and all here; and
    the held-out refits the first run started, in order."""
    started: list[align_ahead.AlignAhead] = []
    start = align_ahead.AlignAhead.start
    refits: list[HeldOutAhead] = []
    start_refit = HeldOutAhead.start.__func__  # type: ignore[attr-defined]

    def spy(*args: Any, **kwargs: Any) -> align_ahead.AlignAhead:
        started.append(start(*args, **kwargs))
        return started[-1]

    def spy_refit(cls, *args):  # type: ignore[no-untyped-def]
        refits.append(start_refit(cls, *args))
        return refits[-1]

    params = RunParams(cell=0.02, fit="auto")
    with monkeypatch.context() as m:
        m.setattr(align_ahead.AlignAhead, "start", spy)
        m.setattr(HeldOutAhead, "start", classmethod(spy_refit))
        ahead = process(log, params)
    if not started or started[0].here:
        pytest.skip("another thread runs in this test process: no fork")
    with monkeypatch.context() as m:
        m.setattr(align_ahead, "fork_is_safe", lambda: False)
        here = process(log, params)
    return ahead, here, refits


@needs_fork
def test_a_log_kept_as_read_is_mapped_once_meanwhile(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "room-box.h5"
    simulate_to_log(ROOT / "configs" / "scenarios" / "room-box.yaml", path)
    starts: list[Any] = []
    real_start_fit = surfacefit.start_fit

    def spy_start_fit(*args: Any, **kwargs: Any) -> Any:
        starts.append(real_start_fit(*args, **kwargs))
        return starts[-1]

    monkeypatch.setattr(surfacefit, "start_fit", spy_start_fit)
    ahead, here, refits = both_ways(read_log(path), monkeypatch)
    assert ahead.alignment is not None and ahead.alignment.applied is False
    assert record(ahead) == record(here)
    assert len(refits) == 1  # the map as read's held-out refit, started meanwhile, kept
    # the fit's first half: done ahead on the map as read (then used), and by the run
    # that aligns first, in its fit
    assert len(starts) == 2 and starts[0].found is not None
    assert ahead.timings_s["align"] > 0 and list(ahead.timings_s) == list(here.timings_s)


@needs_fork
@pytest.mark.slow
def test_a_corrected_log_is_mapped_again_from_its_corrected_poses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    res = looped_scenario("room-box", 3)
    path = tmp_path / "drift.h5"
    with LogWriter(path, res.sensors, speed_of_sound=float(res.speed_of_sound),
                   robot="sim", truth=res.truth) as w:  # fmt: skip
        w.append(drifted_readings(res.readings, seed=0))
    ahead, here, refits = both_ways(read_log(path), monkeypatch)
    assert ahead.alignment is not None and ahead.alignment.applied is True
    assert record(ahead) == record(here)
    # the map as read's refit, dropped with that map, and the corrected map's
    assert len(refits) == 2 and not refits[0].forked and not refits[1].forked
    shift = ahead.alignment.corrected_path - ahead.alignment.raw_path
    assert float(np.abs(shift).max()) > 0.05


@needs_fork
def test_a_failed_child_leaves_the_stage_to_this_process(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "room-box.h5"
    simulate_to_log(ROOT / "configs" / "scenarios" / "room-box.yaml", path)
    log = read_log(path)
    monkeypatch.setattr(forked, "_child_main", lambda *args: os._exit(3))
    job = align_ahead.AlignAhead.start(log)
    if not job.forked:
        pytest.skip("another thread runs in this test process: no fork")
    got = job.result()
    assert job.here and got.log is log and got.record.applied is False
    assert job.result() is got  # asked once


def test_no_child_where_no_fork_is_safe(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    path = tmp_path / "fig12.h5"
    simulate_to_log(ROOT / "configs" / "scenarios" / "fig12.yaml", path)
    monkeypatch.setattr(align_ahead, "fork_is_safe", lambda: False)
    stages: list[str] = []
    job = align_ahead.AlignAhead.start(read_log(path), stages.append)
    assert not job.forked and stages == ["align"]
    assert job.result().record.reason and job.here

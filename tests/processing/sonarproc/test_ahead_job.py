"""The bookkeeping of work handed to a forked child (sonarproc.forked.AheadJob)."""

from __future__ import annotations

import os
import sys
import time

import pytest

from sonarproc import forked
from sonarproc.forked import AheadJob

needs_fork = pytest.mark.skipif(
    sys.platform != "linux" or not hasattr(os, "fork"), reason="a child is forked on Linux only"
)


def test_no_child_collects_none_and_cancels_quietly() -> None:
    job = AheadJob()
    assert not job.forked and job.collect() is None
    job.cancel()
    assert not job.forked


@needs_fork
def test_the_childs_answer_is_collected_once() -> None:
    job = AheadJob()
    job.fork(lambda: {"answer": [1, 2, 3]})
    assert job.forked
    assert job.collect() == {"answer": [1, 2, 3]}
    assert not job.forked and job.collect() is None


@needs_fork
def test_a_failed_child_gives_none(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(forked, "_child_main", lambda *args: os._exit(3))
    job = AheadJob()
    job.fork(lambda: 42)
    assert job.collect() is None


@needs_fork
def test_a_cancelled_child_is_reaped() -> None:
    job = AheadJob()
    job.fork(lambda: time.sleep(3600))  # would wait an hour
    assert job._child is not None
    pid = job._child.pid
    job.cancel()
    assert not job.forked
    with pytest.raises(ChildProcessError):
        os.waitpid(pid, os.WNOHANG)

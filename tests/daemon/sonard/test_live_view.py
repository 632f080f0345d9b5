"""``sonard --foxglove``: the option, and a view that never makes the writer wait."""

from __future__ import annotations

import importlib.util
import threading
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from sonard.cli import main
from sonarlog import POSE_DTYPE, READING_DTYPE, read_log

ROOT = Path(__file__).resolve().parents[3]
WORLD = ROOT / "configs" / "worlds" / "lab.yaml"


def _plan(tmp: Path) -> Path:
    plan = {
        "name": "t",
        "sonars": [0, 2, 14, 1, 15],
        "baud": 38400,
        "steps": [
            {"define_pose": {"x": -0.75, "y": 0.0, "theta": 0, "turret": 90}},
            {"dwell": {"seconds": 0.5}},
        ],
    }
    p = tmp / "plan.yaml"
    p.write_text(yaml.safe_dump(plan))
    return p


def test_bad_endpoint_and_missing_sdk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    plan = _plan(tmp_path)
    argv = ["--port", "x", "--plan", str(plan), "--out", str(tmp_path / "a.h5")]
    assert main([*argv, "--foxglove", "nope"]) == 2
    assert "sonard: --foxglove: must be [HOST:]PORT" in capsys.readouterr().err
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "foxglove" else real(name)
    )
    assert main([*argv, "--foxglove", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["sonard: --foxglove needs the Foxglove SDK: pip install 'sonarmorph[live]'"]
    assert not (tmp_path / "a.h5").exists()


def test_run_with_live_view_logs_every_reading(tmp_path: Path) -> None:
    pytest.importorskip("foxglove")
    out = tmp_path / "a.h5"
    url = f"nomad://live-a?world={WORLD}&fast=1"
    assert main(["--port", url, "--plan", str(_plan(tmp_path)), "--out", str(out),
                 "--foxglove", "127.0.0.1:0"]) == 0  # fmt: skip
    assert len(read_log(out).readings) > 10


class _Writer:
    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.poses: list[np.ndarray] = []

    def append(self, readings: np.ndarray) -> None:
        self.rows.append(readings)

    def append_poses(self, poses: np.ndarray) -> None:
        self.poses.append(poses)

    def event(self, kind: str, detail: str = "", t: float | None = None) -> None:
        pass

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass


def test_a_stuck_view_drops_batches_and_never_blocks_the_writer() -> None:
    pytest.importorskip("foxglove")
    from sonard.live_view import QUEUE_BATCHES, LiveView
    from sonard.ring import ring_sensors

    view = LiveView("127.0.0.1", 0, ring_sensors(), 343.3)
    release = threading.Event()

    def stuck(rows: Any, **kw: Any) -> None:  # a publisher that hangs
        release.wait(30)

    view.robot.readings = stuck  # type: ignore[method-assign]
    try:
        writer = _Writer()
        tee = view.tee(writer)
        rows = np.zeros(5, dtype=READING_DTYPE)
        n = QUEUE_BATCHES + 50
        for _ in range(n):  # the view's thread is stuck on the first batch meanwhile
            tee.append(rows)
        tee.append_poses(np.zeros(1, dtype=POSE_DTYPE))
        assert not release.is_set()
        assert len(writer.rows) == n and len(writer.poses) == 1  # the log got everything
        assert view.dropped_batches >= n - QUEUE_BATCHES  # the view did not
    finally:
        release.set()
        view.close()

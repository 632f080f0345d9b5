"""Figures drawn ahead in a forked child while the run measures its quality: the same
files as figures drawn after the run, and nothing lost when the child cannot be used."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path
from xml.etree import ElementTree

import pytest

from sonarproc.report import ahead as ahead_module
from sonarproc.report.run_report import report_files
from sonarproc.simulate import simulate_to_log

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "configs" / "scenarios"

needs_fork = pytest.mark.skipif(
    sys.platform != "linux" or len(os.sched_getaffinity(0)) < 2,
    reason="figures are drawn ahead on Linux with two cores only",
)

# A fresh interpreter (one thread, as a user's run) runs the CLI and says on stderr whether
# the figures were drawn ahead, and whether this process imported matplotlib to draw them;
# AHEAD=0 forbids the fork, so the report draws them itself.
CHILD = """
import os, sys
from sonarproc.report import ahead, drawing
if os.environ["AHEAD"] == "0":
    ahead.fork_is_safe = lambda: False
_start = ahead.AheadFigures.start
def _told(*a, **k):
    got = _start(*a, **k)
    sys.stderr.write(f"AHEAD={got is not None}\\n")
    return got
ahead.AheadFigures.start = _told
from sonarproc.cli import main
code = main(sys.argv[1:])
sys.stderr.write(f"DREW_HERE={'matplotlib' in sys.modules}\\n")
sys.exit(code)
"""


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("room") / "room-box.h5"
    simulate_to_log(SCENARIOS / "room-box.yaml", path)
    return path


@pytest.fixture(scope="module")
def curve(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("curve") / "fig12.h5"
    simulate_to_log(SCENARIOS / "fig12.yaml", path)
    return path


def run_cli(args: list[str], *, ahead: bool) -> str:
    """Run ``sonarproc ARGS`` in a fresh interpreter; return its stderr."""
    env = {**os.environ, "AHEAD": "1" if ahead else "0"}
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, *args], env=env, capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stderr


def tags(svg: bytes) -> Counter[str]:
    return Counter(e.tag for e in ElementTree.fromstring(svg).iter())


def same_reports(a: Path, b: Path) -> None:
    """The same files; PNGs byte for byte, SVGs element for element (their ids are salted),
    report.json but for its timings (wall times differ from run to run)."""
    assert sorted(p.name for p in a.iterdir()) == sorted(p.name for p in b.iterdir())
    for p in sorted(a.iterdir()):
        if p.suffix == ".png":
            assert p.read_bytes() == (b / p.name).read_bytes(), p.name
        elif p.suffix == ".svg":
            assert tags(p.read_bytes()) == tags((b / p.name).read_bytes()), p.name
    docs = [json.loads((d / "report.json").read_text(encoding="utf-8")) for d in (a, b)]
    for doc in docs:
        doc.pop("timings_s")
        doc["metrics"].pop("t_cpu_s")
    assert docs[0] == docs[1]


@needs_fork
@pytest.mark.parametrize(
    ("scene", "options"),
    [
        ("room", ["--figures", "png,svg"]),  # the default mode on a room: its surfaces
        ("curve", ["--fit", "poly", "--order", "9", "--figures", "png"]),  # given fit
        ("curve", ["--figures", "png"]),  # a curve's default: --auto's choice, sent at the report
    ],
)
def test_figures_drawn_ahead_are_those_drawn_after_the_run(
    scene: str, options: list[str], request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    log: Path = request.getfixturevalue(scene)
    args = ["run", str(log), "--cell", "0.02", "--json", *options]
    told = run_cli([*args, "--out", str(tmp_path / "ahead")], ahead=True)
    assert "AHEAD=True" in told and "DREW_HERE=False" in told
    told = run_cli([*args, "--out", str(tmp_path / "after")], ahead=False)
    assert "AHEAD=False" in told and "DREW_HERE=True" in told
    same_reports(tmp_path / "ahead", tmp_path / "after")
    formats = tuple(options[-1].split(","))
    assert sorted(p.name for p in (tmp_path / "ahead").glob("*.*g")) == sorted(
        n for n in report_files(formats) if n.endswith(("png", "svg"))
    )


@needs_fork
def test_a_failed_child_leaves_the_figures_to_the_report(room: Path, tmp_path: Path) -> None:
    crash = CHILD.replace(
        "from sonarproc.cli import main",
        # every forked child fails (the held-out residual's too: computed here instead)
        "import sonarproc.forked\n"
        "sonarproc.forked._child_main = lambda *a: os._exit(3)\nfrom sonarproc.cli import main",
    )
    args = ["run", str(room), "--cell", "0.02", "--json", "--figures", "png"]
    proc = subprocess.run(
        [sys.executable, "-c", crash, *args, "--out", str(tmp_path / "crashed")],
        env={**os.environ, "AHEAD": "1"}, capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "AHEAD=True" in proc.stderr and "DREW_HERE=True" in proc.stderr
    run_cli([*args, "--out", str(tmp_path / "after")], ahead=False)
    same_reports(tmp_path / "crashed", tmp_path / "after")


class FakeChild:
    """A drawing child that records what was asked of it."""

    pid = 0

    def __init__(self) -> None:
        self.cancelled = self.collected = False

    def cancel(self) -> None:
        self.cancelled = True

    def collect(self) -> dict[str, bytes]:
        self.collected = True
        return {"fit.png": b"x"}


def fake_ahead(monkeypatch: pytest.MonkeyPatch) -> tuple[ahead_module.AheadFigures, FakeChild]:
    """An AheadFigures on a fake child whose sending needs no pickling or pipe."""
    child = FakeChild()
    figs = ahead_module.AheadFigures(child, -1, -1, ("png",))  # type: ignore[arg-type]

    def send(result: object, auto: object = None) -> None:
        if figs._sent is None:
            figs._sent = (result, auto)  # type: ignore[assignment]

    monkeypatch.setattr(figs, "send", send)
    return figs, child


def test_figures_drawn_for_another_result_are_not_used(monkeypatch: pytest.MonkeyPatch) -> None:
    drawn_for, other = object(), object()
    figs, child = fake_ahead(monkeypatch)
    figs.send(drawn_for)  # type: ignore[arg-type]
    assert figs.collect(other, ("png",)) is None  # type: ignore[arg-type]
    assert child.cancelled and not child.collected
    assert figs.collect(drawn_for, ("png",)) is None  # type: ignore[arg-type]  # stopped
    figs, child = fake_ahead(monkeypatch)
    assert figs.collect(drawn_for, ("png", "svg")) is None  # type: ignore[arg-type]
    assert child.cancelled
    figs, child = fake_ahead(monkeypatch)
    figs.send(drawn_for, {"method": "arc-median"})  # type: ignore[arg-type]
    assert figs.collect(drawn_for, ("png",)) is None  # type: ignore[arg-type]  # another record
    figs, child = fake_ahead(monkeypatch)
    figs.send(drawn_for)  # type: ignore[arg-type]
    assert figs.collect(drawn_for, ("png",)) == {"fit.png": b"x"}  # type: ignore[arg-type]
    figs.cancel()
    assert child.collected and not child.cancelled
    figs, child = fake_ahead(monkeypatch)  # never sent before the report: sent there
    assert figs.collect(drawn_for, ("png",)) == {"fit.png": b"x"}  # type: ignore[arg-type]


def test_nothing_is_forked_without_figures_or_beside_another_thread(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    assert ahead_module.AheadFigures.start(()) is None
    monkeypatch.setattr(ahead_module, "fork_is_safe", lambda: False)
    assert ahead_module.AheadFigures.start(("png",)) is None

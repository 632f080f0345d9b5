"""The Python API: sonarproc.run / compare / read_log, RunResult, and docs/api.md run as a test."""

from __future__ import annotations

import contextlib
import io
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import sonarproc
from sonarproc.cli import main
from sonarproc.errors import ParameterError

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def fig12(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("api")
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["simulate", "fig12", "--out", str(folder / "fig12.h5")]) == 0
    return folder / "fig12.h5"


def test_import_is_cheap_and_names_are_stable() -> None:
    code = (
        "import sys, sonarproc; "
        "print(sorted(sonarproc.__all__)); "
        "print(any(m in sys.modules for m in ('sonarproc.api', 'numpy', 'sonarproc.pipeline')))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert out == ["['RunResult', '__version__', 'compare', 'read_log', 'run']", "False"]
    from sonarproc import api

    assert sonarproc.run is api.run and sonarproc.RunResult is api.RunResult
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = sonarproc.nope  # type: ignore[attr-defined]


def test_options_are_the_command_lines() -> None:
    from sonarproc.api import run_params
    from sonarproc.cli.options import build_run_params

    cli = build_run_params(cell=0.01, bbox=None, ops="thinning:3", fit="auto", order=None)
    assert run_params() == cli
    assert run_params(bbox=(0, 4, 0, 2), centre=[1, 1], arc_step=0.5) == build_run_params(
        cell=0.01, bbox="0,4,0,2", ops="thinning:3", fit="auto", order=None, centre="1,1",
        arc_step_deg=0.5,
    )  # fmt: skip
    with pytest.raises(ParameterError, match=r"^cel: is not an option \(options: cell, bbox"):
        run_params(cel=0.1)
    with pytest.raises(ParameterError, match=r"^cell: must be > 0 m, got -1\.0$"):
        run_params(cell=-1)
    with pytest.raises(ParameterError, match=r"^order: must be an integer or 'auto'"):
        run_params(order="nine")


def test_run_agrees_with_report_json(fig12: Path, capsys: pytest.CaptureFixture[str]) -> None:
    r = sonarproc.run(fig12, fit="poly", order=9)
    out = fig12.parent / "rep"
    assert main(["run", str(fig12), "--fit", "poly", "--order", "9", "--out", str(out)]) == 0
    capsys.readouterr()
    doc = json.loads((out / "report.json").read_text())
    assert set(r.metrics) == {"e", "f_c", "t_cpu_s", "E1_m", "E2"}
    for key in ("e", "f_c", "E1_m", "E2"):
        assert r.metrics[key] == pytest.approx(doc["metrics"][key], rel=1e-12)
    profile = np.loadtxt(out / "profile.csv", delimiter=",", skiprows=1)
    assert r.profile is not None
    np.testing.assert_allclose(r.profile, profile, atol=1e-6)
    assert r.surfaces == []
    for name in ("arcmap", "processed", "fit"):
        fig = r.figure(name)
        fig.savefig(fig12.parent / f"{name}.png")
        assert (fig12.parent / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(ParameterError, match=r"^figure: must be one of arcmap, processed, fit"):
        r.figure("map")


def test_compare_and_read_log(fig12: Path) -> None:
    lg = sonarproc.read_log(fig12)
    res = sonarproc.compare(lg, methods="morphological,arc-median", cell=0.02, fit="poly")
    assert list(res) == ["morphological", "arc-median"]
    assert all(
        isinstance(v, sonarproc.RunResult) and v.record.grid.cell == 0.02 for v in res.values()
    )
    assert res["morphological"].metrics["E1_m"] == pytest.approx(
        sonarproc.run(lg, cell=0.02, fit="poly").metrics["E1_m"], rel=1e-12
    )


def _blocks(text: str) -> list[tuple[str, str | None]]:
    """The ```python blocks of a page, each with the untagged block right after it (output)."""
    found = re.finditer(r"```python\n(.*?)```\n(?:\n```\n(.*?)```\n)?", text, re.S)
    return [(m.group(1), m.group(2)) for m in found]


def test_api_tutorial_runs(fig12: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = _blocks((ROOT / "docs/api.md").read_text(encoding="utf-8"))
    assert len(blocks) >= 5
    monkeypatch.chdir(fig12.parent)
    namespace: dict[str, object] = {}
    for code, want in blocks:
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            exec(compile(code, "docs/api.md", "exec"), namespace)
        if want is not None:
            assert buf.getvalue() == want, code
    assert (fig12.parent / "fit.png").stat().st_size > 1000


def test_the_documented_one_liner(fig12: Path) -> None:
    code = "import sonarproc; r = sonarproc.run('fig12.h5'); print(r.metrics)"
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=fig12.parent
    ).stdout
    assert re.fullmatch(r"\{'e': [0-9.e-]+, 'f_c': [0-9.]+, 't_cpu_s': [0-9.e-]+, .*\}\n", out)


def test_default_mode_aligns_and_measures_a_curve_once(
    fig12: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A one-curve log in run's default mode is handed on to --auto: its poses are aligned
    once for both, and only --auto's choice has its quality measured."""
    import sonarproc.pipeline.alignment as alignment
    import sonarproc.quality.measure as measure
    from sonarproc.api import run_params
    from sonarproc.pipeline import load_log
    from sonarproc.run_modes import run_log

    calls = {"align": 0, "quality": 0}
    align_log, measure_quality = alignment.align_log, measure.measure_quality

    def counted_align(*a: object, **k: object) -> object:
        calls["align"] += 1
        return align_log(*a, **k)  # type: ignore[arg-type]

    def counted_quality(*a: object, **k: object) -> object:
        calls["quality"] += 1
        return measure_quality(*a, **k)  # type: ignore[arg-type]

    monkeypatch.setattr(alignment, "align_log", counted_align)
    monkeypatch.setattr(measure, "measure_quality", counted_quality)
    monkeypatch.setattr("sonarproc.quality.measure_quality", counted_quality)
    monkeypatch.setattr("sonarproc.quality.of_auto.measure_quality", counted_quality)
    # aligned in this process, where it is counted (not in a child while the log is mapped)
    monkeypatch.setattr("sonarproc.pipeline.align_ahead.fork_is_safe", lambda: False)
    result, record = run_log(load_log(fig12), run_params(), "default")
    assert record is not None and record["mode"] == "default"
    assert calls == {"align": 1, "quality": 1}
    assert result.alignment is not None and result.quality is not None

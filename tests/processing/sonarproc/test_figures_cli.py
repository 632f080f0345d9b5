"""``--figures`` on ``run``, ``compare`` and ``watch``, and a watched truth log whose fit
runs far out of the map (it once crashed allocating terabytes to draw the curve)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarproc.cli import main
from sonarproc.report.run_report import report_files
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "configs" / "scenarios"
EXAMPLES = ROOT / "configs" / "sensors"
CSV_ARGS = [
    str(EXAMPLES / "example-readings.csv"),
    "--sensors", str(EXAMPLES / "example-sensors.yaml"),
    "--truth", str(EXAMPLES / "example-truth.csv"),
    "--cell", "0.02", "--json",
]  # fmt: skip


@pytest.fixture(scope="module")
def fig12(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("log") / "fig12.h5"
    simulate_to_log(SCENARIOS / "fig12.yaml", path)
    return path


@pytest.mark.parametrize("figures", ["none", "png", "svg", "png,svg"])
def test_run_writes_the_figures_asked_for(
    figures: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "r"
    assert main(["run", *CSV_ARGS, "--out", str(out), "--figures", figures]) == 0
    capsys.readouterr()
    formats = () if figures == "none" else tuple(figures.split(","))
    assert sorted(p.name for p in out.iterdir()) == sorted(report_files(formats))
    page = (out / "report.html").read_text(encoding="utf-8")
    # self-contained: every image is a data URI, every link a file that exists
    srcs = [s.split('"')[0] for s in page.split('src="')[1:]]
    assert all(s.startswith("data:image/") for s in srcs)
    hrefs = [h.split('"')[0] for h in page.split('href="')[1:]]
    assert all((out / h).is_file() for h in hrefs)
    assert len(srcs) == (0 if not formats else 3)
    assert ("image/png" in page) is ("png" in formats)
    if not formats:
        assert "No figures were written" in page
    for name in report_files(formats):
        assert (out / name).stat().st_size > 0


@pytest.mark.parametrize("bad", ["jpg", "png,pdf", "", "none,png"])
def test_a_bad_figures_value_is_one_line_and_exit_2(
    bad: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    for command in (
        ["run", *CSV_ARGS, "--out", str(tmp_path / "r")],
        ["compare", *CSV_ARGS, "--out", str(tmp_path / "c")],
        ["watch", str(tmp_path / "x.h5"), "--once", "--out", str(tmp_path / "w")],
    ):
        assert main([*command, "--figures", bad]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "Traceback" not in err
        assert "--figures" in err and "png,svg, png, svg or none" in err
        assert not (tmp_path / "r").exists() and not (tmp_path / "c").exists()


def test_compare_writes_the_figures_asked_for(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "c"
    args = ["compare", *CSV_ARGS, "--out", str(out), "--methods", "morphological,arc-vote"]
    assert main([*args, "--figures", "svg"]) == 0
    capsys.readouterr()
    names = sorted(p.name for p in out.iterdir())
    assert names == ["compare.csv", "compare.html", "compare.json", "compare.svg"]
    assert "data:image/svg+xml;base64," in (out / "compare.html").read_text(encoding="utf-8")


def test_watch_once_on_a_truth_log_with_an_extrapolating_fit(
    fig12: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A truth 45 m wide beside a 5 m map: the order-9 fit drawn over it reaches ~1e12 m."""
    truth = tmp_path / "wide-truth.csv"
    x = np.linspace(-20.0, 25.0, 400)
    np.savetxt(truth, np.column_stack((x, np.full_like(x, 2.0))), delimiter=",",
               header="x,y", comments="")  # fmt: skip
    out = tmp_path / "w"
    code = main(["watch", str(fig12), "--once", "--out", str(out), "--truth", str(truth),
                 "--fit", "poly", "--order", "9", "--figures", "png,svg"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "Traceback" not in captured.err + captured.out
    doc = json.loads((out / "report.json").read_text(encoding="utf-8"))
    assert doc["live"]["final"] is True and doc["fit"]["ok"] is True
    assert (out / "fit.png").stat().st_size > 0 and (out / "fit.svg").stat().st_size > 0


def test_watch_without_figures(
    fig12: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "w"
    assert main(["watch", str(fig12), "--once", "--out", str(out), "--figures", "none"]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in out.iterdir()) == sorted(report_files(()))

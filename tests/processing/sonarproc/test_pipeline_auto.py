"""End to end: the beyond-the-paper options of ``sonarproc run`` on saturated scenarios."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarproc.cli import main
from sonarproc.params import RunParams
from sonarproc.pipeline import run_file
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]
AUTO = {"ops": "vote:auto,ridge", "robust": "huber", "auto_order": True, "span": "points"}


@pytest.fixture(scope="module")
def fig12(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("fig12") / "fig12.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig12.yaml", out)
    return out


@pytest.fixture(scope="module")
def fig10c(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("fig10c") / "fig10c.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig10c.yaml", out)
    return out


def test_auto_beats_the_papers_method_on_the_saturated_sinusoid(fig12: Path) -> None:
    paper = run_file(fig12, RunParams(ops="thinning:6", order=10))
    auto = run_file(fig12, RunParams(**AUTO))  # type: ignore[arg-type]
    assert paper.metrics.E1_m is not None and auto.metrics.E1_m is not None
    # the paper's method on the saturated binary map: blobs, a flattened fit
    assert paper.metrics.f_c > 0.95 and paper.metrics.E2 is not None and paper.metrics.E2 > 0.6
    # the vote keeps the crest: sub-centimetre within the columns the sonars saw
    assert auto.metrics.E1_m < 0.01 and auto.metrics.e is not None and auto.metrics.e < 0.1
    assert auto.metrics.E1_m < 0.2 * paper.metrics.E1_m
    assert auto.fit.ok and 8 <= auto.fit.order <= 15
    doc = auto.fit.to_json()
    assert doc["method"] == "huber irls" and str(auto.fit.order) in doc["order_selection"]["scores"]
    # --span points judges fewer columns than the truth spans, never more
    whole = run_file(fig12, RunParams(**{**AUTO, "span": "truth"}))  # type: ignore[arg-type]
    assert auto.metrics.N < whole.metrics.N
    assert auto.metrics.N_k == whole.metrics.N_k
    np.testing.assert_array_equal(auto.processed, whole.processed)


def test_the_vote_alone_helps_on_saturated_fig10c(fig10c: Path) -> None:
    base = run_file(fig10c, RunParams(ops="thinning:5", order=6))
    voted = run_file(fig10c, RunParams(ops="vote:auto,ridge", order=6))
    assert base.metrics.E1_m is not None and voted.metrics.E1_m is not None
    assert voted.metrics.E1_m < 0.25 * base.metrics.E1_m
    # the default fit is the paper's least squares and says nothing more
    assert "method" not in base.fit.to_json() and "order_selection" not in base.fit.to_json()


def test_the_robust_fit_alone_helps_on_fig06b(tmp_path: Path) -> None:
    log = tmp_path / "fig06b.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig06b.yaml", log)
    plain = run_file(log, RunParams(ops="thinning:3", order=7, span="points"))
    robust = run_file(log, RunParams(ops="thinning:3", order=7, span="points", robust="huber"))
    assert plain.metrics.E1_m is not None and robust.metrics.E1_m is not None
    # the same points; the thinned blobs pull least squares, not the Huber fit
    assert robust.points_x.size == plain.points_x.size
    assert robust.metrics.E1_m < 0.7 * plain.metrics.E1_m


def test_cli_options_and_report(
    tmp_path: Path, fig10c: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "rep"
    rc = main(["run", str(fig10c), "--out", str(out), "--ops", "vote:auto,ridge",
               "--order", "auto", "--robust", "huber", "--span", "points", "--json"])  # fmt: skip
    captured = capsys.readouterr()
    assert rc == 0, captured.err
    doc = json.loads(captured.out)
    assert doc["parameters"]["order"] == "auto" and doc["parameters"]["robust"] == "huber"
    assert doc["parameters"]["span"] == "points" and doc["fit"]["order"] >= 1
    assert doc["metrics"]["E1_m"] < 0.01
    for args, message in (
        (["--robust", "tukey"], "--robust: must be one of none, huber"),
        (["--span", "all"], "--span: must be one of truth, points"),
        (["--order", "many"], "--order: must be an integer or 'auto'"),
        (["--fit", "spline", "--order", "auto"], "--fit: must be poly for an automatic order"),
        (["--fit", "polar", "--span", "points"], "--span: points applies to"),
        (["--ops", "vote:0"], "K must be >= 1"),
    ):
        assert main(["run", str(fig10c), "--out", str(tmp_path / "x"), *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err

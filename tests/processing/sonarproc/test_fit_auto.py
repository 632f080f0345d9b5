"""``--fit auto``: the paper's polynomial on the paper's scenes, surfaces in a corridor."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarproc.cli import main
from sonarproc.grid import Grid
from sonarproc.pipeline.surfacefit import choose_fit, column_spans


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("auto")
    out = {}
    for name in ("fig16", "corridor-l"):
        out[name] = d / f"{name}.h5"
        assert main(["simulate", name, "--out", str(out[name])]) == 0
    return out


def report(out: Path) -> dict:  # type: ignore[type-arg]
    return json.loads((out / "report.json").read_text())


def test_paper_scene_gets_the_papers_polynomial(
    logs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    no_figures = ["--figures", "none"]  # the fits are compared, not figures
    assert (
        main(
            ["run", str(logs["fig16"]), "--fit", "auto", "--out", str(tmp_path / "a"), *no_figures]
        )
        == 0
    )
    assert (
        main(
            ["run", str(logs["fig16"]), "--fit", "poly", "--out", str(tmp_path / "p"), *no_figures]
        )
        == 0
    )
    auto, poly = report(tmp_path / "a"), report(tmp_path / "p")
    assert auto["fit_choice"]["choice"] == "function" and "surfaces" not in auto
    assert auto["fit"]["coefficients"] == poly["fit"]["coefficients"]
    assert auto["metrics"]["E1_m"] == poly["metrics"]["E1_m"]
    assert not (tmp_path / "a" / "surfaces.csv").exists()


def test_corridor_gets_surfaces(
    logs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "c"
    assert main(["run", str(logs["corridor-l"]), "--out", str(out)]) == 0
    assert "warning" not in capsys.readouterr().err
    doc = report(out)
    assert doc["fit_choice"]["choice"] == "surfaces" and len(doc["surfaces"]) >= 4
    assert "E1_m" not in doc["metrics"]  # the truth is several surfaces
    assert doc["metrics"]["precision_m"] <= 0.03 and doc["metrics"]["completeness"] >= 0.8
    rows = (out / "surfaces.csv").read_text().splitlines()
    assert rows[0] == "surface,kind,x,y" and len(rows) > 100
    geo = json.loads((out / "surfaces.geojson").read_text())
    assert geo["type"] == "FeatureCollection" and len(geo["features"]) == len(doc["surfaces"])


def test_nothing_left_is_zero_surfaces_and_a_warning(
    logs: dict[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "e"
    args = ["run", str(logs["corridor-l"]), "--out", str(out), "--ops", "vote:100000"]
    assert main(args) == 0
    err = capsys.readouterr().err
    assert "no surface found" in err and "Traceback" not in err
    assert report(out)["surfaces"] == []


def test_column_spans_and_the_fast_path() -> None:
    g = Grid(x0=0.0, y0=0.0, cell=0.01, nx=200, ny=300)
    m = np.zeros(g.shape, bool)
    m[100, 10:190] = True
    assert column_spans(m, g.cell).max() == pytest.approx(0.01)
    assert choose_fit(m, m.astype(np.uint32) * 3, g).choice == "function"
    m[250, 10:190] = True  # a second wall 1.5 m away: a corridor
    counts = m.astype(np.uint32) * 5
    assert choose_fit(m, counts, g).choice == "surfaces"

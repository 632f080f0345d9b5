"""A surfaces fit is one successful result that run, report.html, watch and sweep agree on.

Simulated rooms (shipped scenarios, seed 1) run with ``sonarproc run``'s defaults; a
report written before the v3 record (``tests/data/report_v2_surfaces.json``, a room-box
run whose fit was recorded as failed) is read back in today's shape.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path

import pytest

from sonarproc.cli import main
from sonarproc.report import read_report
from sonarproc.report.html import render_html
from sonarproc.report.summary import summary_line

ROOMS = ("room-box", "corridor-l", "hall-pillar")
OLD_REPORT = Path(__file__).resolve().parents[2] / "data" / "report_v2_surfaces.json"
KINDS = {"plane", "curve", "cylinder", "corner", "edge"}


@pytest.fixture(scope="module")
def rooms(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Each room simulated with seed 1 and run with the defaults: its report directory."""
    base = tmp_path_factory.mktemp("rooms")
    out = {}
    for name in ROOMS:
        log = base / f"{name}.h5"
        assert main(["simulate", name, "--out", str(log), "--seed", "1"]) == 0
        rep = base / f"{name}_report"
        assert main(["run", str(log), "--out", str(rep), "--figures", "none", "--json"]) == 0
        out[name] = rep
    return out


def _html_rows(page: str) -> list[list[str]]:
    """The data rows of report.html's surfaces table, cell texts."""
    table = re.search(r'<table class="surfaces">(.*?)</table>', page)
    assert table is not None, "no surfaces table"
    rows = re.findall(r"<tr>(.*?)</tr>", table.group(1))
    return [re.findall(r"<td>(.*?)</td>", r) for r in rows[1:]]


@pytest.mark.parametrize("name", ROOMS)
def test_a_room_is_a_successful_surfaces_fit(rooms: dict[str, Path], name: str) -> None:
    doc = json.loads((rooms[name] / "report.json").read_text())
    fit, surfaces, metrics = doc["fit"], doc["surfaces"], doc["metrics"]
    assert fit["kind"] == "surfaces" and fit["ok"] is True and "reason" not in fit
    fitted = [s for s in surfaces if s["ok"]]
    assert fit["surfaces"] == len(fitted) >= 4
    assert sum(fit["kinds"].values()) == fit["surfaces"]
    for i, s in enumerate(fitted):
        assert s["surface"] == i and s["kind"] in KINDS
        assert s["kind"] == {"line": "plane", "arc": "cylinder", "spline": "curve"}[s["model"]]
        assert s["length_m"] > 0 and s["rms_m"] >= 0 and s["support"] > 0
    # a multi-surface truth: precision and completeness in metrics, no E1/E2, nothing at top
    assert 0 < metrics["precision_m"] < 0.05 and 0.5 < metrics["completeness"] <= 1.0
    assert "E1_m" not in metrics and "E2" not in metrics
    assert "precision_m" not in doc and "completeness" not in doc
    # report.html lists every surface, lengths by the units function (cm)
    rows = _html_rows((rooms[name] / "report.html").read_text())
    assert len(rows) == len(surfaces)
    for s, row in zip(fitted, rows, strict=False):
        assert row[:3] == [str(s["surface"]), s["kind"], s["model"]]
        assert row[3].endswith(" cm") and row[4].endswith(" cm") and row[5] == str(s["support"])
    page = (rooms[name] / "report.html").read_text()
    assert "Fit failed" not in page and "precision_m" not in page
    # surfaces.csv numbers the surfaces as report.json does
    with (rooms[name] / "surfaces.csv").open() as fh:
        ids = sorted({int(r["surface"]) for r in csv.DictReader(fh)})
    assert ids == list(range(len(fitted)))


def test_an_old_report_reads_in_todays_shape() -> None:
    raw = json.loads(OLD_REPORT.read_text())
    assert raw["fit"]["ok"] is False and raw["precision_m"] is None  # the v2 shape
    doc = read_report(OLD_REPORT)
    assert doc["fit"] == {
        "kind": "surfaces", "ok": True, "surfaces": 8, "failed": 0, "kinds": {"plane": 8},
    }  # fmt: skip
    assert "precision_m" not in doc and "completeness" not in doc
    assert doc["metrics"]["precision_m"] == raw["metrics"]["precision_m"]
    assert [s["kind"] for s in doc["surfaces"]] == ["plane"] * 8
    line = summary_line(doc)
    assert line.startswith("1504 used, e —, f_c 0.998, 8 surfaces, precision 0.654 cm")
    assert len(_html_rows(render_html(doc, {}))) == 8
    assert read_report(OLD_REPORT.parent / OLD_REPORT.name) == doc


def test_a_current_report_is_unchanged_by_the_reader(rooms: dict[str, Path]) -> None:
    path = rooms["room-box"] / "report.json"
    assert read_report(path) == json.loads(path.read_text())


def test_sweep_scores_surfaces(tmp_path: Path) -> None:
    out = tmp_path / "sw"
    assert main(["sweep", "room-box", "--grid", "fit=auto", "--out", str(out)]) == 0
    with (out / "results.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 1
    r = rows[0]
    assert r["fit"] == "auto" and r["ok"] == "True" and r["fit_ok"] == "True"
    assert int(r["surfaces"]) >= 4 and r["E1_m"] == ""
    assert 0 < float(r["precision_m"]) < 0.05 and 0.5 < float(r["completeness"]) <= 1.0


def test_watch_once_on_a_truth_log(rooms: dict[str, Path], tmp_path: Path) -> None:
    log = rooms["room-box"].parent / "room-box.h5"
    out = tmp_path / "live"
    assert main(["watch", str(log), "--out", str(out), "--once", "--figures", "none"]) == 0
    doc = json.loads((out / "report.json").read_text())
    assert doc["fit"]["ok"] is True and doc["fit"]["surfaces"] >= 4
    assert len(_html_rows((out / "report.html").read_text())) == len(doc["surfaces"])


def test_sweep_best_of_surfaces_rows_is_the_most_complete_then_precise() -> None:
    from sonarproc.cli.sweep import best_line
    from sonarproc.sweep.merge import best_rows

    def row(i: int, prec: float, comp: float) -> dict[str, object]:
        base = {"input": "room", "ok": True, "fit_ok": True, "fit": "auto", "E1_m": None}
        return {**base, "index": i, "f_c": 1.0, "precision_m": prec, "completeness": comp}

    best = best_rows([row(0, 0.004, 0.70), row(1, 0.006, 0.951), row(2, 0.005, 0.948)])
    assert best["room"]["row"]["index"] == 2  # completeness ties to 0.01, then precision
    assert best["room"]["criterion"].startswith("max completeness")
    line = best_line("room", best["room"])
    assert line.endswith("precision 0.500 cm, completeness 0.948")

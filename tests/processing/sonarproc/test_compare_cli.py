"""Tests for ``sonarproc compare`` through ``sonarproc.cli.main``."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from sonarproc.cli import main
from sonarproc.methods import DEFAULT_METHODS
from sonarproc.methods.compare import COLUMNS
from sonarproc.report.units import sig3
from sonarproc.simulate import simulate_to_log

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def fig16(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("sim") / "fig16.h5"
    simulate_to_log(SCENARIOS / "fig16.yaml", path)
    return path


def test_compare_writes_every_file(
    fig16: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "cmp"
    code = main(
        [
            "compare",
            str(fig16),
            "--out",
            str(out),
            "--ops",
            "erosion,pruning",
            "--order",
            "10",
            "--set",
            "occupancy.select=ridge",
            "--figures",
            "png,svg",
            "--json",
        ]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    names = list(DEFAULT_METHODS)
    assert "directional-max" in names and "arc-median" in names and "triangulation" in names
    assert [r["method"] for r in doc["methods"]] == names
    assert doc["options"]["occupancy"]["select"] == "ridge"
    assert doc["parameters"]["ops"] == "erosion,pruning" and doc["truth"] is True
    assert json.loads((out / "compare.json").read_text()) == doc
    with (out / "compare.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == COLUMNS
    assert [r[0] for r in rows[1:]] == names
    for row, rec in zip(rows[1:], doc["methods"], strict=True):
        assert float(row[COLUMNS.index("E1_m")]) == pytest.approx(rec["E1_m"], rel=1e-5)
        assert float(row[COLUMNS.index("f_c")]) == pytest.approx(rec["f_c"], rel=1e-5)
        assert row[COLUMNS.index("fit_ok")] == "true"
        assert row[COLUMNS.index("fit")] == rec["fit"] == "order 10"
        assert rec["E1_m"] > 0 and rec["t_cpu_s"] > 0
    png = (out / "compare.png").read_bytes()
    assert png.startswith(PNG)
    html = (out / "compare.html").read_text()
    assert "data:image/png;base64," in html and "<script" not in html and 'src="http' not in html
    for rec in doc["methods"]:  # people read lengths in cm, 3 significant figures
        assert f"<td>{sig3(100 * rec['E1_m'])}</td>" in html and rec["method"] in html
    assert "E1 (cm)" in html
    assert (out / "compare.svg").read_text().lstrip().startswith("<?xml")
    # the morphological row is sonarproc run's result on the same options
    run_out = tmp_path / "run"
    assert (
        main(
            [
                "run",
                str(fig16),
                "--out",
                str(run_out),
                "--ops",
                "erosion,pruning",
                "--order",
                "10",
                "--json",
            ]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    for key in ("e", "f_c", "E1_m", "E2"):
        assert doc["methods"][0][key] == pytest.approx(report["metrics"][key])


def test_compare_table_and_subset(
    fig16: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "two"
    assert (
        main(
            [
                "compare",
                str(fig16),
                "--methods",
                "line-of-sight,histogram",
                "--out",
                str(out),
                "--order",
                "3",
                "--export",
                "geojson",
            ]
        )
        == 0
    )
    text = capsys.readouterr().out
    assert "line-of-sight" in text and "histogram" in text and "morphological" not in text
    assert "order 3" in text
    # a spline is named as one, not by its degree
    spl = tmp_path / "spline"
    assert main(["compare", str(fig16), "--methods", "histogram", "--out", str(spl),
                 "--fit", "spline", "--json"]) == 0  # fmt: skip
    row = json.loads(capsys.readouterr().out)["methods"][0]
    assert row["fit"] == "spline" and row["fit_ok"] is True
    with (out / "compare.csv").open() as fh:
        assert len(list(csv.reader(fh))) == 3
    assert sorted(p.name for p in (out / "export").iterdir()) == [
        "histogram.geojson",
        "line-of-sight.geojson",
    ]


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--methods", "foo"], "got 'foo'"),
        (["--methods", ""], "must name at least one method"),
        (["--set", "occupancy.zzz=1"], "has no option 'zzz'"),
        (["--set", "occupancy.select=ridge", "--methods", "histogram"], "not being run"),
        (["--set", "nonsense"], "METHOD.OPTION=VALUE"),
        (["--cell", "0"], "cell: must be > 0"),
        (["--ops", "thinning:0"], "thinning"),
        (["--export", "shp"], "--format: must be among"),
        (["--fit", "cubic"], "fit: must be"),
    ],
)
def test_compare_usage_errors(
    fig16: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], needle: str
) -> None:
    code = main(["compare", str(fig16), "--out", str(tmp_path / "x"), *args])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("sonarproc: error: ") and needle in err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "x").exists()


def test_compare_missing_log_and_unwritable_out(
    fig16: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["compare", str(tmp_path / "none.h5")]) == 2
    assert "no such file" in capsys.readouterr().err
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert (
        main(["compare", str(fig16), "--methods", "line-of-sight", "--out", str(blocker / "d")])
        == 2  # the user's mistake, found before any work
    )
    err = capsys.readouterr().err
    assert err.startswith("sonarproc: error: ") and err.count("\n") == 1


def test_compare_csv_log_without_truth(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sensors = SCENARIOS.parent / "sensors"
    out = tmp_path / "csvlog"
    code = main(
        [
            "compare",
            str(sensors / "example-readings.csv"),
            "--sensors",
            str(sensors / "example-sensors.yaml"),
            "--fit",
            "spline",
            "--out",
            str(out),
            "--json",
            "--figures",
            "none",  # the table is looked at, not figures
        ]
    )
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["truth"] is False
    for rec in doc["methods"]:
        assert rec["E1_m"] is None and rec["E2"] is None and rec["e"] is None
        assert 0 < rec["f_c"] <= 1 and rec["fit_ok"]
    with (out / "compare.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert [r["E1_m"] for r in rows] == [""] * len(DEFAULT_METHODS)


def test_compare_help_names_every_default_method(capsys: pytest.CaptureFixture[str]) -> None:
    # the help text is static (importing the methods would slow every command's start)
    assert main(["compare", "--help"]) == 0
    help_text = "".join(capsys.readouterr().out.split())
    for name in DEFAULT_METHODS:
        assert name in help_text, name

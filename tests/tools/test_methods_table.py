"""Tests for sonarmorph_tools.methods_table: the generated comparison tables of docs/methods.md."""

from __future__ import annotations

from pathlib import Path

import pytest

from sonarmorph_tools.methods_table import (
    END,
    START,
    main,
    render_auto_table,
    render_surface_table,
    render_tables,
    splice,
)


def _row(method: str, e1: float | None, fc: float) -> dict[str, object]:
    return {"method": method, "e": 0.5, "f_c": fc, "E1_m": e1, "E2": 0.1, "t_cpu_s": 0.002}


def test_render_tables_values_and_best() -> None:
    rows = {
        "fig16": [
            _row("morphological", 0.1959, 0.864),
            _row("arc-vote", 0.028, 0.9),
            _row("line-of-sight", None, 0.364),
            _row("histogram", 0.5, 0.364),
            _row("occupancy", 0.0206, 1.0),
        ]
    }
    text = render_tables(rows)
    # columns: morphological, arc-vote, directional-max, arc-median, triangulation,
    # line-of-sight, histogram, occupancy (the three without a row here: —)
    row = "| fig16 (erosion,pruning, 10) | "
    assert row + "19.59 | 2.80 | — | — | — | — | 50.00 | **2.06** |" in text
    assert row + "0.864 | 0.900 | — | — | — | 0.364 | 0.364 | **1.000** |" in text
    assert row + "2.0 | 2.0 | — | — | — | 2.0 | 2.0 | 2.0 |" in text  # t_cpu, no bold


def test_splice_and_main(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    doc = f"# t\n\n{START}\nold\n{END}\n\ntail\n"
    assert splice(doc, "NEW\n") == f"# t\n\n{START}\n\nNEW\n\n{END}\n\ntail\n"
    with pytest.raises(ValueError, match="markers"):
        splice("no markers", "x")
    empty = tmp_path / "scen"
    empty.mkdir()
    target = tmp_path / "doc.md"
    target.write_text(doc)
    assert main(["--doc", str(target), "--scenarios", str(empty)]) == 0
    assert "old" not in target.read_text() and "`occupancy`" in target.read_text()
    bad = tmp_path / "bad.md"
    bad.write_text("nothing")
    assert main(["--doc", str(bad), "--scenarios", str(empty)]) == 2
    assert "markers" in capsys.readouterr().err


def test_render_auto_table() -> None:
    row = {
        "choice": "dirmax/spline@0.1", "metric": "E1_m", "auto_error_m": 0.0036,
        "auto_completeness": None, "best": "dirmax/spline@0.1", "best_error_m": 0.0036,
        "ratio": 1.0, "auto_s": 1.84, "readings": 10794, "auto_columns": 580,
        "best_columns": 601,
    }  # fmt: skip
    room = {
        **row, "auto_columns": None, "best_columns": None, "choice": "surfaces",
        "metric": "precision_m", "auto_error_m": 0.0672,
        "auto_completeness": 0.933, "best": "surfaces", "best_error_m": 0.0672, "readings": 3216,
    }  # fmt: skip
    fig13 = {**row, "auto_error_m": float("inf"), "ratio": float("inf"), "readings": 47}
    text = render_auto_table({"wavy-bistatic": [row], "room-box": [room], "fig13": [fig13]})
    want = (
        "| wavy-bistatic | 10794 | E1 | dirmax/spline@0.1 | 0.36 | dirmax/spline@0.1 | 0.36 "
        "| 1.00 | 580 / 601 | 1.8 |"
    )
    assert want in text and text.count("\n|") == 5
    assert "| 1.00 | — | 1.8 |" in text  # several surfaces: no columns
    assert "| room-box | 3216 | precision (auto complete 0.93) | surfaces | 6.72 |" in text
    assert "| fig13 | 47 | E1 | dirmax/spline@0.1 | undefined |" in text


def test_render_surface_table() -> None:
    rows = {
        "fig02": [{"method": "morphological", "E1_m": 0.06}],
        "room-box": [
            {"method": "morphological", "surfaces": True, "precision_m": 0.0523,
             "completeness": 0.9},
            {"method": "occupancy", "surfaces": True, "precision_m": None, "completeness": None},
        ],
    }  # fmt: skip
    text = render_surface_table(rows)
    assert "| room-box | 5.23 / 0.90 | — |" in text and "fig02" not in text
    assert render_surface_table({"fig02": rows["fig02"]}) == ""


def test_only_names_scenarios_of_the_shipped_and_test_folders(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    doc = tmp_path / "doc.md"
    doc.write_text(f"{START}\n{END}\n")
    # default folders: the shipped scenarios and tests/data/scenarios; a name in neither
    assert main(["--doc", str(doc), "--only", "fig12", "--only", "wavy-sparse", "--only",
                 "nope"]) == 2  # fmt: skip
    assert capsys.readouterr().err.strip() == "methods_table: error: --only: no scenario nope"
    assert doc.read_text() == f"{START}\n{END}\n"


def test_a_test_scenario_runs_from_its_folder(capsys: pytest.CaptureFixture[str]) -> None:
    # one small test scenario, its world and sensors reached through ../../../configs
    assert main(["--doc", "unused.md", "--stdout", "--only", "auto7-ring-hump"]) == 0
    out = capsys.readouterr().out
    assert "| auto7-ring-hump (thinning:3, 9) |" in out
    assert out.count("| auto7-ring-hump |") == 1  # the --auto row

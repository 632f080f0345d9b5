"""Tests for sonarproc.studies.methods_table: the generated comparison tables of docs/methods.md."""

from __future__ import annotations

from pathlib import Path

import pytest

from sonarproc.studies.methods_table import (
    END,
    START,
    main,
    render_auto_table,
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
        "choice": "dirmax/spline@0.1", "auto_E1_m": 0.0036, "best": "dirmax/spline@0.1",
        "best_E1_m": 0.0036, "ratio": 1.0, "auto_s": 1.84, "readings": 10794,
    }  # fmt: skip
    text = render_auto_table({"wavy-bistatic": [row]})
    want = (
        "| wavy-bistatic | 10794 | dirmax/spline@0.1 | 0.36 | dirmax/spline@0.1 | 0.36 "
        "| 1.00 | 1.8 |"
    )
    assert want in text and text.count("\n|") == 3

"""Tests for sonarproc.studies.methods_table: the generated comparison tables of docs/methods.md."""

from __future__ import annotations

from pathlib import Path

import pytest

from sonarproc.studies.methods_table import END, START, main, render_tables, splice


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
    assert "| fig16 (erosion,pruning, 10) | 19.59 | 2.80 | — | 50.00 | **2.06** |" in text
    assert "| fig16 (erosion,pruning, 10) | 0.864 | 0.900 | 0.364 | 0.364 | **1.000** |" in text
    assert "| fig16 (erosion,pruning, 10) | 2.0 | 2.0 | 2.0 | 2.0 | 2.0 |" in text  # t_cpu, no bold


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

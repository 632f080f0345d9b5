"""The study of ``--auto`` as a combination of its best candidates (auto_median)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from sonarproc.auto import Score
from sonarproc.auto.candidates import Candidate
from sonarproc.metrics import bin_stats
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.simulate import simulate_to_log
from sonarproc.studies.auto_median import (
    VARIANTS,
    MedianRow,
    combine,
    main,
    render,
    scenario_row,
)
from sonarproc.studies.auto_study import auto_row

ROOT = Path(__file__).resolve().parents[3]
CENTRES = np.arange(10.0)


def _member(residual: float, offset: float, cols: tuple[int, int]) -> tuple[Score, Any]:
    """A scored candidate whose points span columns ``cols`` and whose fit is y = x + offset."""
    s = Score(Candidate("c/spline", "arc-vote", "spline"))
    s.residual_m = residual
    idx = np.arange(cols[0], cols[1] + 1)
    run = SimpleNamespace(
        bins=bin_stats(idx, idx.astype(float), CENTRES), fit=lambda x: np.asarray(x) + offset
    )
    return s, run


def test_combine_median_and_weighted_mean_on_the_common_columns() -> None:
    chosen = [_member(0.01, 0.0, (2, 8)), _member(0.02, 1.0, (0, 6)), _member(0.01, 5.0, (3, 9))]
    x, y = combine(chosen, "median")  # type: ignore[arg-type]
    assert x.tolist() == [3.0, 4.0, 5.0, 6.0]
    assert np.array_equal(y, x + 1.0)  # the middle one: a bad member does not pull
    x, y = combine(chosen, "wmean")  # type: ignore[arg-type]
    # weights 1/r^2: 10 000, 2 500, 10 000
    assert np.allclose(y, x + (0.0 * 4 + 1.0 * 1 + 5.0 * 4) / 9)


def test_combine_on_the_first_members_columns() -> None:
    chosen = [_member(0.01, 0.0, (2, 8)), _member(0.01, 1.0, (0, 6)), _member(0.01, 3.0, (5, 9))]
    x, y = combine(chosen, "median", "first")  # type: ignore[arg-type]
    assert x.tolist() == [2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
    # columns 2-4: members 0 and 1 (mean 0.5); 5-6: all three (median 1); 7-8: 0 and 2 (1.5)
    assert np.allclose(y - x, [0.5, 0.5, 0.5, 1.0, 1.0, 1.5, 1.5])


def test_scenario_row_on_fig06a(tmp_path: Path) -> None:
    path = tmp_path / "fig06a.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig06a.yaml", path)
    lg = load_log(path)
    row = scenario_row(lg, RunParams(cell=0.01))
    ref = auto_row(lg, RunParams(cell=0.01))
    assert row.errors["auto"] == pytest.approx(ref["auto_error_m"])
    assert row.best_error_m == pytest.approx(ref["best_error_m"])
    assert set(row.errors) == set(VARIANTS)
    assert all(np.isfinite(e) and 0 < e < 0.05 for e in row.errors.values())
    names = row.members["median3"].split(", ")
    assert len(names) == 3 and names[0] == ref["choice"]
    assert len({n.split("/")[0] for n in names}) == 3  # three distinct methods
    assert row.members["median2"].split(", ") == names[:2]


def test_render_and_summaries() -> None:
    errs = dict.fromkeys(VARIANTS, 0.02) | {"median3": 0.012, "auto@span": 0.015}
    rows = {
        "fig02": MedianRow("a@0.4", 0.01, dict.fromkeys(VARIANTS, "a@0.4, b@0.2"), errs),
        "auto3-x": MedianRow("a@0.4", 0.01, dict.fromkeys(VARIANTS, "a@0.4"), errs),
    }
    text = render(rows, held=("auto3-x",))
    assert "| fig02 | 1.00 | 2.00 | 1.50 | 2.00 | 1.20 | 2.00 | 2.00 | 2.00 | 2.00 |" in text
    assert "| auto3-x (held aside) |" in text
    assert "- `median3`: tuned on: 1/1 within 1.2x, mean ratio 1.20" in text
    assert "- `median3` against `auto@span` (the same columns): tuned on: mean 0.80" in text


def test_study_refuses_a_missing_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--scenarios", str(tmp_path / "none")]) == 2
    assert "--scenarios" in capsys.readouterr().err

"""The ends of ``--auto``'s profile: echo points, supported spans, cuts, and the study."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarproc.auto import CANDIDATES, Score
from sonarproc.auto.holdout import predicted_path
from sonarproc.auto.select import candidate_map, evaluate_candidate
from sonarproc.fit import fit_polynomial
from sonarproc.methods.testing import flat_wall_beams
from sonarproc.metrics import Bins
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.simulate import simulate_to_log
from sonarproc.studies.auto_ends import RULES, EndsRow, render
from sonarproc.studies.end_cuts import (
    COVERAGE_FLOOR,
    echo_points,
    make_cut,
    span_by_echoes,
    span_by_end_residuals,
    span_by_support,
)

ROOT = Path(__file__).resolve().parents[3]


def test_echo_points_match_the_first_echo_model_on_a_flat_wall() -> None:
    beams, _ = flat_wall_beams()
    xs = np.linspace(-1.0, 3.0, 81)
    fit = fit_polynomial(xs, np.ones_like(xs), np.ones_like(xs), order=1)
    rows = np.arange(beams.path.size, dtype=np.intp)
    path, ex = echo_points(fit, beams, rows, 0.01)
    np.testing.assert_allclose(path, predicted_path(fit, beams, rows, 0.01), atol=1e-12)
    np.testing.assert_allclose(path, 2.0, atol=2e-3)  # 1 m away, there and back
    # a monostatic echo off a flat wall comes from the foot of the perpendicular
    np.testing.assert_allclose(ex, beams.poses.tx_xy[:, 0], atol=0.051)


def test_spans_and_the_coverage_floor() -> None:
    x = np.arange(100.0) * 0.01
    count = np.r_[np.ones(10, int), np.full(80, 8), np.ones(10, int)]
    b = Bins(x, count, np.zeros(100), np.zeros(100))
    span = span_by_support(b, 0.5)
    assert span is not None
    lo, hi = span
    assert 0.04 <= lo <= 0.1 and 0.89 <= hi <= 0.95
    cut = make_cut("support", b, (lo, hi), "thin ends")
    assert cut.cuts and cut.kept == int(((x >= lo) & (x <= hi)).sum())
    assert cut.to_json()["x_range_m"] == [round(lo, 4), round(hi, 4)]
    small = make_cut("support", b, (0.2, 0.5), "thin ends")
    assert not small.cuts and small.fraction == 1.0 and "at least 70%" in small.reason
    assert COVERAGE_FLOOR == 0.7
    ex = np.linspace(0.0, 1.0, 11)
    loss = np.where(ex < 0.75, 0.001, 0.05)
    assert span_by_echoes(ex, loss, 0.01, 0.0) == pytest.approx((0.0, 0.7))
    assert span_by_end_residuals(ex, np.zeros(11), 3.0) is None  # too few slices


@pytest.fixture(scope="module")
def fig06a(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ends") / "fig06a.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig06a.yaml", out)
    return out


def test_a_cut_refits_only_the_columns_kept(fig06a: Path) -> None:
    lg = load_log(fig06a)
    base = RunParams(cell=0.01)
    cand = next(c for c in CANDIDATES if c.name == "median/spline")
    s = Score(cand)
    s.setting = 0.4
    cm = candidate_map(lg, base, s)
    whole = evaluate_candidate(lg, cm).run
    x0, x1 = float(whole.points_x.min()), float(whole.points_x.max())
    span = (x0 + 0.15 * (x1 - x0), x1 - 0.1 * (x1 - x0))
    cut = evaluate_candidate(lg, cm, span=span).run
    assert cut.points_x.min() >= span[0] - 1e-9 and cut.points_x.max() <= span[1] + 1e-9
    inside = (whole.points_x >= span[0] - 1e-9) & (whole.points_x <= span[1] + 1e-9)
    np.testing.assert_array_equal(cut.points_y, whole.points_y[inside])
    assert cut.metrics.N < whole.metrics.N  # judged on the kept columns only


def test_the_study_renders_each_set_apart() -> None:
    row = EndsRow("a@0.4", "b@0.2", 0.01, {r: (0.02, 2.0, 0.9, 0.8) for r in RULES})
    out = render({"fig02": row, "auto4-x": row, "auto-y": row}, held=("auto-y",))
    assert "| auto4-x (held aside) |" in out and "| fig02 |" in out
    line = next(ln for ln in out.splitlines() if ln.startswith("- `echoes:3`"))
    assert "tuned on: 0/1 within 1.2x, mean ratio 2.00" in line
    assert "held aside: 0/1" in line and "auto4: 0/1" in line and "kept 0.80" in line

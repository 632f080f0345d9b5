"""``--auto``: the held-out range criterion, guard rails, CLI record, and where it stands."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sonarlog.schema import empty_readings
from sonarmorph_tools.auto_judge import auto_row
from sonarproc.arcs import arcs_of, rasterize
from sonarproc.auto import CANDIDATES, HULL_CELLS, Score, choose, run_auto
from sonarproc.auto.candidates import Candidate
from sonarproc.auto.holdout import firing_folds, hull_excess, range_loss, subset_beams
from sonarproc.auto.score import COVERAGE_MIN, TRIM, robust_residual
from sonarproc.auto.scoring import fold_scores, implied_span
from sonarproc.auto.select import _sample_firings
from sonarproc.cli import main
from sonarproc.methods.testing import flat_wall_beams
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.pipeline.selection import select_beams
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def sparse(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("auto") / "wavy-sparse.h5"
    simulate_to_log(ROOT / "tests/data/scenarios/wavy-sparse.yaml", out)
    return out


def test_folds_keep_firings_together() -> None:
    r = empty_readings(12)
    r["t"] = np.repeat(np.arange(4), 3)
    r["tx"] = 1
    f = firing_folds(r, 2, seed=3)
    assert f.shape == (12,) and set(f.tolist()) == {0, 1}
    assert np.all(f.reshape(4, 3) == f.reshape(4, 3)[:, :1])
    np.testing.assert_array_equal(f, firing_folds(r, 2, seed=3))  # seeded


def test_subset_beams_matches_the_readings_alone() -> None:
    beams, grid = flat_wall_beams()
    keep = np.arange(len(beams.path)) % 3 != 0
    sub = subset_beams(beams, keep)
    assert len(sub.path) == int(keep.sum()) and sub.arcs.arc.max() < len(sub.path)
    alone = arcs_of(sub.poses, sub.path)
    np.testing.assert_array_equal(rasterize(sub.arcs, grid), rasterize(alone, grid))


def test_range_loss_and_hull() -> None:
    loss = range_loss(np.array([2.0, 2.0, 2.0, 2.0]), np.array([2.0, 2.1, np.nan, 9.0]), 0.1)
    np.testing.assert_allclose(loss, [0.0, 0.05, 0.1, 0.1])
    x = np.linspace(0.0, 4.0, 401)
    px, py = x, 1.0 + 0.01 * np.sin(90 * x)  # waves shorter than the window
    inside = np.column_stack((x, np.full_like(x, 1.0)))
    assert hull_excess(inside, px, py, window=0.1) == 0.0
    wild = np.column_stack((x, 1.0 + 0.3 * np.sin(3 * x)))
    assert hull_excess(wild, px, py, window=0.1) == pytest.approx(0.29, abs=0.02)


def test_trimmed_residual_and_coverage_guard() -> None:
    losses = np.r_[np.full(75, 0.002), np.full(25, 0.1)]  # a quarter capped: trimmed away
    assert robust_residual(losses) == pytest.approx(0.002) and TRIM == 0.75
    s = Score(Candidate("x", "arc-vote", "spline"))
    s.losses = {0.1: [np.full(40, 0.001)], 0.4: [np.full(40, 0.004)]}
    s.base_losses = [np.full(40, 0.01)]
    s.coverage = {0.1: COVERAGE_MIN - 0.1, 0.4: 0.9}  # the better residual covers too little
    s.finish(0.01)
    assert s.setting == 0.4 and s.residual_m == pytest.approx(0.004) and s.excluded is None
    s.coverage = {0.1: 0.2, 0.4: 0.3}
    s.finish(0.01)
    assert s.excluded is not None and "columns the readings imply" in s.excluded
    s.coverage = {0.1: 1.0, 0.4: 1.0}
    s.losses = {0.1: [np.full(40, 0.004)]}
    s.base_losses = [np.full(40, 0.0005)]  # a line does better by > 1/4 cell: never chosen
    s.finish(0.01)
    assert s.excluded is not None and "constant or a line" in s.excluded


def test_a_fold_whose_map_is_empty_costs_the_cap_on_its_held_out_readings() -> None:
    """Every candidate is scored on the same held-out readings: a fold where its map is
    empty explains none of them (each costs the cap), so its losses pair with the echo
    refit's reading by reading; a candidate empty on every fold left nothing."""
    beams, grid = flat_wall_beams()
    n = len(beams.path)
    held, cap = np.arange(0, n, 4), 0.05
    scores = [Score(c) for c in CANDIDATES if c.family != "surfaces"][:2]
    fold_scores(scores, beams, grid, RunParams(), np.zeros(n, bool), held, cap)
    walls = [Score(s.candidate) for s in scores]
    fold_scores(walls, beams, grid, RunParams(), np.ones(n, bool), held, cap)
    for s, wall in zip(scores, walls, strict=True):
        assert s.empty_folds == 1 and s.losses
        for losses in s.losses.values():
            assert len(losses) == 1
            np.testing.assert_array_equal(losses[0], np.full(held.size, cap))
        s.absorb(wall)  # a second fold that maps the wall
        s.finish(grid.cell)
        assert s.excluded is None or "left nothing" not in s.excluded
        assert {v.size for v in map(np.concatenate, s.losses.values())} == {2 * held.size}
    empty = Score(scores[0].candidate)
    fold_scores([empty], beams, grid, RunParams(), np.zeros(n, bool), held, cap)
    empty.finish(grid.cell)
    assert empty.excluded == "the method left nothing on the map"


def test_choose_scores_every_candidate_with_guard_rails(sparse: Path) -> None:
    lg = load_log(sparse)
    choice = choose(lg, RunParams())
    assert [s.candidate.name for s in choice.scores] == [c.name for c in CANDIDATES]
    best = choice.ranked[0]
    assert best.excluded is None and np.isfinite(best.residual_m)
    assert best.guarded  # the guard rails are judged from the top of the ranking down
    for s in choice.scores:
        if s.excluded is None:
            # never worse than a constant or a line, never out of its points' hull
            assert s.residual_m <= s.baseline_m + 0.25 * 0.01
            assert s.hull_m <= HULL_CELLS * 0.01 or not s.guarded
    # the long wave defeats every polynomial of order <= 15: out of the hull, or far behind
    for s in choice.scores:
        if s.candidate.family == "poly":
            assert s.excluded is not None or s.residual_m > 10 * best.residual_m
    # one wavy wall is one function of x: the surfaces candidate stands aside
    (surf,) = [s for s in choice.scores if s.candidate.family == "surfaces"]
    assert surf.excluded is not None and "one function of x" in surf.excluded
    assert choice.repeats == 3  # 374 readings: the folds are drawn three times
    doc = choice.to_json(best)
    assert doc["choice"] == best.candidate.name and len(doc["runners_up"]) == len(CANDIDATES) - 1
    assert "held-out range residual" in doc["criterion"] and doc["folds"] == 4
    assert doc["repeats"] == 3 and "smallest 75%" in doc["criterion"]


def test_surfaces_stand_aside_on_a_grid_too_large(
    sparse: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import sonarproc.auto.scoring as scoring

    monkeypatch.setattr(scoring, "SURFACES_MAX_CELLS", 1000)
    choice = choose(load_log(sparse), RunParams())
    (surf,) = [s for s in choice.scores if s.candidate.family == "surfaces"]
    assert surf.too_large > 1000 and not surf.losses
    assert surf.excluded is not None and surf.excluded.startswith("not scored: the grid has")


def test_the_choice_is_the_same_on_one_thread_or_several(sparse: Path) -> None:
    """The folds are scored on threads and gathered in order: the same losses, bit for bit."""
    lg = load_log(sparse)
    one, two = (choose(lg, RunParams(), workers=w) for w in (1, 3))
    for a, b in zip(one.scores, two.scores, strict=True):
        assert a.candidate.name == b.candidate.name and a.excluded == b.excluded
        assert a.setting == b.setting and a.residual_m == b.residual_m
        assert a.losses.keys() == b.losses.keys() and a.hull == b.hull
        for k in a.losses:
            np.testing.assert_array_equal(np.concatenate(a.losses[k]), np.concatenate(b.losses[k]))
        np.testing.assert_array_equal(np.concatenate(a.base_losses), np.concatenate(b.base_losses))


def test_judging_the_guard_rails_lazily_chooses_as_judging_every_candidate(sparse: Path) -> None:
    """Only the top of the ranking is judged (a judged residual is never lower than the
    unjudged one); the ranking's head is the one judging every candidate gives."""
    lg = load_log(sparse)
    lazy, full = choose(lg, RunParams()), choose(lg, RunParams(), judge_all=True)
    assert all(s.guarded for s in full.scores)
    assert 1 <= sum(s.guarded for s in lazy.scores) < len(CANDIDATES)
    a, b = lazy.next_ranked([]), full.next_ranked([])
    assert a is not None and b is not None
    assert (a.candidate.name, a.setting, a.residual_m) == (
        b.candidate.name,
        b.setting,
        b.residual_m,
    )
    for s in lazy.scores:  # unjudged: a lower bound of the judged residual
        (t,) = [t for t in full.scores if t.candidate.name == s.candidate.name]
        assert s.residual_m <= t.residual_m or s.guarded


def test_the_chosen_fit_on_every_reading_stays_in_its_points_hull(sparse: Path) -> None:
    lg = load_log(sparse)
    res, chosen, choice = run_auto(lg, RunParams())
    r = res.run
    assert chosen.excluded is None and chosen in choice.ranked
    excess = hull_excess(r.fit.sample(r.grid.cell), r.points_x, r.points_y, window=10 * r.grid.cell)
    assert excess <= HULL_CELLS * r.grid.cell
    # every profile setting's hull and coverage are judged on its fit to all the scored
    # readings (a fold's map may be too sparse to fit; that fold costs the cap instead)
    beams, _ = select_beams(lg, RunParams())
    beams = subset_beams(beams, _sample_firings(beams.readings, 6_000, 0))
    implied = implied_span(beams)
    assert chosen.guarded
    for s in choice.scores:
        if s.candidate.family != "surfaces" and s.guarded:
            assert set(s.hull) <= set(s.candidate.settings) and s.hull
            assert all(np.isfinite(v) and v >= 0 for v in s.hull.values())
            assert set(s.coverage) == set(s.whole_fits) == set(s.candidate.settings)
            for k, fit in s.whole_fits.items():
                lo, hi = fit.domain
                want = (min(hi, implied[1]) - max(lo, implied[0])) / (implied[1] - implied[0])
                assert s.coverage[k] == pytest.approx(float(np.clip(want, 0.0, 1.0)))


def test_auto_leaves_stray_echo_clusters_out_of_the_profile(tmp_path: Path) -> None:
    """The lab procedure past a cardboard, second-order echoes off the room's corners: the
    clusters they leave metres behind the cardboard are not bridged by the profile."""
    path = tmp_path / "lab.h5"
    simulate_to_log(ROOT / "tests/data/scenarios/auto7-lab-tilted.yaml", path)
    res, chosen, choice = run_auto(load_log(path), RunParams())
    record = choice.to_json(chosen)["profile_columns"]
    assert record["cells_left_out"] > 0 and record["cells"] > record["cells_left_out"]
    assert res.run.counts["profile_cells_left_out"] == record["cells_left_out"]
    assert float(np.max(res.run.points_y)) < 2.0  # the cardboard is at y = 1.5 m
    assert res.run.metrics.E1_m < 0.02  # 34 cm when the profile ran through the clusters
    # the terminal and the page say so on the chosen row
    from sonarproc.auto.record import chosen_note
    from sonarproc.report.auto_record import auto_record_html

    note = chosen_note(choice.to_json(chosen))
    assert note.startswith(f"chosen; {record['cells_left_out']} of its {record['cells']}")
    assert note in auto_record_html(choice.to_json(chosen))


# Where auto stands on small scenarios (E1 by the truth, which auto never sees): within
# 1.2x of the best candidate (measured 0.64x and 0.37x; not met on every scenario, see
# docs/methods.md).
@pytest.mark.parametrize(
    ("scenario", "max_ratio"),
    [("tests/data/scenarios/wavy-sparse.yaml", 1.2), ("configs/scenarios/fig06a.yaml", 1.2)],
)
def test_auto_against_its_best_candidate(tmp_path: Path, scenario: str, max_ratio: float) -> None:
    path = tmp_path / f"{Path(scenario).stem}.h5"
    simulate_to_log(ROOT / scenario, path)
    row = auto_row(load_log(path))
    assert row["auto_error_m"] <= max_ratio * row["best_error_m"]
    if row["best_error_m"] < 0.03:
        assert row["auto_error_m"] <= 0.05
    assert row["auto_error_m"] < 0.012  # every method of the paper's set was above 6 cm here


def test_auto_on_a_room_chooses_surfaces_refitted_through_the_echoes(tmp_path: Path) -> None:
    path = tmp_path / "room-box.h5"
    simulate_to_log(ROOT / "configs/scenarios/room-box.yaml", path)
    row = auto_row(load_log(path))
    assert row["choice"] == "surfaces" and row["metric"] == "precision_m"
    # the ridge alone gave 6.7 cm here; the echo-point refits bring it under a centimetre
    assert row["auto_error_m"] < 0.01
    # the run's own record measures the surfaces against the truth, as a plain run does
    res, _, _ = run_auto(load_log(path), RunParams())
    sm = res.run.surface_metrics
    assert sm is not None and sm["precision_m"] == pytest.approx(row["auto_error_m"], rel=1e-9)
    assert 0.8 < sm["completeness"] <= 1.0


def test_cli_run_and_compare_auto(
    tmp_path: Path, sparse: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # the records and pages are looked at, not figures: none are drawn
    no_figures = ["--figures", "none"]
    rc = main(["run", str(sparse), "--auto", "--out", str(tmp_path / "r"), "--json", *no_figures])
    out = capsys.readouterr()
    assert rc == 0, out.err
    doc = json.loads(out.out)
    auto = doc["auto"]
    assert set(auto) >= {"criterion", "choice", "method", "fit", "residual_m", "runners_up"}
    assert auto["residual_m"] > 0 and len(auto["runners_up"]) == len(CANDIDATES) - 1
    on_disk = json.loads((tmp_path / "r" / "report.json").read_text())
    assert on_disk["auto"] == auto and doc["parameters"]["span"] == "points"
    page = (tmp_path / "r" / "report.html").read_text()
    assert "--auto: the choice without ground truth" in page and auto["choice"] in page
    rc = main(["compare", str(sparse), "--methods", "line-of-sight", "--auto",
               "--out", str(tmp_path / "c"), *no_figures])  # fmt: skip
    out = capsys.readouterr()
    assert rc == 0, out.err
    comp = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert [m["method"] for m in comp["methods"]] == ["line-of-sight", "auto"]
    assert comp["auto"]["choice"] in out.out and "held-out range residual" in out.out
    assert (
        "--auto: the choice without ground truth" in (tmp_path / "c" / "compare.html").read_text()
    )

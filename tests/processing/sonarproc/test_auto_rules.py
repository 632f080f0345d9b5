"""``--auto``'s fold schemes, paired standard error, one-SE rule, and the rules study."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarlog.schema import empty_readings
from sonarproc.auto import AutoChoice, Score, choose
from sonarproc.auto.candidates import Candidate
from sonarproc.auto.holdout import make_folds, pass_folds, time_block_folds
from sonarproc.auto.score import one_se_setting, paired_se, robust_residual
from sonarproc.errors import ParameterError
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.simulate import simulate_to_log
from sonarproc.studies.auto_rules import main, pick

ROOT = Path(__file__).resolve().parents[3]


def readings(t: list[int], tx: list[int]) -> np.ndarray:
    r = empty_readings(len(t))
    r["t"] = t
    r["tx"] = tx
    return r


@settings(max_examples=40, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 30), st.integers(0, 4)), min_size=1, max_size=80),
    st.integers(2, 5),
    st.integers(0, 10),
)
def test_fold_schemes_keep_firings_together(
    pairs: list[tuple[int, int]], k: int, seed: int
) -> None:
    pairs.sort()
    r = readings([p[0] for p in pairs], [p[1] for p in pairs])
    keys = list(pairs)
    for scheme in ("firings", "time", "passes"):
        f = make_folds(r, k, by=scheme, seed=seed)
        assert f.shape == (len(pairs),) and f.min() >= 0 and f.max() < k
        seen: dict[tuple[int, int], int] = {}
        for key, fold in zip(keys, f.tolist(), strict=True):
            assert seen.setdefault(key, fold) == fold  # one firing, one fold


def test_time_blocks_are_contiguous_and_passes_cut_each_transmitter() -> None:
    t = np.arange(40)
    f = time_block_folds(readings(t.tolist(), [0] * 40), 4, seed=2)
    assert sorted(set(f.tolist())) == [0, 1, 2, 3]
    assert (np.diff(f) != 0).sum() <= 4  # four blocks (one may wrap around)
    tx = np.tile([0, 1], 20)
    p = pass_folds(readings(t.tolist(), tx.tolist()), 4, seed=5)
    for i in (0, 1):
        mine = p[tx == i]
        # each transmitter's 20 firings: 4 runs of 5, one per fold
        assert np.array_equal(mine, np.repeat(mine[::5], 5)) and sorted(mine[::5]) == [0, 1, 2, 3]


def test_unknown_fold_scheme_names_the_parameter() -> None:
    with pytest.raises(ParameterError, match="folds_by"):
        make_folds(readings([0], [0]), 2, by="x")


def test_paired_se() -> None:
    rng = np.random.default_rng(4)
    a = rng.random(500) * 0.02
    assert paired_se(a, a + 0.001) == pytest.approx(0.0, abs=1e-12)  # a constant shift
    b = a + rng.normal(0.0, 0.002, 500)
    se = paired_se(a, b)
    assert 1e-5 < se < 1e-3 and se == paired_se(a, b)  # seeded
    assert paired_se(b, a) == pytest.approx(se, rel=0.2)
    assert np.isnan(paired_se(a, a[:10]))


def test_one_se_rule_takes_the_smoothest_near_setting() -> None:
    rng = np.random.default_rng(7)
    base = rng.random(400) * 0.01
    near = base + rng.normal(0.0, 0.001, 400)
    far = base + 0.002
    assert robust_residual(far) > robust_residual(base)
    spline = {0.1: base, 0.4: near, 1.6: far}
    assert one_se_setting("spline", spline, {0.1, 0.4, 1.6}) == 0.4
    assert one_se_setting("spline", spline, {0.1, 1.6}) == 0.1  # 0.4 not allowed
    poly = {15.0: base, 6.0: near, 2.0: far}
    assert one_se_setting("poly", poly, {2.0, 6.0, 15.0}) == 6.0
    assert one_se_setting("poly", poly, set()) is None


def _score(losses: dict[float, np.ndarray], hull: dict[float, float]) -> Score:
    s = Score(Candidate("c/spline", "arc-vote", "spline"))
    s.losses = {k: [v] for k, v in losses.items()}
    s.hull = hull
    s.base_losses = [np.full(400, 0.05)]
    s.finish(0.01)
    return s


def test_allowed_settings_and_rule_picks() -> None:
    rng = np.random.default_rng(8)
    base = rng.random(400) * 0.01
    losses = {0.1: base, 0.4: base + rng.normal(0.0, 0.001, 400), 0.8: base + 0.003}
    s = _score(losses, {0.8: 0.2})  # 0.8 leaves the hull
    assert s.allowed(0.01) == {0.1, 0.4} and s.setting in (0.1, 0.4)
    # under blocked folds the candidate prefers 0.4 clearly
    t = _score({0.1: base + 0.004, 0.4: base, 0.8: base + 0.003}, {})
    choices = {
        "firings": AutoChoice([s], "c", 400, 4),
        "time": AutoChoice([t], "c", 400, 4),
        "passes": AutoChoice([s], "c", 400, 4),
    }
    assert pick("lowest", choices, 0.01) == f"c/spline@{s.setting:g}"
    assert pick("one-se", choices, 0.01) == "c/spline@0.4"
    assert pick("time", choices, 0.01) == "c/spline@0.4"
    assert pick("time+se", choices, 0.01) == "c/spline@0.4"


def test_choose_with_blocked_folds(tmp_path: Path) -> None:
    path = tmp_path / "fig06a.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig06a.yaml", path)
    lg = load_log(path)
    for by in ("time", "passes"):
        c = choose(lg, RunParams(cell=0.01), folds_by=by)
        best = c.ranked[0]
        assert np.isfinite(best.residual_m) and best.residual_m < 0.05
        assert c.folds == 4 and c.readings_scored == len(lg.readings)


def test_rules_study_refuses_a_missing_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["--scenarios", str(tmp_path / "none")]) == 2
    assert "--scenarios" in capsys.readouterr().err

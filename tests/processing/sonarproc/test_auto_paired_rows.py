"""``--auto`` compares models on the same held-out readings, or refuses to."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarproc.auto import run_auto
from sonarproc.auto.score import clustered_paired_se, paired_se
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]


def test_paired_standard_error_refuses_unpaired_losses() -> None:
    # 400 losses against 1 200: no pairing exists, and a silent NaN (zeroed later) turned
    # the standard-error tie into "strictly lower wins"
    a, b = np.full(400, 0.01), np.full(1_200, 0.01)
    with pytest.raises(ValueError, match="differ"):
        paired_se(a, b)
    with pytest.raises(ValueError, match="differ"):
        clustered_paired_se(a, b, np.arange(400))


def test_run_auto_scores_every_model_on_the_same_heldout_rows(tmp_path: Path) -> None:
    # fig10b: 730 readings, so 100 held-out readings per fold is a subset of each fold
    log_path = tmp_path / "fig10b.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig10b.yaml", log_path)
    res, chosen, choice = run_auto(load_log(log_path), RunParams(), heldout_per_fold=100)
    record = choice.to_json(chosen)
    assert record["choice"] == chosen.candidate.name
    assert res.run.metrics.E1_m is not None and res.run.metrics.E1_m < 0.05


def test_the_echo_refit_is_scored_on_the_candidates_own_folds(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the refit once drew its folds again from the defaults: with other options (fewer
    # held-out readings, three folds) its losses no longer paired with the candidates'
    import sonarproc.auto.select as select

    seen: list[tuple[object, object]] = []
    real = select.choose_refit

    def spy(*args: object, **kwargs: object) -> object:
        got = real(*args, **kwargs)  # type: ignore[arg-type]
        seen.append((kwargs.get("splits"), got))
        return got

    monkeypatch.setattr(select, "choose_refit", spy)
    log_path = tmp_path / "fig10b.h5"
    simulate_to_log(ROOT / "configs/scenarios/fig10b.yaml", log_path)
    _, chosen, choice = run_auto(load_log(log_path), RunParams(), heldout_per_fold=40, folds=3)
    assert choice.splits is not None and len(choice.splits) == 3 * choice.repeats
    assert {held.size for _, held in choice.splits} == {40}
    winner = np.concatenate(chosen.losses[chosen.setting])
    assert seen
    for splits, refit in seen:
        assert splits is choice.splits
        heldout = refit.heldout  # type: ignore[attr-defined]
        assert heldout is None or heldout.size == winner.size

"""A map fitted as surfaces, without a truth, fits no profile: its metrics (f_c, N, N_k,
none of which reads a profile without a truth) are those the profile's fit gave."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarproc.fit import FitFailure
from sonarproc.params import RunParams
from sonarproc.pipeline import evaluation, load_log
from sonarproc.pipeline.arcmap import build_arc_map
from sonarproc.pipeline.evaluation import fit_and_measure
from sonarproc.pipeline.mapping import map_log

ROBOND = Path(__file__).resolve().parents[2] / "data" / "real" / "robond"


def test_surfaces_without_truth_fit_no_profile(monkeypatch: pytest.MonkeyPatch) -> None:
    lg = load_log(ROBOND / "readings.csv", sensors=ROBOND / "sensors.yaml")
    assert lg.truth is None
    params = RunParams(fit="auto", align=False)
    fitted: list[str] = []
    real = evaluation._fit_binned

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        fitted.append("profile")
        return real(*args, **kwargs)

    monkeypatch.setattr(evaluation, "_fit_binned", counted)
    result, mmap = map_log(lg, params, build_arc_map)
    assert result.surfaces is not None and len(result.surfaces.surfaces) >= 4
    assert fitted == []  # the surfaces are the fit
    assert isinstance(result.fit, FitFailure) and result.fit.kind == "surfaces"
    with_profile = fit_and_measure(
        RunParams(fit="poly"), result.grid, mmap.processed, mmap.evidence, truth=None,
        robot_xy=np.asarray(result.robot_xy),
    )  # fmt: skip
    assert fitted == ["profile"] and not isinstance(with_profile.fit, FitFailure)
    assert with_profile.metrics == result.metrics

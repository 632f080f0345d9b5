"""Drift correction inside ``sonarproc run``: applied where the echoes show drift, never
on an ideal simulated log (whose results must not move), off with ``--no-align``.

Drift: 2 % of the distance driven and 2 degrees of heading per 10 m
(tests/support/drift.py) on a route driven three times. room-box was used while wiring
the decision; hall-pillar was not.
"""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import numpy as np
import pytest
from drift import drifted_readings, looped_scenario, pose_error_rms

from sonarlog import LogWriter, SonarLog, read_log
from sonarproc.cli import main
from sonarproc.params import RunParams
from sonarproc.pipeline import process
from sonarproc.pipeline.alignment import align_log


@cache
def _looped(name: str, seed: int, tmp: str) -> tuple[SonarLog, SonarLog]:
    """The route driven three times: the exact log and the drifted one."""
    res = looped_scenario(name, 3)
    out = []
    for label, r in (("exact", res.readings), ("drift", drifted_readings(res.readings, seed=seed))):
        path = Path(tmp) / f"{name}-{label}.h5"
        with LogWriter(path, res.sensors, speed_of_sound=float(res.speed_of_sound),
                       robot="sim", truth=res.truth) as w:  # fmt: skip
            w.append(r)
        out.append(read_log(path))
    return out[0], out[1]


@pytest.fixture(scope="module")
def tmp(tmp_path_factory: pytest.TempPathFactory) -> str:
    return str(tmp_path_factory.mktemp("align"))


@pytest.mark.slow
@pytest.mark.parametrize(("name", "seed"), [("room-box", 0), ("hall-pillar", 2)])
def test_run_removes_the_drift_and_restores_the_surfaces(name: str, seed: int, tmp: str) -> None:
    exact, drifted = _looped(name, seed, tmp)
    aligned, record = align_log(drifted)
    assert record.applied, record.reason
    # beyond the chance level, judged on the matches found at the raw poses (measured:
    # hall-pillar 231 against 140, about 1.6x)
    assert record.cost_drop_x2 > 1.25 * record.threshold
    # drift displaces every echo of a wall seen again: the typical echo agrees far better
    # (measured: room-box 1.04 -> 0.64 cm, hall-pillar 1.36 -> 0.46 cm)
    assert record.summary["echo_median_after_m"] < 0.7 * record.summary["echo_median_before_m"]
    truth = exact.readings
    before = pose_error_rms(truth, drifted.readings["x"], drifted.readings["y"])
    after = pose_error_rms(truth, aligned.readings["x"], aligned.readings["y"])
    assert before > 0.08
    assert after <= 0.2 * before, (before, after)
    assert record.max_shift_m == pytest.approx(
        float(np.hypot(aligned.readings["x"] - drifted.readings["x"],
                       aligned.readings["y"] - drifted.readings["y"]).max()), abs=1e-9,
    )  # fmt: skip
    params = RunParams(fit="auto")
    on = process(drifted, params)
    off = process(drifted, RunParams(fit="auto", align=False))
    free = process(exact, params)
    assert on.alignment is not None and on.alignment.applied
    assert off.alignment is None
    p_on, p_off = on.metrics_json()["precision_m"], off.metrics_json()["precision_m"]
    p_free = free.metrics_json()["precision_m"]
    # measured: room-box 7.2 mm aligned, 43 mm not, 4.5 mm drift-free; hall-pillar 6.9,
    # 46 and 0.4 mm (the residual pose error, about 1 cm, bounds the aligned precision)
    assert p_on <= 0.25 * p_off, (p_on, p_off)
    assert p_on <= max(2.0 * p_free, 0.01), (p_on, p_free)
    assert on.quality is not None and off.quality is not None
    assert on.quality.explained_fraction is not None and off.quality.explained_fraction is not None
    assert on.quality.explained_fraction > off.quality.explained_fraction
    # The truth-free verdict is the held-out residual: in sample, a drifted map's extra
    # pieces and points explain some of its own smeared readings (hall-pillar: explained
    # 0.689 aligned against 0.667 not), but they do not predict readings left out of the
    # fit (held-out p90 measured: hall-pillar 1.7 cm aligned against 5.4 cm not).
    assert on.quality.heldout_p90_m is not None and off.quality.heldout_p90_m is not None
    assert on.quality.heldout_p90_m < 0.5 * off.quality.heldout_p90_m, (
        on.quality.heldout_p90_m,
        off.quality.heldout_p90_m,
    )


@pytest.mark.parametrize("name", ["fig12", "room-box", "corridor-l"])
def test_an_ideal_log_keeps_its_poses_and_results(name: str, tmp_path: Path) -> None:
    log = tmp_path / f"{name}.h5"
    assert main(["simulate", name, "--out", str(log), "--seed", "1"]) == 0
    docs = []
    for extra in ([], ["--no-align"]):
        out = tmp_path / f"r{len(docs)}"
        args = ["run", str(log), "--out", str(out), "--figures", "none", "--json", *extra]
        assert main(args) == 0
        docs.append(json.loads((out / "report.json").read_text()))
    on, off = docs
    assert on["alignment"]["applied"] is False and on["alignment"]["reason"]
    assert on["alignment"]["max_shift_m"] == 0.0
    assert "alignment" not in off and off["parameters"]["align"] is False
    for key in ("fit", "surfaces", "counts", "quality"):
        assert on.get(key) == off.get(key), key
    for key, value in off["metrics"].items():
        if key != "t_cpu_s":
            assert on["metrics"][key] == value, key


@pytest.mark.slow
def test_the_alignment_figure_is_drawn_when_applied(tmp: str, tmp_path: Path) -> None:
    _looped("room-box", 0, tmp)
    log = Path(tmp) / "room-box-drift.h5"
    out = tmp_path / "rep"
    assert main(["run", str(log), "--out", str(out), "--figures", "png", "--json"]) == 0
    doc = json.loads((out / "report.json").read_text())
    al = doc["alignment"]
    assert al["applied"] is True and 0.05 < al["max_shift_m"] < 0.5
    assert 0 < al["mean_shift_m"] < al["max_shift_m"] and al["max_turn_rad"] > 0
    assert al["summary"]["reason"] == "" and al["summary"]["nodes"] > 10
    assert (out / "alignment.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (out / "report.html").read_text()
    assert "Odometry drift correction" in page and "alignment.png" in page


@pytest.mark.parametrize(
    "scenario",
    [
        "office-door",
        str(Path(__file__).resolve().parents[3] / "data/scenarios/heldout-u-hall.yaml"),
        str(
            Path(__file__).resolve().parents[3]
            / "data/scenarios/sparse17-heldout-branch-corridor.yaml"
        ),
    ],
)
def test_a_drift_free_transducer_log_keeps_its_poses(scenario: str, tmp_path: Path) -> None:
    """Corner and edge echoes and time walk are not drift: judged on the matches found at
    the raw poses, the correction of these exact-pose logs is not significant (measured:
    twice the cost drop 70.6 against 83.5 and 45.2 against 68.7; judged on the solver's
    last matches it passed, and moved their poses by 11 and 38 cm). On a corridor driven
    to its end wall and back, the corners' echoes matched to lines whose readings were
    taken metres nearer passed the test as a 3 % odometry scale error (146 against 90.8,
    poses moved by 26 cm); matched only where the line was seen, they do not (16.6)."""
    log = tmp_path / "log.h5"
    assert main(["simulate", scenario, "--out", str(log)]) == 0
    _, record = align_log(read_log(log))
    assert record.applied is False, record.reason
    assert record.max_shift_m == 0.0
    assert record.cost_drop_x2 <= record.threshold


def test_a_correction_that_worsens_the_typical_echo_is_refused(tmp_path: Path) -> None:
    """A drift-free sparse log of two crossing corridors (Pioneer front ring, transducer
    physics): the solver's correction once passed the chi-square test on its robust cost
    (measured: twice the drop 116 against 87.2), but only by pulling in a few outlying
    echoes (corners' echoes matched to lines seen from elsewhere): the median echo
    residual grew from 0.98 to 1.3 cm, and the median rule refused it. With echoes
    matched only where their line was seen, the drop is no longer significant (26.2
    against 87.2). Either way it is refused and the poses stay exact."""
    scenario = Path(__file__).resolve().parents[3] / "data/scenarios/sparse10-heldout-cross.yaml"
    log = tmp_path / "log.h5"
    assert main(["simulate", str(scenario), "--out", str(log)]) == 0
    _, record = align_log(read_log(log))
    s = record.summary
    significant = record.cost_drop_x2 > record.threshold
    assert not significant or s["echo_median_after_m"] > s["echo_median_before_m"] > 0.0
    assert record.applied is False
    assert record.max_shift_m == 0.0

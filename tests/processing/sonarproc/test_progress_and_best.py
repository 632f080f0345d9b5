"""Progress on long commands (quiet off a terminal) and the sweep's human best line."""

from __future__ import annotations

from pathlib import Path

import pytest

from sonarlog import LogWriter
from sonarlog.csvlog import read_csv_log, read_truth_csv
from sonarproc.cli import main
from sonarproc.cli.progress import progress, wanted
from sonarproc.cli.sweep import best_line
from sonarproc.sweep import run_sweep
from sonarproc.sweep.merge import best_rows

EXAMPLES = Path(__file__).resolve().parents[3] / "configs" / "sensors"


@pytest.fixture(scope="module")
def log_h5(tmp_path_factory: pytest.TempPathFactory) -> Path:
    lg = read_csv_log(EXAMPLES / "example-readings.csv", EXAMPLES / "example-sensors.yaml")
    path = tmp_path_factory.mktemp("p") / "scan.h5"
    truth = read_truth_csv(EXAMPLES / "example-truth.csv")
    with LogWriter(path, lg.sensors, speed_of_sound=lg.speed_of_sound, truth=truth) as w:
        w.append(lg.readings)
    return path


def test_sweep_reports_every_combination(log_h5: Path) -> None:
    seen: list[tuple[int, int]] = []
    result = run_sweep(
        [str(log_h5)], "ops=thinning:1..3;order=4,6", progress=lambda d, t: seen.append((d, t))
    )
    assert seen[0] == (0, 6) and seen[-1] == (6, 6)
    assert [d for d, _ in seen] == list(range(7)) and len(result.rows) == 6


def test_progress_is_quiet_off_a_terminal(
    log_h5: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert not wanted()  # pytest captures stdout: not a terminal
    with progress("x", 3) as steps:
        steps(1, 3)
        steps.advance("next")
    out = tmp_path / "sw"
    grid = "order=4,6"
    assert main(["sweep", str(log_h5), "--grid", grid, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out.count("\n") == 1
    assert "2 of 2 combinations" in captured.out


def test_best_names_tuned_parameters_and_averages_over_seeds() -> None:
    def row(i: int, ops: str, seed: int, e1: float) -> dict[str, object]:
        base = {"input": "s.yaml", "ok": True, "fit_ok": True, "e": 0.5, "f_c": 1.0, "E2": 0.5}
        return {**base, "index": i, "ops": ops, "sigma": 0.01, "seed": seed, "E1_m": e1}

    rows = [row(0, "thinning:1", 0, 0.010), row(1, "thinning:1", 1, 0.050),
            row(2, "thinning:3", 0, 0.020), row(3, "thinning:3", 1, 0.022)]  # fmt: skip
    best = best_rows(rows)["s.yaml"]
    assert best["row"]["ops"] == "thinning:3" and best["row"]["runs"] == 2
    assert best["row"]["E1_m_mean"] == pytest.approx(0.021)
    assert "sigma" not in best["row"] and "seed" not in best["row"]
    line = best_line("s.yaml", best)
    assert line == (
        "best for s.yaml (least mean E1 over 2 noise/seed runs): ops=thinning:3: mean E1 2.10 cm"
    )

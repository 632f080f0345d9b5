"""``sonarproc simulate``: scenario in, sonarlog v1 with truth out."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarlog import FLAG_NO_ECHO, read_log
from sonarproc.cli import main
from sonarsim import load_scenario, simulate

ROOT = Path(__file__).resolve().parents[3]
FIG16 = ROOT / "configs/scenarios/fig16.yaml"
FIG13 = ROOT / "configs/scenarios/fig13.yaml"


def test_round_trip_matches_the_simulation(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "f16.h5"
    assert main(["simulate", str(FIG16), "--out", str(out)]) == 0
    line = capsys.readouterr().out.strip()
    assert line.count("\n") == 0
    assert str(out) in line and "305 readings" in line and "5 sensors" in line

    log = read_log(out)
    expected = simulate(load_scenario(FIG16))
    assert log.speed_of_sound == pytest.approx(343.3)
    np.testing.assert_array_equal(log.sensors, expected.sensors)
    for name in expected.readings.dtype.names or ():
        np.testing.assert_array_equal(log.readings[name], expected.readings[name])
    assert log.truth is not None
    np.testing.assert_allclose(log.truth, expected.truth)
    assert log.attrs["scenario"] == "fig16"
    assert "fig16" in str(log.attrs["scenario_yaml"])
    # The reader's vectorised poses agree with the simulated geometry: the front sonar
    # (id 0) at the first stop sits 0.22 m ahead of (-0.75, 0) along the turret (+y).
    tp = log.transducer_poses()
    first0 = int(np.flatnonzero(log.readings["tx"] == 0)[0])
    np.testing.assert_allclose(tp.tx_xy[first0], [-0.75, 0.22], atol=1e-12)
    assert tp.tx_heading[first0] == pytest.approx(np.pi / 2)
    echo = (log.readings["flags"] & FLAG_NO_ECHO) == 0
    assert np.all(log.path_lengths(log.readings[echo]) > 0)


def test_seed_option_changes_random_scenarios(tmp_path: Path) -> None:
    a, b, c = tmp_path / "a.h5", tmp_path / "b.h5", tmp_path / "c.h5"
    assert main(["simulate", str(FIG13), "--out", str(a)]) == 0
    assert main(["simulate", str(FIG13), "--out", str(b)]) == 0
    assert main(["simulate", str(FIG13), "--out", str(c), "--seed", "4"]) == 0
    la, lb, lc = read_log(a), read_log(b), read_log(c)
    np.testing.assert_array_equal(la.readings["tof"], lb.readings["tof"])
    assert not np.array_equal(la.sensors["x"], lc.sensors["x"])
    assert int(lc.attrs["seed"]) == 4


def test_bad_scenario_exits_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        "world: {surfaces: [{type: wall, start: [0, 1], end: [1, 1]}]}\n"
        "array: {type: linear, count: 2, spacing: 0.5}\n"
        "speed_of_sound: 34.3\n"
    )
    out = tmp_path / "x.h5"
    assert main(["simulate", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0
    assert str(bad) in err and "speed_of_sound" in err and "300" in err
    assert "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize(
    "content",
    ["not: [valid yaml\n", "- a list\n", "world: lab.yaml\n"],
    ids=["syntax", "not-mapping", "no-array"],
)
def test_malformed_scenarios_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: str
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(content)
    assert main(["simulate", str(bad), "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("sonarproc: error: ") and str(bad) in err and err.count("\n") == 0


def test_missing_scenario_and_missing_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", str(tmp_path / "none.yaml"), "--out", str(tmp_path / "x.h5")]) == 2
    assert "no such file" in capsys.readouterr().err
    assert main(["simulate", str(FIG16)]) == 2  # --out is required
    capsys.readouterr()
    assert main(["simulate", str(FIG16), "--out", str(tmp_path / "no" / "x.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err
    assert main(["simulate", str(FIG16), "--out", str(tmp_path / "x.h5"), "--seed", "-1"]) == 2

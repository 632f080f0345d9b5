"""The same readings give the same map and metrics from a Player log and from a sonarlog.

A quantised sonar (1-inch range steps) driving past a gentle wall reads the same range
on consecutive firings about half the time. In a Player log, where every sonar line
repeats the whole ring, such a firing looks like a stale repeat; the importer used to drop
it (171 of 306 echoes kept on this scene, E1 1.20 m against 0.62 m from the sonarlog).
"""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np
import pytest
from playerlogs import at_player_precision, write_player_from_log, write_sensors_yaml

from sonarlog import FLAG_NO_ECHO, read_log
from sonarlog.sources import read_source, write_sonarlog
from sonarproc.cli import main

pytestmark = pytest.mark.slow

#: A test scenario (tests/data/scenarios) by path, a shipped one by name.
RING_SINE = str(Path(__file__).parents[2] / "data" / "scenarios" / "auto5-ring-sine.yaml")

METRICS = ("e", "f_c", "E1_m", "E2", "precision_m", "completeness")


def _run(log: Path, out: Path, *extra: str) -> dict[str, object]:
    with contextlib.redirect_stdout(io.StringIO()):
        # the metrics are compared, not figures: none are drawn
        assert (
            main(["run", str(log), "--out", str(out), "--json", "--figures", "none", *extra]) == 0
        )
    return dict(json.loads((out / "report.json").read_text()))


@pytest.mark.parametrize("scene", [RING_SINE, "room-box"], ids=["auto5-ring-sine", "room-box"])
def test_player_log_maps_like_the_sonarlog(tmp_path: Path, scene: str) -> None:
    sim = tmp_path / "sim.h5"
    with contextlib.redirect_stdout(io.StringIO()):
        assert main(["simulate", scene, "--out", str(sim)]) == 0
    lg = at_player_precision(read_log(sim))
    h5 = write_sonarlog(lg, tmp_path / "same.h5")
    player = tmp_path / "same.player"
    write_player_from_log(player, lg)
    sensors = write_sensors_yaml(tmp_path / "sensors.yaml", lg)
    truth = tmp_path / "truth.csv"
    np.savetxt(truth, lg.truth, delimiter=",", header="x,y", comments="", fmt="%.17g")

    echoes = lg.readings[(lg.readings["flags"] & FLAG_NO_ECHO) == 0]
    imported, _ = read_source(player, sensors=sensors)
    kept = imported.readings[(imported.readings["flags"] & FLAG_NO_ECHO) == 0]
    assert np.array_equal(kept["t"], echoes["t"]) and np.array_equal(kept["rx"], echoes["rx"])
    np.testing.assert_array_equal(kept["tof"], echoes["tof"])
    # the case matters: many echoes repeat their transducer's previous range exactly
    repeats = sum(
        int(np.count_nonzero(np.diff(echoes["tof"][echoes["rx"] == k]) == 0))
        for k in np.unique(echoes["rx"])
    )
    assert repeats > 20

    a = _run(h5, tmp_path / "rep-h5", "--truth", str(truth))
    b = _run(player, tmp_path / "rep-player", "--sensors", str(sensors), "--truth", str(truth))
    ma, mb = a["metrics"], b["metrics"]
    assert isinstance(ma, dict) and isinstance(mb, dict)
    assert a["counts"]["readings_used"] == b["counts"]["readings_used"]  # type: ignore[index]
    for key in METRICS:
        assert (ma.get(key) is None) == (mb.get(key) is None), key
        if ma.get(key) is not None:
            assert mb[key] == pytest.approx(ma[key], rel=1e-9, abs=1e-12), key

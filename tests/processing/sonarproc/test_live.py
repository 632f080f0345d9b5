"""LiveAccumulator: incremental count map and snapshot equal the batch pipeline."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sonarlog import FLAG_NO_ECHO, LogWriter, SonarLog, read_log, writer_closed
from sonarproc.params import RunParams
from sonarproc.pipeline import RunResult, process
from sonarproc.pipeline.live import LiveAccumulator
from sonarproc.simulate import simulate_to_log

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, SonarLog]:
    d = tmp_path_factory.mktemp("live")
    out = {}
    for name in ("fig02", "fig12", "fig13"):
        simulate_to_log(SCENARIOS / f"{name}.yaml", d / f"{name}.h5")
        out[name] = read_log(d / f"{name}.h5")
    return out


def feed(lg: SonarLog, params: RunParams, seed: int, parts: int = 15) -> LiveAccumulator:
    rng = np.random.default_rng(seed)
    n = len(lg.readings)
    cuts = np.sort(rng.choice(np.arange(1, n), size=min(parts, n - 1), replace=False))
    acc = LiveAccumulator(lg, params)
    for part in np.split(lg.readings, cuts):
        acc.add(part)
    return acc


def assert_equal_results(a: RunResult, b: RunResult) -> None:
    assert a.grid == b.grid
    assert a.counts_map.dtype == b.counts_map.dtype
    np.testing.assert_array_equal(a.counts_map, b.counts_map)
    np.testing.assert_array_equal(a.processed, b.processed)
    assert a.counts == b.counts
    assert a.metrics.to_json() == b.metrics.to_json()
    assert a.fit.to_json() == b.fit.to_json()


@pytest.mark.parametrize("name", ["fig02", "fig12", "fig13"])
@pytest.mark.parametrize("seed", [0, 1])
def test_incremental_count_map_equals_batch(
    logs: dict[str, SonarLog], name: str, seed: int
) -> None:
    lg = logs[name]
    params = RunParams(ops="thinning:3")
    acc = feed(lg, params, seed)
    snap = acc.snapshot()
    assert snap is not None
    assert_equal_results(snap, process(lg, params))
    assert acc.n_readings == len(lg.readings)


def test_regrow_happens_and_stays_exact(logs: dict[str, SonarLog]) -> None:
    lg = logs["fig02"]  # a circular array moving: the arcs' extent grows with the log
    acc = feed(lg, RunParams(), seed=3, parts=30)
    assert acc.regrows >= 1
    cm = acc.count_map()
    assert cm is not None
    batch = process(lg, RunParams())
    assert cm[0] == batch.grid
    np.testing.assert_array_equal(cm[1], batch.counts_map)


@pytest.mark.parametrize(
    "params",
    [
        RunParams(ops="vote:auto,ridge", robust="huber", auto_order=True),
        RunParams(fit="spline", ops="closing,thinning:2"),
        RunParams(fit="polar", order=8),
        RunParams(bbox=(0.0, 3.0, 0.0, 3.5), span="points"),
        RunParams(cell=0.02, drop_crosstalk=True),
        RunParams(ops="closing,thinning:2", robust="huber", order=6),
    ],
    ids=["vote-huber-auto", "spline", "polar", "bbox", "cell", "closing-huber"],
)
def test_snapshot_equals_process_for_every_method(
    logs: dict[str, SonarLog], params: RunParams
) -> None:
    lg = logs["fig12"]
    snap = feed(lg, params, seed=5).snapshot()
    assert snap is not None
    assert_equal_results(snap, process(lg, params))


def test_snapshot_finds_the_surfaces_a_batch_run_finds(tmp_path: Path) -> None:
    simulate_to_log(SCENARIOS / "corridor-l.yaml", tmp_path / "corridor.h5")
    lg = read_log(tmp_path / "corridor.h5")
    params = RunParams(fit="auto", ops="thinning:3")
    snap = feed(lg, params, seed=2).snapshot()
    batch = process(lg, params)
    assert snap is not None and snap.surfaces is not None and batch.surfaces is not None
    assert len(batch.surfaces.surfaces) >= 4
    assert snap.surfaces.to_json() == batch.surfaces.to_json()


def test_snapshots_along_the_way_equal_batch_on_the_prefix(logs: dict[str, SonarLog]) -> None:
    lg = logs["fig12"]
    acc = LiveAccumulator(lg, RunParams())
    for stop in (1000, 4000, len(lg.readings)):
        acc.add(lg.readings[acc.n_readings : stop])
        snap = acc.snapshot()
        assert snap is not None
        assert_equal_results(snap, process(replace(lg, readings=lg.readings[:stop]), RunParams()))


def test_empty_and_flagged_batches(logs: dict[str, SonarLog]) -> None:
    lg = logs["fig13"]
    acc = LiveAccumulator(lg, RunParams())
    assert acc.snapshot() is None
    assert acc.add(lg.readings[:0]) == 0
    flagged = lg.readings[:5].copy()
    flagged["flags"] |= FLAG_NO_ECHO
    flagged["tof"] = np.nan
    assert acc.add(flagged) == 0
    assert acc.snapshot() is None and acc.count_map() is None
    assert acc.add(lg.readings) == int(process(lg, RunParams()).counts["readings_used"])
    snap = acc.snapshot()
    assert snap is not None
    assert snap.counts["readings_total"] == len(lg.readings) + 5
    assert snap.counts["flagged_no_echo"] == 5


def test_bad_tof_fails_like_a_batch_run(logs: dict[str, SonarLog]) -> None:
    lg = logs["fig13"]
    bad = lg.readings[:3].copy()
    bad["flags"] = 0
    bad["tof"] = -1.0
    acc = LiveAccumulator(lg, RunParams())
    with pytest.raises(ValueError, match="tof <= 0 or NaN"):
        acc.add(bad)


def test_bad_ops_fail_at_construction(logs: dict[str, SonarLog]) -> None:
    with pytest.raises(ValueError, match="thinning"):
        LiveAccumulator(logs["fig13"], RunParams(ops="thinning:0"))


def test_writer_closed_tracks_the_superblock_flags(
    tmp_path: Path, logs: dict[str, SonarLog]
) -> None:
    lg = logs["fig13"]
    path = tmp_path / "w.h5"
    w = LogWriter(path, lg.sensors, speed_of_sound=lg.speed_of_sound)
    try:
        w.append(lg.readings)
        w.flush()
        assert writer_closed(path) is False
    finally:
        w.close()
    assert writer_closed(path) is True

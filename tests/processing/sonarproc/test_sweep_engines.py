"""A sweep's table does not depend on its engine, and sharing work changes no row."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from procs import sonarproc_in_child

from sonarproc.cli import main
from sonarproc.engines import Engine, map_chunks, parse_engine
from sonarproc.errors import ParameterError
from sonarproc.sweep import combinations, parse_grid
from sonarproc.sweep.runner import _load, _row, chunks_of, run_chunk
from sonarproc.sweep.shared import clear_shared

FIG13 = Path(__file__).resolve().parents[3] / "configs" / "scenarios" / "fig13.yaml"
#: 3 seeds x 2 cells x 2 operations x 2 orders: several count maps per simulated log.
GRID = "seed=1..3;cell=0.01|0.02;ops=thinning:1|thinning:3;order=4|9"


def without_time(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "t_cpu_s"} for r in rows]


def table(out: Path, stem: str = "results") -> list[dict[str, Any]]:
    return [json.loads(line) for line in (out / f"{stem}.jsonl").read_text().splitlines()]


@pytest.fixture(scope="module")
def serial(tmp_path_factory: pytest.TempPathFactory) -> list[dict[str, Any]]:
    out = tmp_path_factory.mktemp("serial")
    assert main(["sweep", str(FIG13), "--grid", GRID, "--out", str(out)]) == 0
    return table(out)


def test_shared_rows_equal_unshared_runs(serial: list[dict[str, Any]]) -> None:
    """Each row, computed on a shared simulation and count map, equals a run of its own."""
    combos = combinations([str(FIG13)], parse_grid(GRID))
    assert len(serial) == len(combos) == 24
    for c in combos[::5]:
        own = _row(c, _load(c.input, {"seed": c.values["seed"]}), None)
        assert without_time([own]) == without_time([serial[c.index]])


@pytest.mark.parametrize("engine", ["local", "dask"])
def test_engines_give_the_serial_table(
    serial: list[dict[str, Any]], tmp_path: Path, engine: str
) -> None:
    if engine == "dask":
        pytest.importorskip("distributed")
    args = ["sweep", str(FIG13), "--grid", GRID, "--out", str(tmp_path)]
    args += ["--engine", engine, "--workers", "2"]
    # dask's client leaves threads in the process that used it: run it in a process of its own
    assert (sonarproc_in_child(args) if engine == "dask" else main(args)) == 0
    assert without_time(table(tmp_path)) == without_time(serial)


def test_the_jobs_flag_still_works(serial: list[dict[str, Any]], tmp_path: Path) -> None:
    args = ["sweep", str(FIG13), "--grid", GRID, "--jobs", "2", "--shard", "1/2"]
    assert main([*args, "--out", str(tmp_path)]) == 0
    shard = table(tmp_path, "results.shard-1-of-2")
    assert without_time(shard) == without_time(serial[1::2])


def test_chunks_keep_one_simulation_each_and_cover_the_grid() -> None:
    combos = combinations([str(FIG13)], parse_grid(GRID))
    for workers in (1, 2, 3, 8):
        chunks = chunks_of(combos, workers)
        assert sorted(c.index for ch in chunks for c in ch) == list(range(24))
        assert all(len({c.values["seed"] for c in ch}) == 1 for ch in chunks)
        assert len(chunks) == (3 if workers <= 3 else 9)  # 3 seeds, split for 8 workers
    one_log = combinations([str(FIG13)], parse_grid("ops=thinning:1..4;order=4|9"))
    assert [len(ch) for ch in chunks_of(one_log, 2)] == [4, 4]


def test_a_worker_simulates_a_seed_once(monkeypatch: pytest.MonkeyPatch) -> None:
    import sonarproc.sweep.runner as runner

    calls: list[dict[str, Any]] = []
    real = runner._load

    def counting(inp: str, values: dict[str, Any]) -> Any:
        calls.append(values)
        return real(inp, values)

    monkeypatch.setattr(runner, "_load", counting)
    clear_shared()
    combos = combinations([str(FIG13)], parse_grid("seed=1|2;ops=thinning:1|thinning:2"))
    halves = [[c for c in combos if c.values["seed"] == 1][i : i + 1] for i in (0, 1)]
    map_chunks(run_chunk, [*halves, [c for c in combos if c.values["seed"] == 2]])
    assert calls == [{"seed": 1}, {"seed": 2}]
    clear_shared()


def test_parse_engine() -> None:
    assert parse_engine(" LOCAL ") == Engine("local")
    for bad in ("", "local=x", "dask=", "slurm"):
        with pytest.raises(ParameterError, match="expected local, dask or dask=SCHEDULER_ADDRESS"):
            parse_engine(bad)


def test_map_chunks_keeps_the_order_of_the_chunks() -> None:
    seen: list[int] = []
    assert map_chunks(abs, [-3, 1, -2], workers=2, done=seen.append) == [3, 1, 2]
    assert sorted(seen) == [1, 2, 3]

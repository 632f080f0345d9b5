"""``sonarproc batch``: many logs of every kind, one report each, one summary, any engine."""

from __future__ import annotations

import csv
import json
import os
from pathlib import Path

import pytest
from bagbuilders import sim_run, write_range_bag
from procs import sonarproc_in_child

from sonarproc.batch import SUMMARY_COLUMNS
from sonarproc.cli import main
from sonarproc.simulate import simulate_to_log

ROOT = Path(__file__).resolve().parents[3]
SCENARIOS = ROOT / "configs" / "scenarios"
ROBOND = ROOT / "tests" / "data" / "real" / "robond"
#: Small shipped scenarios (a fraction of a second each to simulate and run).
SIMULATED = ("fig02", "fig06a", "fig08a", "fig10b", "fig13", "fig16")
SEEDS = (1, 2, 3)
BROKEN = "broken.h5"


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """20 logs (18 simulated, a ROS 1 bag, a readings CSV) and a broken one, in that order.

    The simulated logs of one scenario share a file name in per-seed folders, so the
    report names must be made unique.
    """
    base = tmp_path_factory.mktemp("fleet")
    logs: list[Path] = []
    for name in SIMULATED:
        for seed in SEEDS:
            path = base / f"seed{seed}" / f"{name}.h5"
            path.parent.mkdir(exist_ok=True)
            simulate_to_log(SCENARIOS / f"{name}.yaml", path, seed=seed)
            logs.append(path)
    bag = base / "robond-like.bag"  # the real log's robot, so one --sensors fits both
    write_range_bag(bag, "ros1", sim_run(str(ROBOND / "sensors.yaml"), stops=4))
    logs.append(bag)
    logs.append(ROBOND / "readings.csv")
    broken = base / BROKEN
    broken.write_bytes(b"not an HDF5 file\n")
    logs.append(broken)
    return logs


def _batch(logs: list[Path], out: Path, *extra: str, child: bool = False) -> int:
    args = ["batch", *map(str, logs), "--out", str(out), "--sensors", str(ROBOND / "sensors.yaml")]
    # the paper's knobs: what is tested is the engines, not how a run picks its fit
    args += ["--cell", "0.02", "--paper", *extra]
    return sonarproc_in_child(args) if child else main(args)


@pytest.fixture(scope="module")
def local_out(fleet: list[Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("local")
    assert _batch(fleet, out, "--engine", "local", "--workers", "2") == 1  # one log failed
    return out


def rows_of(out: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in (out / "summary.jsonl").read_text().splitlines()]


def test_summary_has_a_row_per_log_in_order(fleet: list[Path], local_out: Path) -> None:
    rows = rows_of(local_out)
    assert [r["log"] for r in rows] == [str(p) for p in fleet]
    assert [r["index"] for r in rows] == list(range(21))
    assert [r["status"] for r in rows] == ["ok"] * 20 + ["error"]
    names = [r["report"] for r in rows[:18]]
    assert names[:3] == ["fig02", "fig02-2", "fig02-3"] and len(set(names)) == 18
    assert rows[18]["report"] == "robond-like" and rows[19]["report"] == "readings"
    for r in rows[:20]:
        assert r["error"] is None and r["fit_ok"] is True
        assert 0 < r["readings_used"] <= r["readings_total"]  # type: ignore[operator]
        doc = json.loads((local_out / str(r["report"]) / "report.json").read_text())
        assert r["e"] == doc["metrics"]["e"] and r["N"] == doc["metrics"]["N"]
        assert r["processed_cells"] == doc["counts"]["processed_cells"]
        assert r["fit"] == doc["fit"]["kind"] and r["log_state"] == "closed"
        assert not list((local_out / str(r["report"])).glob("*.png"))  # --figures none
    simulated = rows[:18]
    assert all(r["E1_m"] is not None or r["precision_m"] is not None for r in simulated)
    assert rows[19]["E1_m"] is None and rows[19]["precision_m"] is None  # no truth


def test_a_broken_log_is_an_error_row(local_out: Path) -> None:
    row = rows_of(local_out)[-1]
    assert row["status"] == "error" and row["report"] == ""
    assert str(row["error"]).endswith(f"{BROKEN}: not an HDF5 file")
    assert "\n" not in str(row["error"])
    assert all(row[k] is None for k in ("e", "f_c", "N", "readings_used", "quality"))
    # no report for it, and no partial file or directory left anywhere
    assert sorted(p.name for p in local_out.iterdir() if p.name.startswith(".")) == []
    assert not (local_out / "broken").exists()


def test_summary_csv_matches_jsonl(local_out: Path) -> None:
    with (local_out / "summary.csv").open(newline="") as fh:
        table = list(csv.DictReader(fh))
    assert tuple(table[0]) == SUMMARY_COLUMNS
    for line, r in zip(table, rows_of(local_out), strict=True):
        assert line["status"] == r["status"] and line["report"] == r["report"]
        assert (float(line["e"]) if line["e"] else None) == r["e"]


def test_a_row_equals_sonarproc_run(
    fleet: list[Path], local_out: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    capsys.readouterr()
    log = fleet[13]  # fig13, seed 2
    args = ["run", str(log), "--cell", "0.02", "--paper", "--out", str(tmp_path), "--json"]
    args += ["--figures", "none"]  # as the batch ran it: the metrics are compared
    assert main(args) == 0
    doc = json.loads(capsys.readouterr().out)
    row = rows_of(local_out)[13]
    for key in ("e", "f_c", "E1_m", "E2", "N", "N_k"):
        assert row[key] == doc["metrics"].get(key), key


def test_serial_run_gives_the_same_summary(
    fleet: list[Path], local_out: Path, tmp_path: Path
) -> None:
    assert _batch(fleet, tmp_path, "--workers", "1") == 1
    assert (tmp_path / "summary.jsonl").read_bytes() == (local_out / "summary.jsonl").read_bytes()


def test_dask_gives_identical_summaries(fleet: list[Path], local_out: Path, tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    assert _batch(fleet, tmp_path, "--engine", "dask", "--workers", "2", child=True) == 1
    assert (tmp_path / "summary.csv").read_bytes() == (local_out / "summary.csv").read_bytes()
    assert (tmp_path / "summary.jsonl").read_bytes() == (local_out / "summary.jsonl").read_bytes()


def test_a_rerun_replaces_the_reports_whole(fleet: list[Path], tmp_path: Path) -> None:
    logs = [fleet[4]]
    assert _batch(logs, tmp_path, "--figures", "png") == 0
    assert (tmp_path / "fig06a" / "arcmap.png").is_file()
    (tmp_path / "fig06a" / "stale.txt").write_text("from an older run\n")
    assert _batch(logs, tmp_path) == 0
    assert sorted(os.listdir(tmp_path / "fig06a")) == [
        "profile.csv",
        "report.html",
        "report.json",
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "fig06a",
        "summary.csv",
        "summary.jsonl",
    ]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--engine", "spark"], "--engine: bad value 'spark'; expected local, dask or dask="),
        (["--engine", "dask="], "--engine: bad value 'dask='"),
        (["--workers", "-1"], "--workers (--jobs): must be >= 0, got -1"),
        (["--figures", "gif"], "--figures: must be png,svg, png, svg or none"),
        (["--cell", "0"], "--cell"),
    ],
)
def test_usage_errors(
    fleet: list[Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    extra: list[str],
    message: str,
) -> None:
    out = tmp_path / "out"
    assert _batch(fleet[:1], out, *extra) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("sonarproc: error: ") and message in err[0]
    assert not out.exists()


def test_out_that_is_a_file_is_a_usage_error(
    fleet: list[Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "file"
    target.write_text("x")
    assert _batch(fleet[:1], target) == 2
    assert "--out: " in capsys.readouterr().err


def test_dask_without_dask_is_a_one_line_hint(
    fleet: list[Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name == "distributed" else real(name, *a),
    )
    for command in (["batch", str(fleet[0])], ["sweep", "fig13", "--grid", "seed=1"]):
        assert main([*command, "--out", str(tmp_path / "o"), "--engine", "dask"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        hint = "dask needs the optional extra: pip install 'sonarmorph[dask]'"
        assert err == [f"sonarproc: error: --engine: {hint}"]

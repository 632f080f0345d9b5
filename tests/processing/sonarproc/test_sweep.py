"""Parameter sweeps: grid parsing, sharding, merging, and rows equal to single runs."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sonarproc.cli import main
from sonarproc.simulate import simulate_to_log
from sonarproc.sweep import (
    GridSyntaxError,
    combinations,
    parse_grid,
    parse_shard,
    shard_indices,
)
from sonarproc.sweep.merge import best_rows

SCENARIOS = Path(__file__).resolve().parents[3] / "configs" / "scenarios"
FIG13 = SCENARIOS / "fig13.yaml"


@pytest.fixture(scope="module")
def log_h5(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("sweep") / "fig02.h5"
    simulate_to_log(SCENARIOS / "fig02.yaml", path)
    return path


def rows_of(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


def without_time(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [{k: v for k, v in r.items() if k != "t_cpu_s"} for r in rows]


# ---- grid parsing ---------------------------------------------------------------------


@pytest.mark.parametrize(
    ("spec", "expected"),
    [
        ("ops=thinning:1..3", {"ops": ["thinning:1", "thinning:2", "thinning:3"]}),
        ("order=4..6;fit=poly", {"order": [4, 5, 6], "fit": ["poly"]}),
        ("order=4,auto|9", {"order": [4, "auto", 9]}),
        (
            "ops=closing,thinning:1..2|vote:auto,ridge",
            {"ops": ["closing,thinning:1", "closing,thinning:2", "vote:auto,ridge"]},
        ),
        ("cell=0.01..0.03@3", {"cell": [0.01, 0.02, 0.03]}),
        ("sigma=0.001..0.1@log3;seed=0..2", {"sigma": [0.001, 0.01, 0.1], "seed": [0, 1, 2]}),
        (
            " robust = huber ; span=points|truth ",
            {"robust": ["huber"], "span": ["points", "truth"]},
        ),
        ("drop-crosstalk=true,false", {"drop_crosstalk": [True, False]}),
    ],
)
def test_parse_grid_valid(spec: str, expected: dict[str, list[Any]]) -> None:
    assert parse_grid(spec) == expected


@pytest.mark.parametrize(
    ("spec", "token", "why"),
    [
        ("", "", "empty grid"),
        ("ops", "ops", "expected KEY=VALUES"),
        ("colour=red", "colour=red", "unknown key 'colour'"),
        ("ops=thinning:1..9", "thinning:1..9", "n must be in 1..8"),
        ("ops=frobnicate", "frobnicate", "frobnicate"),
        ("order=4..x", "4..x", "not an integer"),
        ("order=9..4", "9..4", "empty range"),
        ("order=1..3@log3", "1..3@log3", "this key takes integers"),
        ("order=99", "order=99", "order: must be between 0 and 60"),
        ("cell=0..0.1@log3", "0..0.1@log3", "a log range needs LO > 0"),
        ("cell=-0.01", "cell=-0.01", "cell: must be > 0"),
        ("fit=cubic", "cubic", "expected one of poly, spline, polar"),
        ("order=4|4", "order=4|4", "a value appears twice"),
        ("order=4;order=5", "order=5", "given twice"),
        ("order=4||5", "order=4||5", "empty value"),
        ("sigma=2", "sigma=2.0", "sigma must be between 0 and 1"),
        ("drop_crosstalk=maybe", "maybe", "expected true or false"),
    ],
)
def test_parse_grid_invalid(spec: str, token: str, why: str) -> None:
    with pytest.raises(GridSyntaxError) as info:
        parse_grid(spec)
    msg = str(info.value)
    assert msg.startswith(f"grid: bad token {token!r}: ")
    assert why in msg and "syntax: KEY=V1|V2|A..B" in msg and "\n" not in msg


def test_invalid_grid_on_the_command_line(
    log_h5: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code = main(["sweep", str(log_h5), "--grid", "ops=thinning:1..9", "--out", str(tmp_path)])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert err[0].startswith("sonarproc: error: --grid: bad token 'thinning:1..9'")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--grid", "fit=spline;robust=huber"],
            "is invalid: fit: must be poly for an automatic order or a robust fit",
        ),
        (["--grid", "sigma=0.01"], "sigma and seed need a scenario input"),
        (["--grid", "order=4", "--shard", "3/3"], "--shard: bad value '3/3'"),
        (["--grid", "order=4", "--shard", "x"], "expected I/N with 0 <= I < N"),
    ],
)
def test_sweep_usage_errors(
    log_h5: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    message: str,
) -> None:
    assert main(["sweep", str(log_h5), *args, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]


# ---- sharding ---------------------------------------------------------------------------


@settings(max_examples=60, deadline=None)
@given(total=st.integers(0, 200), n=st.integers(1, 5))
def test_shards_cover_every_combination_once(total: int, n: int) -> None:
    covered = [i for k in range(n) for i in shard_indices(total, (k, n))]
    assert sorted(covered) == list(range(total))


@settings(max_examples=20, deadline=None)
@given(n=st.integers(1, 5), orders=st.integers(1, 6), ops=st.integers(1, 4))
def test_shards_of_a_real_grid(n: int, orders: int, ops: int) -> None:
    grid = parse_grid(f"order=1..{orders};ops=thinning:1..{ops}")
    combos = combinations(["a.h5", "b.h5"], grid)
    assert len(combos) == 2 * orders * ops
    keys = [combos[i].key for k in range(n) for i in shard_indices(len(combos), (k, n))]
    assert len(keys) == len(set(keys)) == len(combos)
    assert [c.index for c in combos] == list(range(len(combos)))


def test_parse_shard() -> None:
    assert parse_shard("0/1") == (0, 1)
    assert parse_shard(" 4 / 5 ") == (4, 5)
    for bad in ("5/5", "-1/3", "1", "a/b", "1/0"):
        with pytest.raises(GridSyntaxError):
            parse_shard(bad)


# ---- runs and merges --------------------------------------------------------------------

GRID = "ops=thinning:1|thinning:3;order=4|9"


def test_rows_equal_single_runs(
    log_h5: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["sweep", str(log_h5), "--grid", GRID, "--out", str(tmp_path / "s")]) == 0
    rows = rows_of(tmp_path / "s" / "results.jsonl")
    assert [r["index"] for r in rows] == [0, 1, 2, 3]
    assert [(r["ops"], r["order"]) for r in rows] == [
        ("thinning:1", 4),
        ("thinning:1", 9),
        ("thinning:3", 4),
        ("thinning:3", 9),
    ]
    capsys.readouterr()
    for r in rows:
        out = tmp_path / f"run{r['index']}"
        args = ["run", str(log_h5), "--ops", r["ops"], "--order", str(r["order"])]
        assert main([*args, "--out", str(out), "--json"]) == 0
        m = json.loads(capsys.readouterr().out)["metrics"]
        for key in ("e", "f_c", "E1_m", "E2", "N", "N_k"):
            assert r[key] == pytest.approx(m[key], rel=1e-12), key
        assert r["ok"] and r["fit_ok"] and r["cell"] == 0.01 and r["fit"] == "auto"
    header = (tmp_path / "s" / "results.csv").read_text().splitlines()[0]
    assert header.startswith("index,input,ops,order,cell,fit,robust,span,smooth,")
    assert header.endswith(
        ",e,f_c,E1_m,E2,t_cpu_s,N,N_k,readings_used,processed_cells,cv_score,"
        "surfaces,precision_m,completeness,"
        "explained_fraction,heldout_residual_median_m,heldout_residual_p90_m"
    )


def test_jobs_2_gives_the_same_table(log_h5: Path, tmp_path: Path) -> None:
    grid = "ops=thinning:1..3;order=4|9"
    for jobs in ("1", "2"):
        out = str(tmp_path / jobs)
        assert (
            main(["sweep", str(log_h5), str(FIG13), "--grid", grid, "--jobs", jobs, "--out", out])
            == 0
        )
    one, two = rows_of(tmp_path / "1" / "results.jsonl"), rows_of(tmp_path / "2" / "results.jsonl")
    assert len(one) == 12
    assert without_time(one) == without_time(two)


def test_scenario_seeds_and_noise(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    grid = "sigma=0|0.05;seed=3|13"
    assert main(["sweep", str(FIG13), "--grid", grid, "--out", str(tmp_path / "s")]) == 0
    rows = {(r["sigma"], r["seed"]): r for r in rows_of(tmp_path / "s" / "results.jsonl")}
    assert set(rows) == {(0.0, 3), (0.0, 13), (0.05, 3), (0.05, 13)}
    assert rows[(0.0, 13)]["E1_m"] != rows[(0.05, 13)]["E1_m"]
    # sigma 0.05 is the scenario's own noise: the row equals simulate --seed + run
    for seed in (3, 13):
        log = tmp_path / f"fig13-{seed}.h5"
        assert main(["simulate", str(FIG13), "--out", str(log), "--seed", str(seed)]) == 0
        out = tmp_path / f"r{seed}"
        # the metrics are compared, not figures: none are drawn
        args = ["run", str(log), "--paper", "--out", str(out), "--json", "--figures", "none"]
        assert main(args) == 0
        m = json.loads(_json_tail(capsys.readouterr().out))["metrics"]
        for key in ("e", "f_c", "E1_m", "E2"):
            assert rows[(0.05, seed)][key] == pytest.approx(m[key], rel=1e-12), key


def _json_tail(text: str) -> str:
    return text[text.index("{") :]


def test_shards_merge_to_the_full_table(
    log_h5: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    grid = "ops=thinning:1..3;order=4|9"
    assert main(["sweep", str(log_h5), "--grid", grid, "--out", str(tmp_path / "full")]) == 0
    for k in range(3):
        out = str(tmp_path / f"node{k}")
        assert main(["sweep", str(log_h5), "--grid", grid, "--shard", f"{k}/3", "--out", out]) == 0
    capsys.readouterr()
    dirs = [str(tmp_path / f"node{k}") for k in range(3)]
    assert main(["sweep-merge", *dirs, "--out", str(tmp_path / "merged")]) == 0
    out = capsys.readouterr().out
    assert "6 of 6 combinations from 3 shard(s)" in out
    merged = rows_of(tmp_path / "merged" / "merged.jsonl")
    full = rows_of(tmp_path / "full" / "results.jsonl")
    assert without_time(merged) == without_time(full)
    best = json.loads((tmp_path / "merged" / "best.json").read_text())
    row = best["best"][str(log_h5)]["row"]
    assert best["best"][str(log_h5)]["criterion"] == "min E1_m (truth)"
    assert row["E1_m"] == min(r["E1_m"] for r in full)
    assert best["missing"] == [] and best["duplicates"] == []


def test_merge_reports_missing_and_duplicates(
    log_h5: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    grid = "order=2..8"  # 7 combinations; shard 0/3 runs 0, 3, 6
    a, b = str(tmp_path / "a"), str(tmp_path / "b")
    assert main(["sweep", str(log_h5), "--grid", grid, "--shard", "0/3", "--out", a]) == 0
    assert main(["sweep", str(log_h5), "--grid", grid, "--shard", "0/3", "--out", b]) == 0
    assert main(["sweep", str(log_h5), "--grid", grid, "--shard", "1/3", "--out", b]) == 0
    capsys.readouterr()
    assert main(["sweep-merge", a, b, "--out", str(tmp_path / "m")]) == 1
    cap = capsys.readouterr()
    assert "3 combination(s) ran more than once, kept once: 0,3,6" in cap.err
    assert cap.err.strip().splitlines()[-1] == (
        "sonarproc: error: 2 of 7 combinations missing: 2,5"
    )
    summary = json.loads((tmp_path / "m" / "best.json").read_text())
    assert summary["missing"] == [2, 5] and summary["duplicates"] == [0, 3, 6]
    assert summary["conflicting"] == []
    assert len(rows_of(tmp_path / "m" / "merged.jsonl")) == 5


def test_merge_refuses_mixed_sweeps(
    log_h5: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    a, b = str(tmp_path / "a"), str(tmp_path / "b")
    assert main(["sweep", str(log_h5), "--grid", "order=4", "--out", a]) == 0
    assert main(["sweep", str(log_h5), "--grid", "order=5", "--out", b]) == 0
    capsys.readouterr()
    assert main(["sweep-merge", a, b]) == 2
    assert "from a different sweep" in capsys.readouterr().err
    assert main(["sweep-merge", str(tmp_path / "nothing")]) == 2


def test_best_without_truth_uses_cross_validation() -> None:
    base = {"input": "x.h5", "ok": True, "fit_ok": True, "E1_m": None}
    rows = [
        {**base, "index": 0, "f_c": 1.0, "cv_score": 4e-4},
        {**base, "index": 1, "f_c": 0.95, "cv_score": 1e-4},
        {**base, "index": 2, "f_c": 0.5, "cv_score": 1e-6},  # too little coverage
        {**base, "index": 3, "f_c": 1.0, "cv_score": None},
    ]
    best = best_rows(rows)["x.h5"]
    assert best["row"]["index"] == 1 and "cv_score" in best["criterion"]
    truth = [{**r, "E1_m": 0.1 * (4 - r["index"])} for r in rows]
    assert best_rows(truth)["x.h5"]["row"]["index"] == 3


def test_unreadable_inputs_stop_the_sweep(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\nworld: nowhere.yaml\n", encoding="utf-8")
    out = str(tmp_path / "o")
    for jobs in ("1", "2"):
        assert main(["sweep", str(bad), "--grid", "seed=0..2", "--jobs", jobs, "--out", out]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("sonarproc: error: ") and "bad.yaml" in err[0]
    assert main(["sweep", str(tmp_path / "none.h5"), "--grid", "order=4", "--out", out]) == 2
    assert "none.h5: no such file" in capsys.readouterr().err
    notlog = tmp_path / "x.csv"
    notlog.write_text("t\n", encoding="utf-8")
    assert main(["sweep", str(notlog), "--grid", "order=4", "--out", out]) == 2
    assert (
        "must be a log (.h5, .bag, a ROS 2 bag) or a scenario (.yaml, or the name of a shipped one)"
        in capsys.readouterr().err
    )

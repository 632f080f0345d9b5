"""Parameter sweeps: a grid of ``sonarproc run`` parameters over logs or scenarios.

A grid spec names the values of each parameter, ``KEY=VALUES`` separated by ``;``::

    ops=thinning:1..8;order=4..12;cell=0.01|0.02;sigma=0.001..0.3@log7;seed=0..4

VALUES are alternatives separated by ``|`` (for every key but ``ops``, ``,`` works too; in
``ops`` a comma chains operations, as in ``--ops``). An alternative may be a range:
``A..B`` (integers A to B inclusive; also inside an operation, ``thinning:1..8``),
``LO..HI@N`` (N evenly spaced numbers) or ``LO..HI@logN`` (N log-spaced numbers).

Combinations are numbered in a fixed order (inputs outermost, then the keys in the order
the spec names them, the last varying fastest), so shard ``I/N`` (every N-th combination
starting at I) covers the grid with any other shards of the same N, whichever machine
runs them. ``sigma`` (range noise, m) and ``seed`` apply to scenario inputs: each
combination simulates its scenario with that noise and seed.

Library only: :func:`parse_grid`, :func:`combinations`, :func:`shard_indices`,
:func:`run_sweep` here, :func:`~sonarproc.sweep.merge.merge_shards` and
:func:`~sonarproc.sweep.merge.best_rows` in :mod:`sonarproc.sweep.merge`; the command line
is :mod:`sonarproc.cli.sweep`.
"""

from __future__ import annotations

import csv
import json
import logging
import math
import multiprocessing
import multiprocessing.context
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.errors import InputError
from sonarproc.report.jsonable import to_jsonable
from sonarproc.sweep.grid import (
    DATA_KEYS,
    KEYS,
    Combination,
    GridSyntaxError,
    combination_params,
    combinations,
    is_scenario_path,
    parse_grid,
    parse_shard,
    shard_indices,
)

__all__ = [
    "COLUMNS",
    "KEYS",
    "Combination",
    "GridSyntaxError",
    "SweepResult",
    "combinations",
    "parse_grid",
    "parse_shard",
    "run_sweep",
    "shard_indices",
    "write_table",
]

log = logging.getLogger(__name__)

#: Columns of the results table, in order.
COLUMNS = (
    "index",
    "input",
    *KEYS,
    "ok",
    "error",
    "fit_ok",
    "e",
    "f_c",
    "E1_m",
    "E2",
    "t_cpu_s",
    "N",
    "N_k",
    "readings_used",
    "processed_cells",
    "cv_score",
    # several surfaces (fit=auto on a room): scored where E1 and E2 are not defined
    "surfaces",
    "precision_m",
    "completeness",
    # the truth-free quality every run measures (report.json's quality)
    "explained_fraction",
    "heldout_residual_median_m",
    "heldout_residual_p90_m",
)


#: What a sweep takes as an input.
INPUT_KINDS = (
    "a sweep input must be a log (.h5, .bag, a ROS 2 bag) or a scenario (.yaml, or the "
    "name of a shipped one)"
)


def _load(inp: str, values: dict[str, Any]) -> Any:
    """The log of a combination: read a sonarlog, or simulate a scenario."""
    from sonarlog import SonarLog
    from sonarproc.pipeline import load_log

    scenario = is_scenario_path(inp)
    if scenario is None:
        raise InputError(f"{inp}: {INPUT_KINDS}")
    if not scenario:
        return load_log(inp)
    from dataclasses import replace

    from sonarsim import load_scenario, simulate

    scn = load_scenario(inp, seed=values.get("seed"))
    if "sigma" in values:
        imps = scn.imperfections.model_copy(update={"range_noise_sigma": float(values["sigma"])})
        scn = replace(scn, imperfections=imps)
    res = simulate(scn)
    attrs = {**res.attrs, "speed_of_sound": res.speed_of_sound}
    truth = res.truth if res.truth.size else None
    return SonarLog(
        path=Path(inp), attrs=attrs, sensors=res.sensors, readings=res.readings, truth=truth
    )


def _row(c: Combination, lg: Any) -> dict[str, Any]:
    """Run one combination on its log; a refused run becomes a row with ``ok`` false."""
    from sonarproc.fit import select_order_cv
    from sonarproc.pipeline import process

    p = combination_params(c.values)
    row: dict[str, Any] = {"index": c.index, "input": c.input}
    effective = p.to_json()
    for k in KEYS:
        row[k] = c.values.get(k, effective.get(k))
    if "sigma" not in c.values and is_scenario_path(c.input):
        row["sigma"] = None
    if "seed" not in c.values and is_scenario_path(c.input):
        row["seed"] = lg.attrs.get("seed")
    row.update(ok=False, error=None, fit_ok=False)
    row.update({k: None for k in COLUMNS if k not in row})
    try:
        r = process(lg, p)
    except ValueError as err:
        row["error"] = str(err)
        return row
    # the run's own record (report.json's fit and metrics): a surfaces fit is a success,
    # scored by precision and completeness where E1 and E2 are not defined
    fit = r.fit_json()
    m = r.metrics_json()
    row.update(
        ok=True,
        fit_ok=bool(fit.get("ok")),
        e=m["e"],
        f_c=m["f_c"],
        E1_m=m.get("E1_m"),
        E2=m.get("E2"),
        surfaces=fit.get("surfaces"),
        precision_m=m.get("precision_m"),
        completeness=m.get("completeness"),
        t_cpu_s=r.t_cpu_s,
        N=m["N"],
        N_k=m["N_k"],
        readings_used=r.counts["readings_used"],
        processed_cells=r.counts["processed_cells"],
    )
    if r.quality is not None:
        row.update(
            explained_fraction=r.quality.explained_fraction,
            heldout_residual_median_m=r.quality.heldout_median_m,
            heldout_residual_p90_m=r.quality.heldout_p90_m,
        )
    if r.truth is None and p.fit != "polar" and r.surfaces is None and r.points_x.size:
        try:
            _, scores = select_order_cv(
                r.points_x,
                r.points_y,
                np.ones(r.points_x.size),
                orders=range(p.fit_order, p.fit_order + 1),
                robust=False,
            )
            row["cv_score"] = scores[p.fit_order]
        except ValueError:
            pass
    return to_jsonable(row)


def _run_task(
    task: list[Combination], progress: Callable[[int], None] | None = None
) -> list[dict[str, Any]]:
    """Run combinations that share one input, noise and seed: load or simulate once.

    A log or scenario that cannot be read raises (the whole sweep stops: a usage error).
    ``progress`` (in-process runs only) hears of each finished combination.
    """
    data = {k: v for k, v in task[0].values.items() if k in DATA_KEYS}
    lg = _load(task[0].input, data)
    rows = []
    for c in task:
        rows.append(_row(c, lg))
        if progress is not None:
            progress(1)
    return rows


def _tasks(combos: Sequence[Combination], jobs: int) -> list[list[Combination]]:
    """Group combinations by data (input, sigma, seed): each group loads or simulates its
    log once. Groups are split only when there are fewer than ``jobs`` of them (a split
    repeats the load), so that every worker has something to do."""
    groups: dict[str, list[Combination]] = {}
    for c in combos:
        key = json.dumps([c.input, *(c.values.get(k) for k in DATA_KEYS)])
        groups.setdefault(key, []).append(c)
    tasks: list[list[Combination]] = []
    splits = max(1, math.ceil(jobs / max(1, len(groups))))
    for g in groups.values():
        size = max(1, math.ceil(len(g) / splits))
        for s in range(0, len(g), size):
            tasks.append(g[s : s + size])
    return tasks


def _mp_context() -> multiprocessing.context.BaseContext:
    """Workers from a fork server that has imported this module (cheap to start, and no
    fork of a possibly multi-threaded parent); plain spawn where there is no fork server."""
    if "forkserver" in multiprocessing.get_all_start_methods():
        ctx = multiprocessing.get_context("forkserver")
        ctx.set_forkserver_preload(["sonarproc.sweep", "sonarproc.pipeline", "sonarsim"])
        return ctx
    return multiprocessing.get_context("spawn")


@dataclass
class SweepResult:
    """What :func:`run_sweep` did."""

    rows: list[dict[str, Any]]
    total: int
    wall_s: float
    manifest: dict[str, Any] = field(default_factory=dict)


def run_sweep(
    inputs: Sequence[str],
    spec: str,
    *,
    jobs: int = 1,
    shard: tuple[int, int] = (0, 1),
    progress: Callable[[int, int], None] | None = None,
) -> SweepResult:
    """Run this shard's combinations of the grid, ``jobs`` processes at once.

    Parameters
    ----------
    inputs : sequence of str
        Sonarlog files and/or scenario YAML files.
    spec : str
        The grid (:func:`parse_grid`).
    jobs : int
        Worker processes (1: in this process).
    shard : (I, N)
        Run every N-th combination starting at I.
    progress : callable, optional
        ``progress(done, total)``: combinations of this shard finished so far and in
        all, after each one in this process, after each task with ``jobs > 1``.

    Returns
    -------
    SweepResult
        Rows sorted by combination index.
    """
    for inp in inputs:
        kind = is_scenario_path(inp)
        if not Path(inp).exists() and kind is not True:  # a shipped scenario's name is fine
            raise FileNotFoundError(2, "no such file", inp)
        if kind is None:
            raise InputError(f"{inp}: {INPUT_KINDS}")
    grid = parse_grid(spec)
    combos = combinations(list(inputs), grid)
    mine = [combos[i] for i in shard_indices(len(combos), shard)]
    wall0 = time.perf_counter()
    tasks = _tasks(mine, jobs)
    rows: list[dict[str, Any]] = []
    finished = 0

    def advance(n: int) -> None:
        nonlocal finished
        finished += n
        if progress is not None:
            progress(finished, len(mine))

    advance(0)
    if jobs <= 1 or len(tasks) <= 1:
        for t in tasks:
            rows.extend(_run_task(t, advance))
    else:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=_mp_context()) as pool:
            for done in as_completed([pool.submit(_run_task, t) for t in tasks]):
                part = done.result()
                rows.extend(part)
                advance(len(part))
    rows.sort(key=lambda r: int(r["index"]))
    manifest = {
        "format": "sonarproc-sweep",
        "version": 1,
        "grid": spec,
        "keys": list(grid),
        "inputs": list(inputs),
        "total": len(combos),
        "shard": list(shard),
        "rows": len(rows),
    }
    return SweepResult(rows, len(combos), time.perf_counter() - wall0, manifest)


def _csv_value(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)


def write_table(rows: Iterable[dict[str, Any]], out_dir: Path, stem: str) -> tuple[Path, Path]:
    """Write ``stem.csv`` and ``stem.jsonl`` (one row per run, :data:`COLUMNS`)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = list(rows)
    csv_path, jsonl_path = out_dir / f"{stem}.csv", out_dir / f"{stem}.jsonl"
    with csv_path.open("w", encoding="utf-8", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([_csv_value(r.get(k)) for k in COLUMNS])
    with jsonl_path.open("w", encoding="utf-8") as fh:
        for r in rows:
            fh.write(json.dumps({k: r.get(k) for k in COLUMNS}) + "\n")
    return csv_path, jsonl_path


def shard_stem(shard: tuple[int, int]) -> str:
    """File stem of a shard's outputs: ``results`` or ``results.shard-I-of-N``."""
    return "results" if shard == (0, 1) else f"results.shard-{shard[0]}-of-{shard[1]}"


def write_sweep(result: SweepResult, out_dir: Path) -> Path:
    """Write a sweep's table and its manifest (``STEM.json``); return the CSV path."""
    i, n = result.manifest["shard"]
    stem = shard_stem((int(i), int(n)))
    csv_path, _ = write_table(result.rows, out_dir, stem)
    manifest = {**result.manifest, "table": f"{stem}.jsonl", "wall_s": result.wall_s}
    (out_dir / f"{stem}.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return csv_path

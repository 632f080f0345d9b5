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
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.engines import Engine, map_chunks, runs_here
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
from sonarproc.sweep.shared import SharedMaps, clear_shared, shared_log

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


def _row(c: Combination, lg: Any, maps: SharedMaps | None = None) -> dict[str, Any]:
    """Run one combination on its log; a refused run becomes a row with ``ok`` false.

    ``maps``: the log's shared count maps (None: a whole run of its own, as
    ``sonarproc run`` does it).
    """
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
        r = process(lg, p) if maps is None else maps.process(p)
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


def _data_values(c: Combination) -> dict[str, Any]:
    return {k: v for k, v in c.values.items() if k in DATA_KEYS}


def _map_key(c: Combination) -> str:
    """The map parameters of a combination, as a sortable key (see :class:`SharedMaps`)."""
    try:
        return repr(SharedMaps.map_key(combination_params(c.values)))
    except ValueError:  # refused later, with its row
        return ""


def run_chunk(
    task: list[Combination], tick: Callable[[], None] | None = None
) -> list[dict[str, Any]]:
    """Run a chunk of combinations that share one input, noise and seed.

    The log is read or simulated once per worker process (:func:`shared_log`), and the
    combinations run in the order of their map parameters, so that each count map is
    built once. A log or scenario that cannot be read raises (the whole sweep stops: a
    usage error). ``tick`` (in this process only) hears of each finished combination.
    """
    lg, maps = shared_log(task[0].input, _data_values(task[0]), _load)
    rows = []
    for c in sorted(task, key=_map_key):
        rows.append(_row(c, lg, maps))
        if tick is not None:
            tick()
    return rows


def chunks_of(combos: Sequence[Combination], workers: int) -> list[list[Combination]]:
    """Cut combinations into chunks, one per (input, sigma, seed) group.

    A group is split only when there are fewer groups than ``workers`` (a split makes a
    second worker read or simulate the same data), along its map parameters so that
    each chunk builds as few count maps as it can. Every chunk holds several runs: the
    cost of handing a task to a worker is paid per chunk.
    """
    groups: dict[str, list[Combination]] = {}
    for c in combos:
        key = json.dumps([c.input, *(c.values.get(k) for k in DATA_KEYS)])
        groups.setdefault(key, []).append(c)
    chunks: list[list[Combination]] = []
    splits = max(1, math.ceil(workers / max(1, len(groups))))
    for g in groups.values():
        g = sorted(g, key=_map_key)
        size = max(1, math.ceil(len(g) / splits))
        for s in range(0, len(g), size):
            chunks.append(g[s : s + size])
    return chunks


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
    engine: Engine | None = None,
) -> SweepResult:
    """Run this shard's combinations of the grid on ``jobs`` workers.

    Parameters
    ----------
    inputs : sequence of str
        Sonarlog files and/or scenario YAML files.
    spec : str
        The grid (:func:`parse_grid`).
    jobs : int
        Workers (local processes, or a Dask ``LocalCluster``'s; 1 with the local
        engine: in this process).
    shard : (I, N)
        Run every N-th combination starting at I.
    progress : callable, optional
        ``progress(done, total)``: combinations of this shard finished so far and in
        all: after each one in this process, after each chunk on workers.
    engine : Engine, optional
        Where the chunks run (:mod:`sonarproc.engines`; default: local). The rows do
        not depend on it.

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
    finished = 0

    def advance(n: int) -> None:
        nonlocal finished
        finished += n
        if progress is not None:
            progress(finished, len(mine))

    advance(0)
    where = engine or Engine()
    chunks = chunks_of(mine, jobs)
    try:
        if runs_here(where, jobs, len(chunks)):  # progress after every combination
            parts = [run_chunk(ch, lambda: advance(1)) for ch in chunks]
        else:
            parts = map_chunks(
                run_chunk, chunks, engine=where, workers=jobs, done=lambda p: advance(len(p))
            )
    finally:
        clear_shared()  # chunks run in this process leave no logs behind in it
    rows = [r for part in parts for r in part]
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

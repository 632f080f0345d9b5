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
:func:`run_sweep`, :func:`merge_shards`; the command line is :mod:`sonarproc.cli_sweep`.
"""

from __future__ import annotations

import csv
import itertools
import json
import logging
import math
import multiprocessing
import multiprocessing.context
import re
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sonarproc.params import RunParams

__all__ = [
    "KEYS",
    "Combination",
    "GridSyntaxError",
    "MergeResult",
    "best_rows",
    "combinations",
    "merge_shards",
    "parse_grid",
    "parse_shard",
    "run_sweep",
    "shard_indices",
    "write_table",
]

log = logging.getLogger(__name__)

SYNTAX = (
    "KEY=V1|V2|A..B|LO..HI@N|LO..HI@logN[;KEY=...] with KEY in "
    "ops, order, cell, fit, robust, span, smooth, drop_crosstalk, sigma, seed"
)

#: Parameter keys and the kind of their values.
KEYS: dict[str, str] = {
    "ops": "ops",
    "order": "order",
    "cell": "float",
    "fit": "choice:poly,spline,polar",
    "robust": "choice:none,huber",
    "span": "choice:truth,points",
    "smooth": "float",
    "drop_crosstalk": "bool",
    "sigma": "float",
    "seed": "int",
}
#: Keys that change the data (simulation) rather than the processing.
DATA_KEYS = ("sigma", "seed")
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
)

_RANGE = re.compile(r"^(-?[0-9.eE+-]+?)\.\.(-?[0-9.eE+-]+?)(?:@(log)?([0-9]+))?$")
_INT_RANGE = re.compile(r"^(.*?)(-?[0-9]+)\.\.(-?[0-9]+)$")


class GridSyntaxError(ValueError):
    """A bad ``--grid`` (or ``--shard``) spec; the message names the token and the syntax."""


def _bad(token: str, why: str) -> GridSyntaxError:
    return GridSyntaxError(f"--grid: bad token {token!r}: {why}; syntax: {SYNTAX}")


def _numbers(token: str, kind: str) -> list[Any]:
    """Expand one alternative of a numeric key: a number or a range."""
    m = _RANGE.match(token)
    if m is None:
        try:
            return [int(token)] if kind == "int" else [float(token)]
        except ValueError:
            raise _bad(token, f"not a{'n integer' if kind == 'int' else ' number'}") from None
    lo_s, hi_s, log_, count_s = m.groups()
    if count_s is None:
        try:
            lo, hi = int(lo_s), int(hi_s)
        except ValueError:
            raise _bad(token, "A..B needs integers (use LO..HI@N for numbers)") from None
        if hi < lo:
            raise _bad(token, "empty range (B < A)")
        values: list[Any] = list(range(lo, hi + 1))
        return values if kind == "int" else [float(v) for v in values]
    if kind == "int":
        raise _bad(token, "this key takes integers: use A..B")
    try:
        lo_f, hi_f = float(lo_s), float(hi_s)
    except ValueError:
        raise _bad(token, "range ends must be numbers") from None
    count = int(count_s)
    if count < 1:
        raise _bad(token, "the count after @ must be >= 1")
    if log_:
        if not (lo_f > 0 and hi_f > 0):
            raise _bad(token, "a log range needs LO > 0 and HI > 0")
        arr = np.geomspace(lo_f, hi_f, count)
    else:
        arr = np.linspace(lo_f, hi_f, count)
    return [float(f"{v:.6g}") for v in arr]


def _ops_values(token: str) -> list[str]:
    """Expand one ``ops`` alternative (a chain) with integer ranges inside its steps."""
    from sonarproc.voting import parse_chain

    steps: list[list[str]] = []
    for step in token.split(","):
        step = step.strip()
        m = _INT_RANGE.match(step)
        if m is None:
            steps.append([step])
            continue
        head, lo, hi = m.group(1), int(m.group(2)), int(m.group(3))
        if hi < lo:
            raise _bad(token, "empty range (B < A)")
        steps.append([f"{head}{k}" for k in range(lo, hi + 1)])
    chains = [",".join(c) for c in itertools.product(*steps)]
    for chain in chains:
        try:
            parse_chain(chain)
        except ValueError as err:
            raise _bad(token, str(err)) from None
    return chains


def _expand(key: str, alternatives: list[str]) -> list[Any]:
    kind = KEYS[key]
    out: list[Any] = []
    for alt in alternatives:
        if kind == "ops":
            out.extend(_ops_values(alt))
        elif kind == "order":
            out.extend(["auto"] if alt.lower() == "auto" else _numbers(alt, "int"))
        elif kind in ("int", "float"):
            out.extend(_numbers(alt, kind))
        elif kind == "bool":
            low = alt.lower()
            if low not in ("true", "false", "1", "0", "yes", "no"):
                raise _bad(alt, "expected true or false")
            out.append(low in ("true", "1", "yes"))
        else:
            allowed = kind.split(":", 1)[1].split(",")
            if alt.lower() not in allowed:
                raise _bad(alt, f"expected one of {', '.join(allowed)}")
            out.append(alt.lower())
    for v in out:  # value checks: the same rules as sonarproc run
        _check_value(key, v)
    return out


def _check_value(key: str, v: Any) -> None:
    if key == "sigma":
        if not (math.isfinite(v) and 0 <= v <= 1):
            raise _bad(f"{key}={v}", "sigma must be between 0 and 1 m")
        return
    if key == "seed":
        if v < 0:
            raise _bad(f"{key}={v}", "seed must be >= 0")
        return
    try:
        _params({key: v})
    except ValueError as err:
        raise _bad(f"{key}={v}", str(err)) from None


def parse_grid(spec: str) -> dict[str, list[Any]]:
    """Parse a grid spec into ``{key: [values...]}`` in the order the spec names the keys.

    Parameters
    ----------
    spec : str
        ``KEY=VALUES[;KEY=VALUES...]`` (see the module docstring).

    Returns
    -------
    dict

    Raises
    ------
    GridSyntaxError
        One line naming the bad token and giving the syntax.

    Examples
    --------
    >>> g = parse_grid("ops=thinning:1..3;order=4,6|8;cell=0.01..0.03@3")
    >>> g["ops"], g["order"], g["cell"]
    (['thinning:1', 'thinning:2', 'thinning:3'], [4, 6, 8], [0.01, 0.02, 0.03])
    """
    grid: dict[str, list[Any]] = {}
    parts = [p.strip() for p in spec.split(";") if p.strip()]
    if not parts:
        raise _bad(spec, "empty grid")
    for part in parts:
        key, sep, values = part.partition("=")
        key = key.strip().lower().replace("-", "_")
        if not sep or not values.strip():
            raise _bad(part, "expected KEY=VALUES")
        if key not in KEYS:
            raise _bad(part, f"unknown key {key!r}")
        if key in grid:
            raise _bad(part, f"key {key!r} given twice")
        seps = r"\|" if key == "ops" else r"[|,]"
        alternatives = [a.strip() for a in re.split(seps, values)]
        if any(not a for a in alternatives):
            raise _bad(part, "empty value")
        expanded = _expand(key, alternatives)
        if len(set(map(str, expanded))) != len(expanded):
            raise _bad(part, "a value appears twice")
        grid[key] = expanded
    return grid


def _params(values: dict[str, Any]) -> RunParams:
    """A :class:`RunParams` from grid values (the data keys are ignored)."""
    kw = {k: v for k, v in values.items() if k not in DATA_KEYS}
    order = kw.pop("order", None)
    if order == "auto":
        kw["auto_order"] = True
    elif order is not None:
        kw["order"] = int(order)
    return RunParams(**kw)


@dataclass(frozen=True)
class Combination:
    """One point of the grid on one input."""

    index: int
    input: str
    values: dict[str, Any]

    @property
    def key(self) -> str:
        """A stable identity (input and values) used to find duplicates across shards."""
        return json.dumps({"input": self.input, **self.values}, sort_keys=True)


def combinations(inputs: Sequence[str], grid: dict[str, list[Any]]) -> list[Combination]:
    """Every combination, numbered in the deterministic sweep order.

    Raises
    ------
    ValueError
        ``sigma``/``seed`` with an input that is not a scenario, or a combination of
        values ``sonarproc run`` refuses (e.g. ``robust=huber`` with ``fit=spline``).
    """
    keys = list(grid)
    out: list[Combination] = []
    for inp in inputs:
        if _is_scenario(inp) is False and any(k in grid for k in DATA_KEYS):
            raise GridSyntaxError(f"--grid: sigma and seed need a scenario input, not {inp}")
        for combo in itertools.product(*(grid[k] for k in keys)):
            values = dict(zip(keys, combo, strict=True))
            out.append(Combination(len(out), inp, values))
    checked: set[str] = set()
    for c in out:
        sig = json.dumps({k: v for k, v in c.values.items() if k not in DATA_KEYS})
        if sig in checked:
            continue
        try:
            _params(c.values)
        except ValueError as err:
            raise GridSyntaxError(f"--grid: combination {sig} is invalid: {err}") from None
        checked.add(sig)
    return out


def parse_shard(text: str) -> tuple[int, int]:
    """Parse ``I/N`` (0 <= I < N).

    Examples
    --------
    >>> parse_shard("2/8")
    (2, 8)
    """
    m = re.fullmatch(r"\s*(\d+)\s*/\s*(\d+)\s*", text)
    if m is None or not 0 <= int(m.group(1)) < int(m.group(2)):
        raise GridSyntaxError(f"--shard: bad value {text!r}; expected I/N with 0 <= I < N")
    return int(m.group(1)), int(m.group(2))


def shard_indices(total: int, shard: tuple[int, int]) -> range:
    """Indices of the combinations shard ``(I, N)`` runs: every N-th from I.

    Examples
    --------
    >>> list(shard_indices(7, (1, 3)))
    [1, 4]
    """
    i, n = shard
    return range(i, total, n)


def _is_scenario(inp: str) -> bool | None:
    suffix = Path(inp).suffix.lower()
    if suffix in (".yaml", ".yml"):
        return True
    if suffix in (".h5", ".hdf5"):
        return False
    return None


def _load(inp: str, values: dict[str, Any]) -> Any:
    """The log of a combination: read a sonarlog, or simulate a scenario."""
    from sonarlog import SonarLog
    from sonarproc.pipeline import load_log

    scenario = _is_scenario(inp)
    if scenario is None:
        raise ValueError(f"{inp}: a sweep input must be a sonarlog (.h5) or a scenario (.yaml)")
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
    from sonarproc.fit import FitFailure, select_order_cv
    from sonarproc.pipeline import process

    p = _params(c.values)
    row: dict[str, Any] = {"index": c.index, "input": c.input}
    effective = p.to_json()
    for k in KEYS:
        row[k] = c.values.get(k, effective.get(k))
    if "sigma" not in c.values and _is_scenario(c.input):
        row["sigma"] = None
    if "seed" not in c.values and _is_scenario(c.input):
        row["seed"] = lg.attrs.get("seed")
    row.update(ok=False, error=None, fit_ok=False)
    row.update({k: None for k in COLUMNS if k not in row})
    try:
        r = process(lg, p)
    except ValueError as err:
        row["error"] = str(err)
        return row
    m = r.metrics.to_json()
    row.update(
        ok=True,
        fit_ok=not isinstance(r.fit, FitFailure),
        e=m["e"],
        f_c=m["f_c"],
        E1_m=m["E1_m"] if r.truth is not None else None,
        E2=m["E2"] if r.truth is not None else None,
        t_cpu_s=r.t_cpu_s,
        N=m["N"],
        N_k=m["N_k"],
        readings_used=r.counts["readings_used"],
        processed_cells=r.counts["processed_cells"],
    )
    if r.truth is None and p.fit != "polar" and r.points_x.size:
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
    return _clean(row)


def _clean(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _clean(x) for k, x in v.items()}
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def _run_task(task: list[Combination]) -> list[dict[str, Any]]:
    """Run combinations that share one input, noise and seed: load or simulate once.

    A log or scenario that cannot be read raises (the whole sweep stops: a usage error).
    """
    data = {k: v for k, v in task[0].values.items() if k in DATA_KEYS}
    lg = _load(task[0].input, data)
    return [_row(c, lg) for c in task]


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

    Returns
    -------
    SweepResult
        Rows sorted by combination index.
    """
    for inp in inputs:
        if not Path(inp).is_file():
            raise FileNotFoundError(2, "no such file", inp)
        if _is_scenario(inp) is None:
            raise ValueError(f"{inp}: a sweep input must be a sonarlog (.h5) or a scenario (.yaml)")
    grid = parse_grid(spec)
    combos = combinations(list(inputs), grid)
    mine = [combos[i] for i in shard_indices(len(combos), shard)]
    wall0 = time.perf_counter()
    tasks = _tasks(mine, jobs)
    rows: list[dict[str, Any]] = []
    if jobs <= 1 or len(tasks) <= 1:
        for t in tasks:
            rows.extend(_run_task(t))
    else:
        with ProcessPoolExecutor(max_workers=jobs, mp_context=_mp_context()) as pool:
            for part in pool.map(_run_task, tasks):
                rows.extend(part)
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


# ---- merging and choosing ---------------------------------------------------------------


@dataclass
class MergeResult:
    """Merged shards: the rows by index, and what is missing or repeated."""

    rows: list[dict[str, Any]]
    total: int
    missing: list[int]
    duplicates: list[int]
    conflicting: list[int]
    manifests: list[Path]


def merge_shards(dirs: Sequence[Path]) -> MergeResult:
    """Merge the shard outputs found in ``dirs`` into one table.

    Every ``results*.json`` manifest names its table; all must come from the same grid
    and inputs. Rows repeated across shards are kept once (``duplicates``; those whose
    metrics differ are listed in ``conflicting`` too); indices no shard ran are
    ``missing``.

    Raises
    ------
    ValueError
        No manifest found, or manifests of different sweeps.
    """
    manifests = sorted(
        {p for d in dirs for p in Path(d).glob("results*.json") if p.name != "results.merged.json"}
    )
    if not manifests:
        raise ValueError(f"no sweep outputs (results*.json) in {', '.join(map(str, dirs))}")
    ref: dict[str, Any] | None = None
    by_index: dict[int, dict[str, Any]] = {}
    duplicates: set[int] = set()
    conflicting: set[int] = set()
    for mpath in manifests:
        try:
            man = json.loads(mpath.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as err:
            raise ValueError(f"{mpath}: unreadable sweep manifest ({err})") from None
        ident = {k: man.get(k) for k in ("grid", "inputs", "total")}
        if ref is None:
            ref = ident
        elif ident != ref:
            raise ValueError(f"{mpath}: from a different sweep (grid, inputs or size differ)")
        table = mpath.with_name(str(man.get("table", "")))
        with table.open(encoding="utf-8") as fh:
            for line in fh:
                if not line.strip():
                    continue
                row = json.loads(line)
                i = int(row["index"])
                if i in by_index:
                    duplicates.add(i)
                    a = {k: v for k, v in by_index[i].items() if k != "t_cpu_s"}
                    b = {k: v for k, v in row.items() if k != "t_cpu_s"}
                    if a != b:
                        conflicting.add(i)
                    continue
                by_index[i] = row
    assert ref is not None
    total = int(ref["total"])
    missing = sorted(set(range(total)) - set(by_index))
    rows = [by_index[i] for i in sorted(by_index)]
    return MergeResult(rows, total, missing, sorted(duplicates), sorted(conflicting), manifests)


def best_rows(rows: Sequence[dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """The best parameters for each input.

    With a truth profile: the smallest ``E1_m``. Without: among the runs that keep at
    least 90 % of the best coverage ``f_c``, the smallest ``cv_score`` (the 5-fold
    cross-validated held-out loss of the fitted order on the run's own points, from
    :func:`sonarproc.fit.select_order_cv`: no ground truth); if no run has one, the
    largest ``f_c``.

    Returns
    -------
    dict
        ``{input: {"criterion": ..., "row": row}}``.
    """
    out: dict[str, dict[str, Any]] = {}
    for inp in dict.fromkeys(r["input"] for r in rows):
        good = [r for r in rows if r["input"] == inp and r.get("ok") and r.get("fit_ok")]
        with_e1 = [r for r in good if r.get("E1_m") is not None]
        if with_e1:
            best = min(with_e1, key=lambda r: (r["E1_m"], r["index"]))
            out[inp] = {"criterion": "min E1_m (truth)", "row": best}
            continue
        cover = [r for r in good if r.get("f_c") is not None]
        if not cover:
            continue
        top = max(r["f_c"] for r in cover)
        near = [r for r in cover if r["f_c"] >= 0.9 * top]
        scored = [r for r in near if r.get("cv_score") is not None]
        if scored:
            best = min(scored, key=lambda r: (r["cv_score"], r["index"]))
            crit = "min cv_score among f_c >= 0.9 max f_c (no truth)"
        else:
            best = max(cover, key=lambda r: (r["f_c"], -r["index"]))
            crit = "max f_c (no truth)"
        out[inp] = {"criterion": crit, "row": best}
    return out

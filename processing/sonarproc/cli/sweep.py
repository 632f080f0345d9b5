"""``sonarproc sweep`` and ``sonarproc sweep-merge``: parameter sweeps, local or sharded.

Thin: :mod:`sonarproc.sweep` holds the grid parsing, the sharding, the runs and the
merge; this module parses options, prints a summary and maps errors to exit codes
(:func:`sonarproc.cli.guarded`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from sonarproc.cli.app import RuntimeProblem, app, guarded
from sonarproc.cli.options import EngineOption, WorkersOption, worker_count
from sonarproc.cli.paths import check_output_dir
from sonarproc.cli.progress import progress

__all__ = ["sweep_command", "sweep_merge_command"]


@app.command("sweep")
def sweep_command(
    inputs: Annotated[
        list[Path], typer.Argument(help="Sonarlog files (.h5) and/or scenario YAML files.")
    ],
    grid: Annotated[
        str,
        typer.Option(
            help="Parameter grid, e.g. 'ops=thinning:1..8;order=4..12;sigma=0.001..0.1@log5'."
        ),
    ],
    workers: WorkersOption = 1,
    engine: EngineOption = "local",
    shard: Annotated[
        str, typer.Option(help="Run every N-th combination from I: 'I/N' (0 <= I < N).")
    ] = "0/1",
    out: Annotated[Path, typer.Option("--out", help="Output directory.")] = Path("sweep"),
) -> None:
    """Run a grid of processing parameters (and noise/seeds for scenarios); write a table."""
    from sonarproc.engines import parse_engine
    from sonarproc.sweep import parse_shard, run_sweep, write_sweep

    with guarded():
        part = parse_shard(shard)
        n_workers = worker_count(workers)
        where = parse_engine(engine)
        check_output_dir(out)
        with progress("sweep", None) as steps:
            result = run_sweep(
                [str(p) for p in inputs], grid, jobs=n_workers, shard=part, progress=steps,
                engine=where,
            )  # fmt: skip
        csv_path = write_sweep(result, out)
    failed = sum(1 for r in result.rows if not r["ok"])
    typer.echo(
        f"sonarproc sweep: {len(result.rows)} of {result.total} combinations "
        f"(shard {part[0]}/{part[1]}) in {result.wall_s:.2f} s with {where.describe(n_workers)}"
        + (f", {failed} refused (see the error column)" if failed else "")
        + f"; table: {csv_path}"
    )


@app.command("sweep-merge")
def sweep_merge_command(
    dirs: Annotated[list[Path], typer.Argument(help="Directories holding shard outputs.")],
    out: Annotated[
        Path | None, typer.Option("--out", help="Where to write (default: the first DIR).")
    ] = None,
) -> None:
    """Merge shard tables; report missing/duplicate combinations; pick the best parameters."""
    from sonarproc.sweep import write_table
    from sonarproc.sweep.merge import best_rows, merge_shards

    with guarded():
        merged = merge_shards(dirs)
        out_dir = out if out is not None else dirs[0]
        csv_path, _ = write_table(merged.rows, out_dir, "merged")
        best = best_rows(merged.rows)
        summary = {
            "total": merged.total,
            "rows": len(merged.rows),
            "missing": merged.missing,
            "duplicates": merged.duplicates,
            "conflicting": merged.conflicting,
            "shards": [str(p) for p in merged.manifests],
            "best": best,
        }
        (out_dir / "best.json").write_text(json.dumps(summary, indent=2) + "\n", encoding="utf-8")
        for inp, b in best.items():
            typer.echo(best_line(inp, b))
        if merged.duplicates:
            typer.echo(
                f"sonarproc: warning: {len(merged.duplicates)} combination(s) ran more than "
                f"once, kept once: {_ranges(merged.duplicates)}"
                + (
                    f"; results differ for {_ranges(merged.conflicting)}"
                    if merged.conflicting
                    else ""
                ),
                err=True,
            )
        typer.echo(
            f"sonarproc sweep-merge: {len(merged.rows)} of {merged.total} combinations from "
            f"{len(merged.manifests)} shard(s); table: {csv_path}; best: {out_dir / 'best.json'}"
        )
        if merged.missing:
            raise RuntimeProblem(
                f"{len(merged.missing)} of {merged.total} combinations missing: "
                f"{_ranges(merged.missing)}"
            )


def best_line(inp: str, best: dict[str, Any]) -> str:
    """One human line for an input's best parameters: tuned ones only, lengths in cm.

    Examples
    --------
    >>> best_line("a.h5", {"criterion": "min E1_m (truth)", "row": {"ops": "thinning:3",
    ...     "order": 9, "sigma": 0.01, "seed": 3, "e": 0.5, "f_c": 1.0, "E1_m": 0.0123,
    ...     "E2": 0.25}})
    'best for a.h5 (least E1): ops=thinning:3, order=9: e 0.500, f_c 1.00, E1 1.23 cm, E2 0.250'
    """
    from sonarproc.report.units import length_cm, number
    from sonarproc.sweep.merge import TUNED

    r = best["row"]
    params = ", ".join(f"{k}={r[k]}" for k in TUNED if r.get(k) is not None)
    if "cell" in params:
        params = params.replace(f"cell={r['cell']}", f"cell={length_cm(r['cell'])}")
    criterion = str(best["criterion"])
    criterion = "least E1" if criterion.startswith("min E1_m") else criterion
    if "runs" in r:
        return (
            f"best for {inp} (least mean E1 over {r['runs']} noise/seed runs): "
            f"{params or 'the defaults'}: mean E1 {length_cm(r['E1_m_mean'])}"
        )
    scores = f"e {number(r.get('e'))}, f_c {number(r.get('f_c'))}"
    if r.get("E1_m") is not None:
        scores += f", E1 {length_cm(r['E1_m'])}, E2 {number(r.get('E2'))}"
    if r.get("precision_m") is not None:
        scores += (
            f", precision {length_cm(r['precision_m'])}, "
            f"completeness {number(r.get('completeness'))}"
        )
    return f"best for {inp} ({criterion}): {params or 'the defaults'}: {scores}"


def _ranges(indices: list[int]) -> str:
    """``[0, 1, 2, 5]`` -> ``"0-2,5"``."""
    parts: list[str] = []
    start = prev = None
    for i in [*indices, None]:
        if start is not None and (i is None or i != prev + 1):  # type: ignore[operator]
            parts.append(str(start) if start == prev else f"{start}-{prev}")
            start = None
        if i is not None and start is None:
            start = i
        prev = i
    return ",".join(parts)

"""The comparison tables of ``docs/methods.md``, generated from the scenarios.

``python -m sonarmorph_tools.methods_table --doc docs/methods.md [--scenarios DIR ...]``
simulates every scenario of the shipped ``configs/scenarios/`` and of the test scenarios
``tests/data/scenarios/`` (each with its own seed), runs every registered method with
the paper's operations and polynomial order for that figure
(:data:`sonarmorph_tools.reproduce.PAPER`; the order applies to every method's fit, the
operations to ``morphological``), then ``--auto`` and every one of its candidates
(:mod:`sonarmorph_tools.auto_judge`: the error by the truth, which auto never sees), and
rewrites the part of the doc between ``<!-- methods-table:start -->`` and
``<!-- methods-table:end -->``.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Collection, Sequence
from pathlib import Path

import numpy as np

from sonarmorph_tools import TEST_SCENARIOS
from sonarmorph_tools.reproduce import PAPER, PaperRow
from sonarproc.methods import DEFAULT_METHODS, make_method
from sonarproc.methods.compare import compare, comparison_rows
from sonarproc.params import RunParams
from sonarproc.pipeline.selection import select_beams
from sonarproc.runtime import retain_freed_memory
from sonarsim.shipped import shipped_dir

__all__ = [
    "END",
    "START",
    "main",
    "render_auto_table",
    "render_surface_table",
    "render_tables",
    "run_all",
    "run_scenarios",
    "splice",
]

log = logging.getLogger(__name__)

START = "<!-- methods-table:start -->"
END = "<!-- methods-table:end -->"

Rows = dict[str, list[dict[str, object]]]

#: The table's columns: every method ``compare`` runs by default.
TABLE_METHODS = DEFAULT_METHODS

_METRICS = (
    (
        "E1_m",
        "E1 (cm), Eq. 3: RMS of fit minus truth over the columns the truth spans",
        100.0,
        ".2f",
    ),
    ("E2", "E2, Eq. 4: E1 / sigma_y", 1.0, ".3f"),
    ("e", "e, Eq. 1: RMS of the median point per column minus truth, / sigma_y", 1.0, ".3f"),
    ("f_c", "f_c = N_k / N: columns left with a point", 1.0, ".3f"),
    ("t_cpu_s", "t_cpu (ms): process CPU from the log in memory to the metrics", 1000.0, ".1f"),
)


def run_scenarios(*scenario_dirs: Path, cell: float = 0.01) -> Rows:
    """Simulate each scenario of ``scenario_dirs`` and compare every default method on it."""
    rows, _ = run_all(*scenario_dirs, cell=cell, with_auto=False)
    return rows


def run_all(
    *scenario_dirs: Path, cell: float = 0.01, with_auto: bool = True,
    only: Collection[str] | None = None,
) -> tuple[Rows, Rows]:  # fmt: skip
    """Every method and (``with_auto``) ``--auto`` (:func:`auto_row`) on each scenario.

    The scenarios of every folder of ``scenario_dirs`` run in one order, by name; ``only``
    keeps those of these names.

    A scene whose truth is several surfaces (a room, a corridor) is run with
    ``fit = "auto"`` (the surfaces fit) and its rows carry ``precision_m`` and
    ``completeness`` instead of E1, E2 and e (``"surfaces": True``).
    """
    from dataclasses import replace

    from sonarmorph_tools.auto_judge import Judge, auto_row, simulated_scenarios

    out: Rows = {}
    auto: Rows = {}
    for name, lg in simulated_scenarios(*scenario_dirs, only=only):
        paper = PAPER.get(name, PaperRow("—", "thinning:3", 9))
        params = RunParams(cell=cell, ops=paper.ops, order=paper.order)
        judge = Judge(lg, select_beams(lg, params)[0])
        if judge.metric == "precision_m":
            params = replace(params, fit="auto")
        methods = [make_method(m) for m in TABLE_METHODS]
        results = compare(lg, params, methods)
        out[name] = comparison_rows(results)
        if judge.metric == "precision_m":
            for row, r in zip(out[name], results, strict=True):
                prec, comp = judge.error(r.run)
                row.update(surfaces=True, precision_m=prec, completeness=comp)
                row.update(E1_m=None, E2=None, e=None)
        if not with_auto:
            log.info("%s done", name)
            continue
        row = auto_row(lg, RunParams(cell=cell))
        row["readings"] = len(lg.readings)
        auto[name] = [row]
        log.info("%s done: auto %s", name, row["choice"])
    return out, auto


def _cm(v: object) -> str:
    if not isinstance(v, (int, float)):
        return "—"
    return f"{100 * float(v):.2f}" if np.isfinite(v) else "undefined"


def _columns(r: dict[str, object]) -> str:
    a, b = r.get("auto_columns"), r.get("best_columns")
    if not isinstance(a, int) or not isinstance(b, int):
        return "—"
    return f"{a} / {b}"


def render_auto_table(auto: Rows) -> str:
    """Markdown: auto's choice and error against the best candidate's, per scenario."""
    head = (
        "| scenario | readings | error | `--auto` chose | auto (cm) | best candidate | best (cm) "
        "| ratio | columns judged (auto / best) | auto wall (s) |"
    )
    lines = [
        "**`--auto` against its best candidate (by the truth, which auto never sees: E1 over "
        "the columns with points for a profile; `precision_m`, the mean distance of the "
        "fitted curves to the truth, with completeness, for several surfaces). `+ echo L` "
        "says that the chosen profile was refitted through the echo points with that "
        "smoothing length (`L=a/b`: the mean of the refits tied at those lengths; `from X`: "
        "the refit started from runner-up X's profile); auto's "
        "error is that of the profile it returns, the candidates' "
        "are without the refit; a refitted profile is reported, and judged, between its "
        "outermost echo points only, so the columns each error is judged on are shown**",
        "",
        head,
        "|---" * 10 + "|",
    ]
    for scen, recs in auto.items():
        r = recs[0]
        metric = "E1" if r["metric"] == "E1_m" else "precision"
        comp = r.get("auto_completeness")
        if isinstance(comp, (int, float)):
            metric += f" (auto complete {float(comp):.2f})"
        ratio = float(r["ratio"])  # type: ignore[arg-type]
        record = r.get("record")
        refit = record.get("echo_refit") if isinstance(record, dict) else None
        chose = str(r["choice"])
        if refit and refit.get("applied"):
            if refit.get("polynomial_order") is not None:
                chose += f" + echo m={int(refit['polynomial_order'])}"
            else:
                lengths = refit.get("averaged_lengths_m") or [refit["smoothing_length_m"]]
                chose += " + echo L=" + "/".join(f"{float(k):g}" for k in lengths)
            starts = refit.get("starts") or []
            if starts and refit.get("start") != starts[0].get("start"):
                chose += f" from {refit['start']}"
        lines.append(
            f"| {scen} | {r['readings']} | {metric} | {chose} | {_cm(r['auto_error_m'])} "
            f"| {r['best']} | {_cm(r['best_error_m'])} "
            f"| {ratio:.2f} | {_columns(r)} | {float(r['auto_s']):.1f} |"  # type: ignore[arg-type]
        )
    return "\n".join(lines) + "\n"


def render_surface_table(rows: Rows) -> str:
    """Markdown: precision (cm) / completeness of each method on the multi-surface scenes."""
    scenes = {k: v for k, v in rows.items() if v and v[0].get("surfaces")}
    if not scenes:
        return ""
    names = list(TABLE_METHODS)
    head = "| scenario | " + " | ".join(f"`{n}`" for n in names) + " |"
    lines = [
        "**Several surfaces (`--fit auto`): precision (cm, mean distance of the fitted curves "
        "to the truth) / completeness (fraction of the seen truth within reach)**",
        "",
        head,
        "|---" * (len(names) + 1) + "|",
    ]
    for scen, recs in scenes.items():
        vals = {str(r["method"]): r for r in recs}
        cells = []
        for n in names:
            r = vals.get(n)
            if r is None:
                cells.append("—")
                continue
            comp = r.get("completeness")
            c = f"{float(comp):.2f}" if isinstance(comp, (int, float)) else "—"
            cells.append(f"{_cm(r.get('precision_m'))} / {c}")
        lines.append(f"| {scen} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def render_tables(rows: Rows) -> str:
    """Markdown: one table per metric, scenarios down, methods across (best in bold)."""
    names = list(TABLE_METHODS)
    parts = []
    for key, title, scale, spec in _METRICS:
        head = "| scenario (ops, m) | " + " | ".join(f"`{n}`" for n in names) + " |"
        lines = [f"**{title}**", "", head, "|---" * (len(names) + 1) + "|"]
        lower_better = key != "f_c"
        for scen, recs in rows.items():
            if key in ("E1_m", "E2", "e") and recs and recs[0].get("surfaces"):
                continue  # not one profile y(x): see the surfaces table
            vals = {str(r["method"]): r[key] for r in recs}
            nums = [v for v in vals.values() if isinstance(v, (int, float))]
            best = (min(nums) if lower_better else max(nums)) if nums and key != "t_cpu_s" else None
            paper = PAPER.get(scen, PaperRow("—", "thinning:3", 9))
            cells = []
            for n in names:
                v = vals.get(n)
                if not isinstance(v, (int, float)):
                    cells.append("—")
                    continue
                text = format(float(v) * scale, spec)
                cells.append(f"**{text}**" if best is not None and v == best else text)
            lines.append(f"| {scen} ({paper.ops}, {paper.order}) | " + " | ".join(cells) + " |")
        parts.append("\n".join(lines))
    return "\n\n".join(parts) + "\n"


def splice(doc: str, tables: str) -> str:
    """Replace the text between :data:`START` and :data:`END` in ``doc``."""
    i, j = doc.find(START), doc.find(END)
    if i < 0 or j < i:
        raise ValueError(f"the doc has no {START} ... {END} markers")
    return doc[: i + len(START)] + "\n\n" + tables + "\n" + doc[j:]


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate the tables of ``docs/methods.md``."""
    ap = argparse.ArgumentParser(
        prog="python -m sonarmorph_tools.methods_table", description=__doc__
    )
    ap.add_argument("--doc", type=Path, required=True, help="the methods.md to update")
    ap.add_argument(
        "--scenarios", type=Path, action="append", default=None, metavar="DIR",
        help="a folder of scenario YAMLs (repeatable; default: the shipped scenarios and "
        "tests/data/scenarios)",
    )  # fmt: skip
    ap.add_argument("--stdout", action="store_true", help="print the tables, leave the doc")
    ap.add_argument(
        "--only", action="append", default=None, metavar="NAME",
        help="this scenario only (repeatable; with --stdout, to look at a few)",
    )  # fmt: skip
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    retain_freed_memory()  # as the sonarproc command does: the wall times are the command's
    dirs = args.scenarios or [shipped_dir("scenarios"), TEST_SCENARIOS]
    names = {p.stem for d in dirs for p in d.glob("*.yaml")}
    unknown = sorted(set(args.only or ()) - names)
    if unknown:
        print(f"methods_table: error: --only: no scenario {', '.join(unknown)}", file=sys.stderr)
        return 2
    rows, auto = run_all(*dirs, only=args.only)
    surf = render_surface_table(rows)
    tables = render_tables(rows) + "\n" + (surf + "\n" if surf else "") + render_auto_table(auto)
    if args.stdout:
        sys.stdout.write(tables)
        return 0
    try:
        args.doc.write_text(splice(args.doc.read_text(encoding="utf-8"), tables), encoding="utf-8")
    except (OSError, ValueError) as err:
        print(f"sonarmorph_tools.methods_table: error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {args.doc}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

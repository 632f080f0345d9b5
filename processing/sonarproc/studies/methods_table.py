"""The comparison tables of ``docs/methods.md``, generated from the shipped scenarios.

``python -m sonarproc.studies.methods_table --doc docs/methods.md [--scenarios DIR]`` simulates
every ``configs/scenarios/*.yaml`` (with its own seed), runs every registered method with
the paper's operations and polynomial order for that figure
(:data:`sonarproc.studies.reproduce.PAPER`; the order applies to every method's fit, the
operations to ``morphological``), then ``--auto`` and every one of its candidates
(:mod:`sonarproc.studies.auto_study`: E1 by the truth, which auto never sees), and
rewrites the part of the doc between ``<!-- methods-table:start -->`` and
``<!-- methods-table:end -->``.
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path

from sonarproc.methods import make_method
from sonarproc.methods.compare import compare, comparison_rows
from sonarproc.params import RunParams
from sonarproc.pipeline import load_log
from sonarproc.studies.reproduce import PAPER, PaperRow
from sonarsim.shipped import shipped_dir

__all__ = [
    "END",
    "START",
    "main",
    "render_auto_table",
    "render_tables",
    "run_all",
    "run_scenarios",
    "splice",
]

log = logging.getLogger(__name__)

START = "<!-- methods-table:start -->"
END = "<!-- methods-table:end -->"

Rows = dict[str, list[dict[str, object]]]

#: The table's columns: every registered method (``compare``'s default set, then
#: Barshan's directional methods).
TABLE_METHODS = (
    "morphological",
    "arc-vote",
    "directional-max",
    "arc-median",
    "triangulation",
    "line-of-sight",
    "histogram",
    "occupancy",
)

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


def run_scenarios(scenario_dir: Path, *, cell: float = 0.01) -> Rows:
    """Simulate each scenario and compare every default method on it."""
    rows, _ = run_all(scenario_dir, cell=cell, with_auto=False)
    return rows


def run_all(scenario_dir: Path, *, cell: float = 0.01, with_auto: bool = True) -> tuple[Rows, Rows]:
    """Every method and (``with_auto``) ``--auto`` (:func:`auto_row`) on each scenario."""
    from sonarproc.simulate import simulate_to_log
    from sonarproc.studies.auto_study import auto_row

    out: Rows = {}
    auto: Rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for yml in sorted(scenario_dir.glob("*.yaml")):
            name = yml.stem
            paper = PAPER.get(name, PaperRow("—", "thinning:3", 9))
            path = Path(tmp) / f"{name}.h5"
            simulate_to_log(yml, path)
            lg = load_log(path)
            params = RunParams(cell=cell, ops=paper.ops, order=paper.order)
            methods = [make_method(m) for m in TABLE_METHODS]
            out[name] = comparison_rows(compare(lg, params, methods))
            if not with_auto:
                log.info("%s done", name)
                continue
            row = auto_row(lg, RunParams(cell=cell))
            row["readings"] = len(lg.readings)
            auto[name] = [row]
            log.info("%s done: auto %s", name, row["choice"])
    return out, auto


def render_auto_table(auto: Rows) -> str:
    """Markdown: auto's choice and E1 against the best candidate's, per scenario."""
    head = (
        "| scenario | readings | `--auto` chose | auto E1 (cm) | best candidate | best E1 (cm) "
        "| ratio | auto wall (s) |"
    )
    lines = [
        "**`--auto` against its best candidate (E1 by the truth, columns with points; auto "
        "never sees the truth)**",
        "",
        head,
        "|---" * 8 + "|",
    ]
    for scen, recs in auto.items():
        r = recs[0]

        def cm(v: object) -> str:
            return f"{100 * float(v):.2f}" if isinstance(v, (int, float)) else "—"

        ratio = r["ratio"]
        lines.append(
            f"| {scen} | {r['readings']} | {r['choice']} | {cm(r['auto_E1_m'])} | {r['best']} "
            f"| {cm(r['best_E1_m'])} | {float(ratio):.2f} | {float(r['auto_s']):.1f} |"  # type: ignore[arg-type]
        )
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
        prog="python -m sonarproc.studies.methods_table", description=__doc__
    )
    ap.add_argument("--doc", type=Path, required=True, help="the methods.md to update")
    ap.add_argument("--scenarios", type=Path, default=shipped_dir("scenarios"))
    ap.add_argument("--stdout", action="store_true", help="print the tables, leave the doc")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    rows, auto = run_all(args.scenarios)
    tables = render_tables(rows) + "\n" + render_auto_table(auto)
    if args.stdout:
        sys.stdout.write(tables)
        return 0
    try:
        args.doc.write_text(splice(args.doc.read_text(encoding="utf-8"), tables), encoding="utf-8")
    except (OSError, ValueError) as err:
        print(f"sonarproc.studies.methods_table: error: {err}", file=sys.stderr)
        return 2
    print(f"wrote {args.doc}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

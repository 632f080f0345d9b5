"""Judge ``--auto`` on random scenes nobody tuned on: writes ``docs/auto-frozen.md``.

For each seed of a block, :func:`sonarsim.random_scenes.random_scenario` draws a scene
(a wall, a curve or a corner; a ring, a linear, a random or an all-pairs bistatic array;
range noise and spurious echoes), the scene is simulated, every candidate of ``--auto``
(:data:`sonarproc.auto.CANDIDATES`, at each of its settings) is run on the whole log and
judged by the truth (E1, the RMS error over the columns with points), and so is ``--auto`` (which
never sees the truth). The table lists, per seed, the scene's kind, the best model and
its E1, ``--auto``'s choice and its E1, and their ratio; the summary gives the fraction
of scenes within 1.25x the best model, the scenes where ``--auto`` is above 5 cm while
some model is below 3 cm, and the median ratio.

The evaluation seeds :data:`FROZEN_SEEDS` were fixed before any further change to
``--auto``'s rules, and are run once per change, at the end; ``--auto`` is developed on
:data:`DEVELOPMENT_SEEDS` (``--seeds dev``), never on the frozen block.

Usage::

    python tools/auto_frozen.py                 # the frozen block -> docs/auto-frozen.md
    python tools/auto_frozen.py --seeds dev     # the development seeds, printed only
    python tools/auto_frozen.py --seeds 0-49 --workers 2
    python tools/auto_frozen.py --best-from other.md   # --auto only; the best from a page

The best candidate does not depend on ``--auto``'s rules (every candidate is run on the
whole log at every setting): ``--best-from`` takes each seed's best model and its E1
from a page this tool wrote for the same seeds (another version's), and runs ``--auto``
alone, at a fraction of the cost.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: The evaluation block: fixed before any rule of ``--auto`` was changed; run once. (The
#: blocks 1000-1099 to 1500-1599 were each run once for earlier rules and are no longer
#: untouched.)
FROZEN_SEEDS = range(1600, 1700)
#: The seeds ``--auto`` is developed and checked on.
DEVELOPMENT_SEEDS = range(0, 200)
#: ``--auto`` counts as matching the best model within this factor.
WITHIN = 1.25
#: A scene counts as a failure when ``--auto`` is above the first (m) while a model is
#: below the second.
FAIL_ABOVE_M, FAIL_WHEN_BEST_BELOW_M = 0.05, 0.03


def judge_seed(seed: int, best: tuple[str, float] | None = None) -> dict[str, Any]:
    """Simulate one random scene and judge every candidate and ``--auto`` on it by the truth.

    ``best``: the seed's best model and its E1 (m), known already; then only ``--auto`` is run.
    """
    import yaml

    from sonarmorph_tools.auto_judge import auto_row
    from sonarproc.pipeline import load_log
    from sonarproc.simulate import simulate_to_log
    from sonarsim.random_scenes import random_scenario_dict

    scene = random_scenario_dict(seed)
    with tempfile.TemporaryDirectory() as tmp:
        yml = Path(tmp) / f"random-{seed}.yaml"
        yml.write_text(yaml.safe_dump(scene), encoding="utf-8")
        simulate_to_log(yml, Path(tmp) / "log.h5")
        log_ = load_log(Path(tmp) / "log.h5")
    row: dict[str, Any] = {
        "seed": seed, "kind": scene["description"], "readings": int(log_.readings.size),
        "sigma_cm": 100 * scene["imperfections"]["range_noise_sigma"],
    }  # fmt: skip
    try:
        judged = auto_row(log_) if best is None else _auto_only(log_, *best)
    except Exception as err:  # a failure is a row of the table, not the end of the block
        return {**row, "error": f"{type(err).__name__}: {err}"}
    best_e, auto_e = judged["best_error_m"], judged["auto_error_m"]
    if not (math.isfinite(best_e) and best_e >= 0):
        return {**row, "error": "no candidate left anything on the map"}
    auto_e = float(auto_e) if auto_e is not None and math.isfinite(auto_e) else math.inf
    return {
        **row, "best": judged["best"], "best_E1": best_e, "auto": judged["choice"],
        "auto_E1": auto_e, "ratio": auto_e / max(best_e, 1e-6), "auto_s": judged["auto_s"],
    }  # fmt: skip


def _auto_only(log_: Any, best: str, best_error_m: float) -> dict[str, Any]:
    """``--auto``'s pick and error on ``log_``, beside a best model known already."""
    import time

    from sonarmorph_tools.auto_judge import Judge
    from sonarproc.auto import run_auto
    from sonarproc.params import RunParams
    from sonarproc.pipeline.selection import select_beams

    base = RunParams()
    t0 = time.perf_counter()
    res, chosen, _ = run_auto(log_, base)
    wall = time.perf_counter() - t0
    auto_e, _ = Judge(log_, select_beams(log_, base)[0]).error(res.run)
    setting = "" if chosen.candidate.family == "surfaces" else f"@{chosen.setting:g}"
    return {
        "choice": f"{chosen.candidate.name}{setting}", "auto_error_m": auto_e, "best": best,
        "best_error_m": best_error_m, "auto_s": wall,
    }  # fmt: skip


def best_from(page: str) -> dict[int, tuple[str, float]]:
    """Each seed's best model and its E1 (m) from a page this tool wrote.

    Examples
    --------
    >>> row = "| 7 | wall / ring | 59 | 1.33 | median/spline@1.6 | 0.68 | x | 1.27 | 1.88 |"
    >>> {k: (m, round(e, 6)) for k, (m, e) in best_from(row).items()}
    {7: ('median/spline@1.6', 0.0068)}
    """
    out = {}
    for line in page.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 9 and cells[0].isdigit() and cells[5] not in ("—", ""):
            out[int(cells[0])] = (cells[4], float(cells[5]) / 100)
    return out


def _seeds(text: str) -> range:
    if text == "frozen":
        return FROZEN_SEEDS
    if text == "dev":
        return DEVELOPMENT_SEEDS
    lo, _, hi = text.partition("-")
    return range(int(lo), int(hi or lo) + 1)


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The block's summary: the share within :data:`WITHIN`, the failures, the median ratio."""
    judged = [r for r in rows if "ratio" in r]
    ratios = [r["ratio"] for r in judged]
    within = sum(q <= WITHIN for q in ratios)
    fails = [
        r["seed"] for r in judged
        if r["auto_E1"] > FAIL_ABOVE_M and r["best_E1"] < FAIL_WHEN_BEST_BELOW_M
    ]  # fmt: skip
    return {
        "scenes": len(rows), "judged": len(judged), "within": within,
        "within_share": within / max(len(judged), 1), "fails": fails,
        "median_ratio": statistics.median(ratios) if ratios else math.nan,
        "errors": [r["seed"] for r in rows if "error" in r],
    }  # fmt: skip


def table(rows: list[dict[str, Any]], seeds: range) -> str:
    """The Markdown page of a block."""
    s = summary(rows)
    lines = [
        "# `--auto` on random scenes nobody tuned on",
        "",
        "Generated by `python tools/auto_frozen.py` (do not edit). Seeds "
        f"{seeds.start}-{seeds.stop - 1} of `sonarsim.random_scenes.random_scenario`, fixed "
        "before any further change to `--auto`'s rules. Each scene is judged by "
        "the truth, which `--auto` never sees: E1 (cm), the RMS error of the profile over "
        "its columns with points. *best* is the best candidate at its best setting, "
        "each run on the whole log; *ratio* is `--auto`'s E1 over the best's.",
        "",
        f"- within {WITHIN}x the best model: {s['within']} of {s['judged']} scenes "
        f"({100 * s['within_share']:.1f} %)",
        f"- `--auto` above {100 * FAIL_ABOVE_M:g} cm where a model is below "
        f"{100 * FAIL_WHEN_BEST_BELOW_M:g} cm: {len(s['fails'])} scene(s)"
        + (f" (seeds {', '.join(map(str, s['fails']))})" if s["fails"] else ""),
        f"- median ratio: {s['median_ratio']:.3f}",
        f"- scenes not judged (nothing mapped, or a failure): {len(s['errors'])}",
        "",
        "| seed | scene (surface / array) | readings | sigma (cm) | best model | best E1 (cm) "
        "| `--auto` chose | auto E1 (cm) | ratio |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if "ratio" not in r:
            lines.append(
                f"| {r['seed']} | {r['kind']} | {r['readings']} | {r['sigma_cm']:.2f} | "
                f"{r.get('best', '—')} | — | {r.get('error', '—')} | — | — |"
            )
            continue
        lines.append(
            f"| {r['seed']} | {r['kind']} | {r['readings']} | {r['sigma_cm']:.2f} | "
            f"{r['best']} | {100 * r['best_E1']:.2f} | {r['auto']} | "
            f"{100 * r['auto_E1']:.2f} | {r['ratio']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Run a block of seeds; the frozen block writes ``docs/auto-frozen.md``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="frozen", help="frozen, dev, or LO-HI")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None, help="Markdown file to write")
    ap.add_argument(
        "--best-from", type=Path, default=None, metavar="PAGE",
        help="take each seed's best model from this page (written by this tool for the "
        "same seeds) and run --auto alone",
    )  # fmt: skip
    args = ap.parse_args(argv)
    seeds = _seeds(args.seeds)
    known = best_from(args.best_from.read_text(encoding="utf-8")) if args.best_from else {}
    if args.best_from and not set(seeds) <= set(known):
        missing = sorted(set(seeds) - set(known))
        print(f"auto_frozen: error: --best-from: no best model for seeds {missing[:5]}...",
              file=sys.stderr)  # fmt: skip
        return 2
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        rows = list(pool.map(judge_seed, seeds, [known.get(s) for s in seeds]))
    out = args.out
    if out is None and args.seeds == "frozen":
        out = ROOT / "docs" / "auto-frozen.md"
    page = table(rows, seeds)
    if out is not None:
        out.write_text(page, encoding="utf-8")
    s = summary(rows)
    print(
        f"{s['within']}/{s['judged']} within {WITHIN}x ({100 * s['within_share']:.1f} %), "
        f"fails {s['fails']}, median ratio {s['median_ratio']:.3f}, errors {s['errors']}",
        file=sys.stderr,
    )
    if out is None:
        sys.stdout.write(page)
    return 0


if __name__ == "__main__":
    sys.exit(main())

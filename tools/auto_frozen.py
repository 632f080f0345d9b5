"""Judge ``--auto`` on random scenes nobody tuned on: writes ``docs/auto-frozen.md``.

For each seed of a block, :func:`sonarsim.random_scenes.random_scenario` draws a scene
(a wall, a curve or a corner; a ring, a linear, a random or an all-pairs bistatic array;
range noise and spurious echoes), the scene is simulated, every model of ``--auto``'s
model space (:func:`sonarproc.auto.model_space`) is run on the whole log and judged by
the truth (E1, the RMS error over the columns with points), and so is ``--auto`` (which
never sees the truth). The table lists, per seed, the scene's kind, the best model and
its E1, ``--auto``'s choice and its E1, and their ratio; the summary gives the fraction
of scenes within 1.25x the best model, the scenes where ``--auto`` is above 5 cm while
some model is below 3 cm, and the median ratio.

The evaluation seeds :data:`FROZEN_SEEDS` were fixed before ``--auto``'s rules were
rebuilt on one principle, and are run once, at the end; ``--auto`` is developed on
:data:`DEVELOPMENT_SEEDS` (``--seeds dev``), never on the frozen block.

Usage::

    python tools/auto_frozen.py                 # the frozen block -> docs/auto-frozen.md
    python tools/auto_frozen.py --seeds dev     # the development seeds, printed only
    python tools/auto_frozen.py --seeds 0-49 --workers 2
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]

#: The evaluation block: fixed before any rule of ``--auto`` was changed; run once.
FROZEN_SEEDS = range(1000, 1200)
#: The seeds ``--auto`` is developed and checked on.
DEVELOPMENT_SEEDS = range(0, 200)
#: ``--auto`` counts as matching the best model within this factor.
WITHIN = 1.25
#: A scene counts as a failure when ``--auto`` is above the first (m) while a model is
#: below the second.
FAIL_ABOVE_M, FAIL_WHEN_BEST_BELOW_M = 0.05, 0.03


def judge_seed(seed: int) -> dict[str, Any]:
    """Simulate one random scene and judge every model and ``--auto`` on it by the truth."""
    import yaml

    from sonarproc.auto import run_auto
    from sonarproc.auto.select import model_runs
    from sonarproc.params import RunParams
    from sonarproc.pipeline import load_log
    from sonarproc.simulate import simulate_to_log
    from sonarsim.random_scenes import random_scenario_dict

    scene = random_scenario_dict(seed)
    with tempfile.TemporaryDirectory() as tmp:
        yml = Path(tmp) / f"random-{seed}.yaml"
        yml.write_text(yaml.safe_dump(scene), encoding="utf-8")
        simulate_to_log(yml, Path(tmp) / "log.h5")
        log_ = load_log(Path(tmp) / "log.h5")
    base = RunParams()
    row: dict[str, Any] = {
        "seed": seed, "kind": scene["description"], "readings": int(log_.readings.size),
        "sigma_cm": 100 * scene["imperfections"]["range_noise_sigma"],
    }  # fmt: skip
    errors = {
        label: r.metrics.E1_m
        for label, r in model_runs(log_, base).items()
        if r.metrics.E1_m is not None and math.isfinite(r.metrics.E1_m)
    }
    if not errors:
        return {**row, "error": "no model left anything on the map"}
    best = min(errors, key=lambda k: errors[k])
    t0 = time.perf_counter()
    try:
        res, chosen, choice = run_auto(log_, base)
    except Exception as err:  # a failure is a row of the table, not the end of the block
        return {**row, "best": best, "best_E1": errors[best], "error": f"--auto: {err}"}
    wall = time.perf_counter() - t0
    e1 = res.run.metrics.E1_m
    auto_e1 = float("inf") if e1 is None else float(e1)
    return {
        **row, "best": best, "best_E1": errors[best], "auto": choice.label(chosen),
        "auto_E1": auto_e1, "ratio": auto_e1 / max(errors[best], 1e-6), "auto_s": wall,
    }  # fmt: skip


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
        "before `--auto` was rebuilt on one principle and run once. Each scene is judged by "
        "the truth, which `--auto` never sees: E1 (cm), the RMS error of the profile over "
        "its columns with points. *best* is the best model of `--auto`'s model space, each "
        "run on the whole log; *ratio* is `--auto`'s E1 over the best's.",
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
    args = ap.parse_args(argv)
    seeds = _seeds(args.seeds)
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        rows = list(pool.map(judge_seed, seeds))
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

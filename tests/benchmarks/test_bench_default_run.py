"""Benchmark: the default ``sonarproc run`` on the 1-hour room log, and what its second core
gains.

The default run of a room (no option but the cell and the bbox) aligns its poses where
the echoes show drift, fits its surfaces, measures its truth-free quality and draws its
figures. Forked children work on the second core meanwhile: the figures (matplotlib's
import while the run loads and maps, the arc map while it fits, the others while it
measures), the align stage (while the log is mapped as read) and the held-out refit
(while it fits). Pinned to one core, no child is forked and every stage runs in turn.

Each run is a fresh interpreter timed from the outside; the default run, the same run on
one core, ``--figures none`` and the floor (start, import, read, one scatter of the arc
cells) take turns, best of three each, so that all see the same machine load. Printed:
the walls and their ratios (default / one core is the second core's gain).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from benchroom import FLOOR, ROOM, RUN, run_child, write_room_log

# The same wrapped run, pinned to one of this process's cores before anything is imported.
ONE_CORE = "import os\nos.sched_setaffinity(0, {min(os.sched_getaffinity(0))})\n" + RUN


def _run(script: str, log: Path, out: Path, figures: str = "png") -> tuple[float, dict[str, Any]]:
    args = ["-c", script, "run", str(log), "--out", str(out), "--cell", "0.01",
            "--bbox", f"0,{ROOM:g},0,{ROOM:g}", "--figures", figures, "--json"]  # fmt: skip
    out.mkdir(parents=True, exist_ok=True)
    wall, _, stdout, _ = run_child(args, out)
    return wall, json.loads(stdout)


def _content(doc: dict[str, Any]) -> dict[str, Any]:
    """report.json but for the times."""
    doc = dict(doc, metrics=dict(doc["metrics"]))
    doc.pop("timings_s")
    doc["metrics"].pop("t_cpu_s")
    return doc


@pytest.mark.benchmark
@pytest.mark.skipif(
    not hasattr(os, "sched_getaffinity") or len(os.sched_getaffinity(0)) < 2,
    reason="the second core's gain needs two cores",
)
def test_bench_default_run(tmp_path: Path) -> None:
    log = tmp_path / "hour.h5"
    n = write_room_log(log, 1.0)
    best: dict[str, float] = {k: np.inf for k in ("default", "one core", "none", "floor")}
    docs: dict[str, dict[str, Any]] = {}
    for _ in range(3):
        for kind, script, figures in [
            ("default", RUN, "png"), ("one core", ONE_CORE, "png"), ("none", RUN, "none"),
        ]:  # fmt: skip
            wall, doc = _run(script, log, tmp_path / kind.replace(" ", "-"), figures)
            best[kind] = min(best[kind], wall)
            docs[kind] = doc
        counts, grid = docs["default"]["counts"], docs["default"]["grid"]
        cells = int(grid["nx"]) * int(grid["ny"])
        fwall, _, _, _ = run_child(
            ["-c", FLOOR, str(log), str(counts["arc_cells"]), str(cells)], tmp_path
        )
        best["floor"] = min(best["floor"], fwall)
    # the children change when the work is done, not what it gives
    assert _content(docs["default"]) == _content(docs["one core"]) == _content(docs["none"])
    assert docs["default"]["fit"]["kind"] == "surfaces" and docs["default"]["fit"]["ok"]
    default, one, none, floor = (best[k] for k in ("default", "one core", "none", "floor"))
    print(f"\nthe default run on the 1-hour room log ({n} readings), best of 3 in turns:")
    print(
        f"  wall: default {default:.2f} s, on one core {one:.2f} s, --figures none "
        f"{none:.2f} s, floor {floor:.2f} s"
    )
    print(
        f"  one core / default = {one / default:.2f} (the second core's gain); "
        f"default / floor = {default / floor:.2f}; figures add {default - none:.2f} s"
    )
    print(
        "  stages (s): "
        + ", ".join(f"{k} {v:.3f}" for k, v in docs["default"]["timings_s"].items())
    )

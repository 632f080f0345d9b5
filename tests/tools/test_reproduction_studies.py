"""Tests for the own-echo and multi-surface studies of docs/reproduction.md."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sonarlog import read_log
from sonarmorph_tools.reproduce import main
from sonarmorph_tools.reproduction.multi_surface import (
    FIRST_ORDER,
    RingLogError,
    SurfaceRow,
    multi_surface_section,
    record_ring_log,
    world_truth,
)
from sonarmorph_tools.reproduction.outcome import Outcome
from sonarmorph_tools.reproduction.own_echo import (
    PAPER_TIMING,
    VariantRun,
    own_echo_section,
    run_own_echo,
    simulate_variant,
)
from sonarsim.shipped import shipped_dir

SCENARIOS = shipped_dir("scenarios")


def _variant(name: str, pairs: str, sensors: int, arcs: float, e: float) -> VariantRun:
    o = Outcome(e, 0.9, 10 * e, e, 0.01, int(arcs), True, 5.0)
    return VariantRun(name, pairs, sensors, o, 1000, arcs, 100 * arcs, 0.01, 1e-5 * arcs)


def _runs(own: tuple[float, ...], every: tuple[float, ...]) -> list[VariantRun]:
    out = []
    for t, a_own, a_all in zip(PAPER_TIMING, own, every, strict=True):
        out.append(_variant(t.scenario, "own", t.sensors, a_own, 0.2))
        out.append(_variant(t.scenario, "all", t.sensors, a_all, 0.9))
    return out


def test_paper_timing_transcribed() -> None:
    assert [(t.scenario, t.sensors, t.t_cpu_s) for t in PAPER_TIMING] == [
        ("fig10b", 100, 0.49),
        ("fig10c", 150, 0.73),
        ("fig12", 400, 0.51),
    ]


def test_own_echo_section_ratios_and_verdict() -> None:
    text = "\n".join(own_echo_section(_runs((30, 45, 120), (700, 1575, 11200))))
    assert "| Fig. 11a (fig10b) | 100 | 10000 | 0.49 | 4.90 | 49.0 |" in text
    # own arcs x1.50, all x2.25: slopes 1 and 2 against N, paper 0.98
    assert "| Fig. 11b (fig10c) | ratio | ×1.50 | ×2.25 | ×1.49 | ×1.50 | ×1.50 |" in text
    assert "| log-log slope against N | 1 | 2 | 0.98 | 1.00 | 1.00 |" in text
    assert "0.98 against N (0.94-1.03) and 0.49 against N²" in text
    # fixed share for t = a + b arcs to grow x1.49: (1.5-1.49)/0.5 = 2 %, (2.25-1.49)/1.25 = 61 %
    assert "own echoes 2 % / 2 %, every pair 61 % / 61 %" in text
    # e and E1 nearer with own echoes on all three figures, f_c a tie
    assert "machine) ×1.50 and ×2.25, the arc cells it draws ×1.50 and ×2.25." in text
    assert "own echoes come nearer on 6 and every pair on 0" in text
    assert "| 30 / 700 | 0.296 / 0.200 / 0.900 |" in text


def test_own_echo_section_without_every_scenario() -> None:
    text = "\n".join(own_echo_section(_runs((30, 45, 120), (700, 1575, 11200))[:2]))
    assert "(The verdict needs fig10b, fig10c and fig12.)" in text
    assert own_echo_section([]) == []


def test_simulate_variant_own_and_all(tmp_path: Path) -> None:
    for pairs in ("own", "all"):
        simulate_variant(SCENARIOS / "fig10b.yaml", pairs, tmp_path / f"{pairs}.h5")
    own = read_log(tmp_path / "own.h5").readings
    every = read_log(tmp_path / "all.h5").readings
    assert own.size > 0 and np.all(own["tx"] == own["rx"])
    assert every.size > 10 * own.size and np.any(every["tx"] != every["rx"])
    # own echoes are the all-pairs run's diagonal: the same sensors, seed and surface
    diag = every[every["tx"] == every["rx"]]
    assert sorted(diag["tx"].tolist()) == sorted(own["tx"].tolist())


def test_run_own_echo_one_draw(tmp_path: Path) -> None:
    runs = run_own_echo(SCENARIOS, tmp_path, cell=0.02, draws=(None,), repeats=1,
                        only=["fig10b"], reports=tmp_path / "rep")  # fmt: skip
    assert (tmp_path / "rep" / "fig10b-own" / "arcmap.png").stat().st_size > 0
    assert (tmp_path / "rep" / "fig10b-all" / "report.json").is_file()
    assert [(r.scenario, r.pairs) for r in runs] == [("fig10b", "own"), ("fig10b", "all")]
    own, every = runs
    assert own.arcs == own.outcome.readings < every.arcs == every.outcome.readings
    assert 0 < own.map_cells < every.map_cells and own.arc_cells < every.arc_cells
    with pytest.raises(ValueError, match="draws must hold None"):
        run_own_echo(SCENARIOS, tmp_path, cell=0.02, draws=(1,), repeats=1, only=["fig10b"])


def test_multi_surface_section() -> None:
    rows = [
        SurfaceRow("corridor-l", "scenario, seed 31", 534, 3024, 10, "surfaces", 0.0127, 0.99, 1.0),
        SurfaceRow("ring log", "sonard", 726, 1781, 39, "surfaces", 0.316, 0.73, 2.4),
        SurfaceRow("empty", "scenario", 0, 10, 0, "surfaces", None, None, 0.1),
    ]
    assert [r.met for r in rows] == [True, False, False]
    text = "\n".join(multi_surface_section(rows, [FIRST_ORDER, "e", FIRST_ORDER]))
    assert "`max_order: 1`: first echoes only, no multiple reflections" in text
    assert "precision <= 3 cm and completeness >= 0.8; met by 1 of 3" in text
    assert (
        "| `corridor-l` | scenario, seed 31 | first echo, max_order 1 | 534 / 3024 | surfaces "
        "| 10 | 1.27 | 0.990 | yes | 1.00 |" in text
    )
    assert "| ring log | sonard | e | 726 / 1781 | surfaces | 39 | 31.60 | 0.730 | no |" in text
    assert (
        "| `empty` | scenario | first echo, max_order 1 | 0 / 10 | surfaces | 0 | — | — | no |"
        in text
    )
    assert multi_surface_section([], []) == []
    other = "\n".join(multi_surface_section(rows[:1], ["every echo, max_order 2"]))
    assert "max_order: 1" not in other and "the echo models of the column *echoes*" in other


def test_world_truth_holds_every_surface() -> None:
    truth = world_truth("lab")
    parts = np.flatnonzero(np.isnan(truth[:, 0]))
    assert parts.size == 1  # the cardboard, then the room's walls
    room = truth[parts[0] + 1 :]
    assert room[:, 0].min() == pytest.approx(-3.0) and room[:, 1].max() == pytest.approx(3.5)


def test_record_ring_log_reports_sonard_failure(tmp_path: Path) -> None:
    with pytest.raises(RingLogError, match="sonard failed with exit code"):
        record_ring_log(tmp_path / "missing-dir" / "ring.h5")


def test_main_only_without_ring_log(tmp_path: Path) -> None:
    out = tmp_path / "r.md"
    assert main(["--out", str(out), "--only", "fig10b", "--only", "corridor-l", "--quiet"]) == 0
    text = out.read_text(encoding="utf-8")
    assert "| fig10b (Fig. 11a/c) | `thinning:2` | 6 |" in text
    assert "corridor-l (" not in text  # the multi-surface scenes have their own table
    assert "| `corridor-l` | scenario, seed 31 |" in text and "| ring log |" not in text
    assert "| Fig. 11a (fig10b) | `thinning:2`, 6 |" in text
    assert main(["--out", str(out), "--only", "nope"]) == 2

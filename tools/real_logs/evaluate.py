"""Run ``sonarproc run`` with default options on every real log and write docs/real-logs.md.

The shipped real logs live in ``tests/data/real/<name>/`` (a ``readings.csv`` and a
``sensors.yaml`` beside a ``PROVENANCE.md``). Logs that may not be shipped are given by
path; their figures and numbers go into the same page with the source the user names::

    python tools/real_logs/evaluate.py                       # the shipped logs
    python tools/real_logs/evaluate.py --log run.bag --robot pioneer3-dx \\
        --source "https://example.org/run.bag (licence ...)"

For every log the page shows: readings (total, with an echo), robot, time and travel,
the run's wall time, the surfaces found (count, longest, how many reach 2 m, the fewest
distinct poses any surface rests on), the fraction of the readings that echo from a
surface within 5 cm, and the report's own ``quality`` figures when the run writes them;
then the odometry correction :func:`sonarproc.align.align_poses` finds (how far the
corrected path is from the raw one). A figure per log shows the raw and corrected paths,
the readings' line-of-sight echo points and the surfaces.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from unexplained import CATEGORIES, classify

ROOT = Path(__file__).resolve().parents[2]
SHIPPED = ROOT / "tests" / "data" / "real"
DOC = ROOT / "docs" / "real-logs.md"
FIGURES = ROOT / "docs" / "real-logs"
#: A reading is explained when a surface predicts its range within this (the issue's 5 cm).
EXPLAINED_TOL = 0.05


@dataclass
class RealLog:
    """One log to evaluate."""

    name: str
    path: Path
    sensors: Path | None = None
    robot: str | None = None
    source: str = ""
    shipped: bool = False


@dataclass
class Outcome:
    """What one run gave."""

    log: RealLog
    report: dict[str, Any]
    wall_s: float
    figures: dict[str, Any] = field(default_factory=dict)


def shipped_logs() -> list[RealLog]:
    """Every folder of tests/data/real with a readings CSV and a sensors YAML."""
    out = []
    for folder in sorted(p for p in SHIPPED.iterdir() if p.is_dir()):
        csv_path, yaml_path = folder / "readings.csv", folder / "sensors.yaml"
        if csv_path.is_file() and yaml_path.is_file():
            prov = folder / "PROVENANCE.md"
            out.append(RealLog(folder.name, csv_path, yaml_path,
                               source=f"tests/data/real/{folder.name}/"
                               + ("PROVENANCE.md" if prov.is_file() else ""),
                               shipped=True))  # fmt: skip
    return out


def sonarproc_exe() -> str:
    """The ``sonarproc`` console script of this interpreter's environment."""
    local = Path(sys.executable).parent / "sonarproc"
    found = str(local) if local.is_file() else shutil.which("sonarproc")
    if not found:
        raise SystemExit("evaluate: error: sonarproc is not installed in this environment")
    return found


def run_log(log: RealLog, out: Path) -> Outcome:
    """``sonarproc run`` with default options; its report and wall time."""
    cmd = [sonarproc_exe(), "run", str(log.path), "--out", str(out), "--json"]
    if log.sensors is not None:
        cmd += ["--sensors", str(log.sensors)]
    if log.robot is not None:
        cmd += ["--robot", log.robot]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"evaluate: error: {log.name}: sonarproc run failed: "
                         f"{proc.stderr.strip().splitlines()[-1:]}")  # fmt: skip
    return Outcome(log, json.loads(proc.stdout), wall)


def read_surfaces(path: Path) -> list[np.ndarray]:
    """The polylines of surfaces.csv (point features dropped)."""
    polys: dict[int, list[tuple[float, float]]] = {}
    with path.open(newline="") as f:
        for row in csv.DictReader(f):
            polys.setdefault(int(row["surface"]), []).append((float(row["x"]), float(row["y"])))
    return [np.asarray(v) for _, v in sorted(polys.items()) if len(v) >= 2]


def own_echo_geometry(readings: np.ndarray, lg: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """The own-echo readings of ``readings`` with an echo in the sensors' range, as
    :class:`sonarproc.surfaces.EchoGeometry`; also which readings those are (the
    own-echo mask over ``readings`` and, over those, the in-range mask)."""
    from sonarproc.surfaces import EchoGeometry

    r = readings
    ok = ((r["flags"] & 1) == 0) & (r["tx"] == r["rx"]) & np.isfinite(r["tof"])
    tp = lg.transducer_poses(r[ok])
    path = lg.path_lengths(r[ok])
    rng = 0.5 * path
    keep = (rng >= tp.min_range) & (rng <= tp.max_range)
    geo = EchoGeometry.from_beams(tp.tx_xy[keep], tp.tx_heading[keep], tp.rx_xy[keep],
                                  tp.rx_heading[keep], path[keep],
                                  tx_half_beamwidth=tp.tx_half_beamwidth[keep],
                                  rx_half_beamwidth=tp.rx_half_beamwidth[keep])  # fmt: skip
    return geo, ok, keep


def measure(outcome: Outcome, out: Path) -> None:
    """Truth-free figures from the log and the run's surfaces (into ``outcome.figures``)."""
    from sonarproc.align import align_poses
    from sonarproc.pipeline.run import load_log
    from sonarproc.surfaces import echo_points

    lg = load_log(outcome.log.path, sensors=outcome.log.sensors, robot=outcome.log.robot)
    r = lg.readings[np.argsort(lg.readings["t"], kind="stable")]
    fig = outcome.figures
    fig["robot"] = str(lg.attrs.get("robot", ""))
    fig["duration_s"] = float(r["t"][-1] - r["t"][0]) if r.size else 0.0
    fig["travel_m"] = float(np.sum(np.hypot(np.diff(r["x"]), np.diff(r["y"]))))
    geo, ok, keep = own_echo_geometry(r, lg)
    polys = read_surfaces(out / "surfaces.csv") if (out / "surfaces.csv").is_file() else []
    per = echo_points(polys, [False] * len(polys), geo, tol=EXPLAINED_TOL) if polys else []
    pose = np.column_stack((r["x"], r["y"], r["theta"]))[ok][keep]
    fig["echoes"] = int(geo.size)
    fig["explained"] = sum(int(s.readings.size) for s in per) / max(geo.size, 1)
    poses = [int(np.unique(pose[s.readings], axis=0).shape[0]) for s in per]
    fig["fewest_poses"] = min(poses) if poses else 0
    lengths = [float(np.sum(np.hypot(*np.diff(p, axis=0).T))) for p in polys]
    fig["lengths"] = lengths
    fig["los"] = geo.xy + geo.range_m[:, None] * np.column_stack(
        (np.cos(geo.heading), np.sin(geo.heading)))  # fmt: skip
    fig["polys"] = polys
    if (out / "surfaces.csv").is_file():
        fig["why"] = classify(outcome.log.path, outcome.log.sensors, outcome.log.robot,
                              out / "surfaces.csv")  # fmt: skip
    t0 = time.perf_counter()
    a = align_poses(lg.readings, lg.sensors, speed_of_sound=lg.speed_of_sound)
    fig["align_s"] = time.perf_counter() - t0
    fig["alignment"] = a
    order = np.argsort(lg.readings["t"], kind="stable")
    fig["raw_xy"] = np.column_stack((lg.readings["x"], lg.readings["y"]))[order]
    fig["aligned_xy"] = np.column_stack((a.x, a.y))[order]


def draw(outcome: Outcome, png: Path) -> None:
    """Raw and corrected path, line-of-sight echo points, surfaces (matplotlib, Agg)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    f = outcome.figures
    fig = Figure(figsize=(8.0, 6.0), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    los = f["los"]
    ax.scatter(los[:, 0], los[:, 1], s=1.5, c="0.65", lw=0, label="echo points (line of sight)")
    for i, p in enumerate(f["polys"]):
        ax.plot(p[:, 0], p[:, 1], lw=2.0, color=f"C{i % 10}",
                label="surfaces" if i == 0 else None)  # fmt: skip
    raw, cor = f["raw_xy"], f["aligned_xy"]
    ax.plot(raw[:, 0], raw[:, 1], "k--", lw=1.0, label="raw path (odometry)")
    a = f["alignment"]
    label = "corrected path" + (" (= raw: correction refused)" if a.reason else "")
    ax.plot(cor[:, 0], cor[:, 1], color="C3", lw=1.0, label=label)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{outcome.log.name}: {len(f['polys'])} surfaces")
    ax.legend(loc="best", fontsize=7, markerscale=4)
    png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(png, dpi=110)


def _quality(report: dict[str, Any], key: str) -> str:
    """One figure of the report's truth-free ``quality`` block, as text."""
    q = report.get("quality")
    if not isinstance(q, dict):
        return "not in this version's report"
    value = q.get(key)
    if value is None:
        return f"none ({q.get('reason')})"
    return f"{100 * value:.1f} cm" if key.endswith("_m") else f"{value:.2f}"


def _surfaces_explained(report: dict[str, Any]) -> str:
    """How many surfaces the map explains at least 0.7 of the readings they echo."""
    q = report.get("quality")
    if not isinstance(q, dict):
        return "not in this version's report"
    per = [s for s in q.get("surfaces", []) if s.get("readings")]
    good = sum(1 for s in per if (s.get("explained_fraction") or 0.0) >= 0.7)
    return f"{good} of {len(per)}"


def _alignment(report: dict[str, Any]) -> str:
    al = report.get("alignment")
    if not isinstance(al, dict):
        return "not tried (--no-align, or a report before drift correction)"
    if al.get("applied"):
        return f"applied: up to {al['max_shift_m']:.3f} m, mean {al['mean_shift_m']:.3f} m"
    return f"not applied: {al.get('reason')}"


#: The columns of the rows that sort the mapped readings (tools/real_logs/unexplained.py).
WHY_ROW = ("count: explained / mispredicted / beyond a mapped surface / at a mapped surface "
           "off its specular point / at a reported point / nothing mapped")  # fmt: skip


def _why(o: Outcome, group: str) -> str:
    """One sensor group's sorted readings, as text (see :data:`WHY_ROW`)."""
    why = o.figures.get("why")
    if not why or group not in why:
        return "no surfaces"
    w = why[group]
    return f"{w['readings']:.0f}: " + " / ".join(f"{w[c]:.2f}" for c in CATEGORIES)


def _why_text(o: Outcome) -> list[str]:
    """A paragraph on where the unexplained readings come from (from the sorted rows)."""
    why = o.figures.get("why")
    if not why:
        return []
    a, groups = why["all"], [g for g in ("side", "oblique", "front") if why[g]["readings"]]
    share = ", ".join(f"{g} {why[g]['readings'] / a['readings']:.0%} (explained "
                      f"{why[g]['explained']:.0%})" for g in groups)  # fmt: skip
    return [
        f"Of the {a['readings']:.0f} readings the run mapped, the map's specular first echo "
        f"explains {a['explained']:.0%}. By sensor direction: {share}. Of all of them, "
        f"{a['beyond_a_surface']:.0%} reach beyond a mapped surface that crosses their beam "
        f"without facing them, {a['at_a_surface']:.0%} end on a mapped surface away from "
        f"its specular point, {a['at_a_point']:.0%} at a reported corner or edge, and "
        f"{a['nothing_mapped']:.0%} where nothing is mapped; {a['mispredicted']:.0%} are "
        "predicted more than 5 cm off.",
        "",
    ]


def table(outcomes: list[Outcome]) -> list[str]:
    """The generated table, one column per log."""
    rows: list[tuple[str, list[str]]] = []

    def row(label: str, values: list[str]) -> None:
        rows.append((label, values))

    def each(fn: Any) -> list[str]:
        return [str(fn(o)) for o in outcomes]

    row("source", each(lambda o: o.log.source or str(o.log.path)))
    row("robot", each(lambda o: o.figures["robot"]))
    row("readings (with an echo)", each(lambda o: f"{o.report['counts']['readings_total']} "
                                        f"({o.report['counts']['readings_used']})"))  # fmt: skip
    row("time, travel", each(lambda o: f"{o.figures['duration_s']:.0f} s, "
                                       f"{o.figures['travel_m']:.1f} m"))  # fmt: skip

    def per_10k(o: Outcome) -> str:
        return f"{o.wall_s:.1f} s ({o.wall_s * 1e4 / o.report['counts']['readings_total']:.1f} s)"

    row("`sonarproc run` wall (per 10 000 readings)", each(per_10k))
    row("`sonarproc run` CPU, reading to fitting (`t_cpu_s`)", each(
        lambda o: f"{float(o.report['metrics'].get('t_cpu_s', float('nan'))):.1f} s"))  # fmt: skip
    row("surfaces", each(lambda o: len(o.report.get("surfaces", []))))
    row("longest surface", each(lambda o: f"{max(o.figures['lengths'], default=0.0):.2f} m"))
    row("surfaces of 2 m or more", each(lambda o: sum(x >= 2.0 for x in o.figures["lengths"])))
    row("fewest distinct poses a surface's echoes come from", each(
        lambda o: o.figures["fewest_poses"]))  # fmt: skip
    row("readings explained within 5 cm (echo points, in sample)", each(
        lambda o: f"{o.figures['explained']:.2f}"))  # fmt: skip
    row("quality: readings explained within 5 cm", each(
        lambda o: _quality(o.report, "explained_fraction")))  # fmt: skip
    row("quality: surfaces explaining 0.7 of their readings", each(
        lambda o: _surfaces_explained(o.report)))  # fmt: skip
    row("quality: held-out range residual, median", each(
        lambda o: _quality(o.report, "heldout_residual_median_m")))  # fmt: skip
    row("quality: held-out range residual, 90th percentile", each(
        lambda o: _quality(o.report, "heldout_residual_p90_m")))  # fmt: skip
    for group in ("all", "side", "oblique", "front"):
        row(f"mapped readings, {group} sensors: {WHY_ROW}", each(lambda o, g=group: _why(o, g)))
    row("odometry correction by `sonarproc run`", each(lambda o: _alignment(o.report)))
    row("odometry correction found: max / mean path difference", each(
        lambda o: f"{o.figures['alignment'].path_difference_max_m:.3f} m / "
                  f"{o.figures['alignment'].path_difference_mean_m:.3f} m"))  # fmt: skip
    row("odometry calibration found: scale, heading per 10 m", each(
        lambda o: f"{o.figures['alignment'].calibration[0]:+.3f}, "
                  f"{math.degrees(o.figures['alignment'].calibration[1]) * 10:+.2f}°"))  # fmt: skip
    row("alignment time", each(lambda o: f"{o.figures['align_s']:.2f} s"))
    head = "| | " + " | ".join(o.log.name for o in outcomes) + " |"
    sep = "|---|" + "---|" * len(outcomes)
    return [head, sep] + [f"| {label} | " + " | ".join(v) + " |" for label, v in rows]


def public_logs_text() -> list[str]:
    """The public logs that may not be shipped (tools/real_logs/unshipped.py), for the page."""
    from unshipped import PUBLIC_LOGS

    lines = ["Public logs that may not be shipped are recorded in",
             "`tools/real_logs/unshipped.py` (source, commit, SHA-256, robot); fetch one",
             "and run `python tools/real_logs/unshipped.py NAME PATH`. Their figures",
             "appear below only where their terms allow it.", ""]  # fmt: skip
    for lg in PUBLIC_LOGS:
        lines += [f"- `{lg.name}`: <{lg.url}>, {lg.licence}; robot `{lg.robot}`. "
                  f"{lg.recording[0].upper()}{lg.recording[1:]}."]  # fmt: skip
    return [*lines, ""]


def write_doc(outcomes: list[Outcome]) -> None:
    """docs/real-logs.md: the test set, the table, a figure per log."""
    lines = [
        "# Real logs",
        "",
        "<!-- generated by tools/real_logs/evaluate.py; edit that script, not this page -->",
        "",
        "Real recordings differ from the simulated scenarios: they are sparse (a sonar fires",
        "every 40–200 ms while the robot moves several centimetres), their odometry drifts,",
        "and nobody measured their rooms, so a map is judged from the readings alone.",
        "",
        "Every log here is run with `sonarproc run LOG` and default options (shipped logs",
        "as `readings.csv --sensors sensors.yaml`). The figures below are computed by",
        "`tools/real_logs/evaluate.py` from the run's outputs and the log:",
        "",
        "- *readings explained within 5 cm (echo points)*: the fraction of the readings with",
        "  an echo whose range a reported surface predicts within 5 cm (specular first echo,",
        "  `sonarproc.surfaces.echo_points`, in sample);",
        "- *quality*: the run's own truth-free figures (report.json `quality`, every run",
        "  writes them): the readings the map explains within 5 cm by the first-echo model",
        "  of `--auto` (overall, and per surface), and the held-out range residual (one",
        "  firing in ten left out, the map refitted without them, their ranges predicted);",
        "- *fewest distinct poses*: of all reported surfaces, the fewest distinct robot poses",
        "  its explaining readings were taken from (1 means a surface rests on one pose);",
        "- *odometry correction*: what `sonarproc run` decided (report.json `alignment`: the",
        "  correction `sonarproc.align.align_poses` finds is applied only where the echoes",
        "  agree significantly better with it); the figure shows both paths;",
        "- *mapped readings* (`tools/real_logs/unexplained.py`): every reading the run",
        "  mapped, sorted by what its map says of it, for all sensors and by direction",
        "  (*side*: 60° or more off the robot's heading, *oblique*: 20–60°, *front*: less",
        "  than 20°): *explained* (the specular first echo within 5 cm, as the quality",
        "  figure), *mispredicted* (a specular echo predicted, more than 5 cm off), *beyond",
        "  a mapped surface* (no mapped surface faces the sensor within its beam, yet one",
        "  crosses the beam nearer than the range: a wall seen at an incidence beyond the",
        "  half beam width sends its echo away, and the sonar hears something further: a",
        "  gap in the wall such as a doorway or recess, a door jamb, or a multipath echo),",
        "  *at a mapped surface off its specular point* (a mapped surface crosses the beam",
        "  at the range: a diffuse echo, or one from a feature on the wall), *at a reported",
        "  point* (a corner or edge the run reported, which the quality figure's specular",
        "  model does not predict from), *nothing mapped* (in the beam up to the range).",
        "",
        "Held aside: the RoboND log (`robond`) was never used to choose any parameter of",
        "the processing or of the odometry correction, which were set from physical",
        "arguments and simulated logs only; it was used only to choose the order of its",
        "sonar columns (see its PROVENANCE.md).",
        "",
        "The odometry correction's accuracy where the truth is known (simulated logs with",
        "injected drift: pose error removed, surface precision with and without drift and",
        "after the correction) is printed by `python tools/real_logs/drift_study.py",
        "--work DIR`.",
        "",
        "Times are those of the machine that generated this page (a shared one: compare",
        "them with `./scripts/bench`, not across pages).",
        "",
        "Add a log you may not ship: `python tools/real_logs/evaluate.py --log PATH",
        "[--sensors YAML | --robot PRESET] --source TEXT` (it joins the shipped ones).",
        "",
        *public_logs_text(),
        *table(outcomes),
        "",
    ]
    for o in outcomes:
        lines += [f"## {o.log.name}", "", f"Source: {o.log.source or o.log.path}", "",
                  *_why_text(o), f"![{o.log.name}](real-logs/{o.log.name}.png)", ""]  # fmt: skip
    DOC.write_text("\n".join(lines))


def main(argv: list[str] | None = None) -> int:
    """Evaluate the shipped real logs plus any given with ``--log``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path, action="append", default=[],
                    help="another log (any format sonarproc run reads)")  # fmt: skip
    ap.add_argument("--sensors", type=Path, help="sensors YAML for the --log logs")
    ap.add_argument("--robot", help="robot preset for the --log logs (bags, Player logs)")
    ap.add_argument("--source", action="append", default=[],
                    help="where each --log comes from and its licence, in order")  # fmt: skip
    ap.add_argument("--work", type=Path, default=Path("real-logs-work"),
                    help="folder for the run reports (default: ./real-logs-work)")  # fmt: skip
    args = ap.parse_args(argv)
    logs = shipped_logs()
    for i, p in enumerate(args.log):
        if not p.exists():
            print(f"evaluate: error: --log {p}: no such file", file=sys.stderr)
            return 2
        src = args.source[i] if i < len(args.source) else str(p)
        logs.append(RealLog(p.stem, p, args.sensors, args.robot, src))
    outcomes = []
    for lg in logs:
        out = args.work / lg.name
        o = run_log(lg, out)
        measure(o, out)
        draw(o, FIGURES / f"{lg.name}.png")
        outcomes.append(o)
        print(f"{lg.name}: {len(o.report.get('surfaces', []))} surfaces, {o.wall_s:.1f} s")
    write_doc(outcomes)
    print(f"wrote {DOC.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Odometry drift on simulated logs: pose error and surface precision with and without it.

For each (scene, seed): a shipped scenario whose closed route is driven three times is
simulated; drift (2 % of the distance driven, 2 degrees of heading per 10 m, signs from
the seed) is injected into its exact poses; :func:`sonarproc.align.align_poses` corrects
them. Three logs are written (true poses, drifted, aligned) and each is run with
``sonarproc run`` and default options against the scene's truth. Prints a Markdown table:
RMS pose error, the share of it the alignment removes, and the run's surface precision
and completeness for each log::

    python tools/real_logs/drift_study.py --work /tmp/drift-study
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "support"))

from drift import drifted_readings, looped_scenario, pose_error_rms  # noqa: E402

from sonarproc.align import align_readings  # noqa: E402
from sonarproc.simulate import write_result  # noqa: E402

#: (scene, seed): room-box was used while developing the alignment, hall-pillar was not.
CASES = (("room-box", 0), ("room-box", 1), ("hall-pillar", 2))


def run(log: Path, out: Path) -> dict[str, float]:
    """Surface precision and completeness of a default ``sonarproc run``."""
    exe = Path(sys.executable).parent / "sonarproc"
    proc = subprocess.run([str(exe), "run", str(log), "--out", str(out), "--json"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    metrics = json.loads(proc.stdout)["metrics"]
    return {k: float(metrics.get(k, float("nan"))) for k in ("precision_m", "completeness")}


def main(argv: list[str] | None = None) -> int:
    """Simulate, drift, align, run; print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True, help="folder for the logs and runs")
    ap.add_argument("--loops", type=int, default=3, help="times each route is driven")
    args = ap.parse_args(argv)
    args.work.mkdir(parents=True, exist_ok=True)
    print("| scene, seed | pose error RMS: drifted → aligned (removed) | precision: true poses"
          " / drifted / aligned | completeness: true / drifted / aligned |")  # fmt: skip
    print("|---|---|---|---|")
    for scene, seed in CASES:
        res = looped_scenario(scene, args.loops)
        truth = res.readings
        drifted = drifted_readings(truth, seed=seed)
        aligned, a = align_readings(drifted, res.sensors, speed_of_sound=res.speed_of_sound)
        e0 = pose_error_rms(truth, drifted["x"], drifted["y"])
        e1 = pose_error_rms(truth, aligned["x"], aligned["y"])
        figs = {}
        for label, rows in (("true", truth), ("drifted", drifted), ("aligned", aligned)):
            log = args.work / f"{scene}-{seed}-{label}.h5"
            log.unlink(missing_ok=True)
            write_result(dataclasses.replace(res, readings=rows), log, robot=f"sonarsim:{scene}")
            figs[label] = run(log, args.work / f"{scene}-{seed}-{label}")
        p = " / ".join(f"{100 * figs[k]['precision_m']:.2f} cm" for k in figs)
        c = " / ".join(f"{figs[k]['completeness']:.2f}" for k in figs)
        print(f"| {scene}, {seed} | {100 * e0:.1f} cm → {100 * e1:.1f} cm "
              f"({1 - e1 / e0:.0%}) | {p} | {c} |", flush=True)  # fmt: skip
        if a.reason:
            print(f"|  | alignment refused: {a.reason} | | |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

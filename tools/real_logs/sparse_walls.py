"""Whole walls from sparse, drifting logs: how many surfaces each true wall comes out as.

For each sparse scene (``tests/data/scenarios/sparse10-*.yaml``: a Pioneer front ring, a
scan every few centimetres, transducer physics) the scenario is simulated, odometry drift
is injected into its exact poses (2 % of the distance driven, 2 degrees of heading per
10 m, signs from the scenario's seed; ``--no-drift`` keeps the true poses) and
``sonarproc run`` maps it with default options. Against the scene's walls (the straight
segments of its world's polylines):

- a *long wall* is a wall of at least 2 m whose readings saw at least 2 m of it: its
  *seen length* joins the specular feet on it (true poses: the foot of the perpendicular
  from the sensor lies inside the beam and on the wall, and the measured range is within
  5 cm of the perpendicular distance) that lie at most 0.5 m apart;
- a surface *covers* a wall where at least half of its length lies within 10 cm of it;
  per long wall: how many surfaces cover it (the target is 1), and the share of its seen
  length the best single surface covers (within 10 cm). The wall is taken where the
  run's poses put it (each foot moved with its reading's pose error: drift the run did
  not remove displaces a wall but does not break it, and this counts breaks);
- an *opening* is a gap of 0.5-2.5 m between the ends of two collinear walls (a doorway,
  a junction, a recess); it is *bridged* when surfaces within 5 cm of the gap's line
  cover a third of its interior (10 cm in from either end);
- *one-pose surfaces*: surfaces whose echoes (readings within 5 cm of the range they
  predict) come from one robot pose only (poses as the run corrected them).

Also the run's precision and completeness against the truth. Prints a Markdown table::

    python tools/real_logs/sparse_walls.py --work /tmp/sparse-walls [--scene NAME ...]
        [--held-out] [--no-drift]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import yaml

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "support"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from drift import drifted_readings  # noqa: E402
from evaluate import EXPLAINED_TOL, own_echo_geometry, read_surfaces  # noqa: E402

FloatArray = npt.NDArray[np.float64]
SCENES = ROOT / "tests" / "data" / "scenarios"

#: Scenes used while developing the surface rules.
SEEN = ("sparse10-door-corridor", "sparse10-junction", "sparse10-hall-loop",
        "sparse10-l-corridor", "sparse10-return-corridor", "sparse10-heldout-cross",
        "sparse10-heldout-office", "sparse10-heldout-dogleg", "sparse11-heldout-tee",
        "sparse11-heldout-room-door", "sparse11-heldout-wide-cross", "sparse12-heldout-lab",
        "sparse12-heldout-side-rooms", "sparse12-heldout-alcove-hall",
        "sparse13-heldout-obtuse-room", "sparse13-heldout-alcove-corridor",
        "sparse13-heldout-l-doors", "sparse14-heldout-storeroom", "sparse14-heldout-lobby",
        "sparse14-heldout-zigzag-corridor", "sparse15-heldout-niches",
        "sparse15-heldout-bay-office", "sparse15-heldout-dead-ends",
        "sparse16-heldout-bent-corridor", "sparse16-heldout-pillar-hall",
        "sparse16-heldout-cluttered-office", "sparse17-heldout-workshop",
        "sparse17-heldout-branch-corridor", "sparse17-heldout-curved-lounge")  # fmt: skip
#: Scenes held out from all tuning, run once after the last rule change.
HELD_OUT = ("sparse18-heldout-copy-room", "sparse18-heldout-jog-corridor",
            "sparse18-heldout-slanted-store")  # fmt: skip

LONG_WALL_M = 2.0
COVER_TOL_M = 0.10
BIN_M = 0.05
FOOT_TOL_M = 0.05
FOOT_GAP_M = 0.5
GAP_MIN_M, GAP_MAX_M = 0.5, 2.5
BRIDGE_TOL_M = 0.05


def walls_of(data: dict[str, Any]) -> list[tuple[FloatArray, FloatArray]]:
    """The straight segments (start, end) of a scenario's inline world polylines."""
    out = []
    for s in data["world"]["surfaces"]:
        if s.get("type") != "polyline":
            continue
        p = np.asarray(s["points"], dtype=np.float64)
        if s.get("closed"):
            p = np.vstack((p, p[:1]))
        out += [(p[i], p[i + 1]) for i in range(len(p) - 1)]
    return out


def _frame(a: FloatArray, b: FloatArray, pts: FloatArray) -> tuple[FloatArray, FloatArray, float]:
    """Along (from a) and across distances of ``pts`` in the frame of segment a-b."""
    length = float(np.hypot(*(b - a)))
    u = (b - a) / length
    d = pts - a
    return d @ u, d @ np.array([-u[1], u[0]]), length


def _resample(poly: FloatArray, step: float = 0.01) -> FloatArray:
    seg = np.hypot(*np.diff(poly, axis=0).T)
    s = np.concatenate(([0.0], np.cumsum(seg)))
    if s[-1] <= 0:
        return poly[:1]
    t = np.linspace(0.0, s[-1], max(int(s[-1] / step) + 1, 2))
    return np.column_stack((np.interp(t, s, poly[:, 0]), np.interp(t, s, poly[:, 1])))


def beams(readings: np.ndarray, sensors: np.ndarray, c: float,
          used: np.ndarray) -> tuple[FloatArray, ...]:  # fmt: skip
    """Per echo (true poses): sensor position, heading, half beam, range, and the rigid
    motion (shift, turn) from its true pose to the pose the run ``used``."""
    ok = ((readings["flags"] & 1) == 0) & (readings["tx"] == readings["rx"])
    r, u = readings[ok], used[ok]
    s = sensors[np.searchsorted(sensors["id"], r["tx"])]
    ct, st = np.cos(r["turret"]), np.sin(r["turret"])
    xy = np.column_stack((r["x"] + ct * s["x"] - st * s["y"], r["y"] + st * s["x"] + ct * s["y"]))
    turn = np.angle(np.exp(1j * (u["theta"] - r["theta"])))
    return (
        xy,
        r["turret"] + s["heading"],
        s["half_beamwidth"],
        0.5 * c * r["tof"],
        np.column_stack((r["x"], r["y"])),
        np.column_stack((u["x"], u["y"])),
        turn,
    )


def seen_feet(a: FloatArray, b: FloatArray,
              beam: tuple[FloatArray, ...]) -> tuple[FloatArray, FloatArray]:  # fmt: skip
    """The wall's seen stretches, densified (1 cm): position along it, and where the run's
    poses put that point (the specular feet moved with their readings' pose errors)."""
    xy, heading, half, rng, true_xy, used_xy, turn = beam
    along, across, length = _frame(a, b, xy)
    # the perpendicular from the sensor to the wall: its direction, and its foot
    u = (b - a) / length
    to_wall = -np.sign(across)[:, None] * np.array([-u[1], u[0]])
    normal = np.arctan2(to_wall[:, 1], to_wall[:, 0])
    off = np.abs(np.angle(np.exp(1j * (normal - heading))))
    hit = (off <= half) & (np.abs(np.abs(across) - rng) <= FOOT_TOL_M)
    hit = np.flatnonzero(hit & (along >= 0) & (along <= length))
    hit = hit[np.argsort(along[hit])]
    foot = a + along[hit, None] * u
    d = foot - true_xy[hit]
    c, s = np.cos(turn[hit]), np.sin(turn[hit])
    moved = used_xy[hit] + np.column_stack((c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]))
    pos, pts = [], []
    for i in range(hit.size - 1):
        p, q = along[hit[i]], along[hit[i + 1]]
        if q - p > FOOT_GAP_M:
            continue
        t = np.linspace(0.0, 1.0, max(int((q - p) / 0.01), 1) + 1)
        pos.append(p + t * (q - p))
        pts.append(moved[i] + t[:, None] * (moved[i + 1] - moved[i]))
    if not pos:
        return np.zeros(0), np.zeros((0, 2))
    return np.concatenate(pos), np.concatenate(pts)


def fragmentation(data: dict[str, Any], beam: tuple[FloatArray, ...],
                  polys: list[FloatArray]) -> dict[str, Any]:  # fmt: skip
    """Per long wall: covering surfaces and best single coverage; bridged openings."""
    from scipy.spatial import cKDTree

    walls = walls_of(data)
    samples = [_resample(p) for p in polys]
    trees = [cKDTree(q) for q in samples]
    rows = []
    for a, b in walls:
        length = float(np.hypot(*(b - a)))
        if length < LONG_WALL_M:
            continue
        pos, pts = seen_feet(a, b, beam)
        seen = np.unique(np.floor(pos / BIN_M).astype(int))
        if seen.size * BIN_M < LONG_WALL_M:
            continue
        wall_tree = cKDTree(pts)
        count, best = 0, 0.0
        for q, tree in zip(samples, trees, strict=True):
            near = wall_tree.query(q, distance_upper_bound=COVER_TOL_M)[0] <= COVER_TOL_M
            if near.mean() >= 0.5:
                count += 1
            hit = tree.query(pts, distance_upper_bound=COVER_TOL_M)[0] <= COVER_TOL_M
            if hit.any():
                bins = np.unique(np.floor(pos[hit] / BIN_M).astype(int))
                best = max(best, float(np.isin(seen, bins).mean()))
        rows.append({"length": length, "seen": seen.size * BIN_M, "count": count, "best": best})
    bridged, openings = 0, 0
    for i, (a, b) in enumerate(walls):
        for c, d in walls[i + 1 :]:
            u = (b - a) / np.hypot(*(b - a))
            v = (d - c) / np.hypot(*(d - c))
            if abs(u[0] * v[1] - u[1] * v[0]) > 0.02 or abs(_frame(a, b, c[None])[1][0]) > 0.02:
                continue
            ends = [(p, q) for p in (a, b) for q in (c, d)]
            p, q = min(ends, key=lambda e: float(np.hypot(*(e[0] - e[1]))))
            gap = float(np.hypot(*(q - p)))
            if not GAP_MIN_M <= gap <= GAP_MAX_M:
                continue
            # the gap must not lie inside either wall (overlapping collinear walls)
            ga, _, _ = _frame(a, b, ((p + q) / 2)[None])
            if 0 <= ga[0] <= np.hypot(*(b - a)):
                continue
            openings += 1
            inner = 0.10
            covered = np.zeros(max(int((gap - 2 * inner) / 0.01), 1), dtype=bool)
            for s in samples:
                sa, sc, _ = _frame(p, q, s)
                hit = (np.abs(sc) <= BRIDGE_TOL_M) & (sa >= inner) & (sa < gap - inner)
                idx = ((sa[hit] - inner) / 0.01).astype(int)
                covered[np.clip(idx, 0, covered.size - 1)] = True
            bridged += int(covered.mean() >= 1.0 / 3.0)
    return {"walls": rows, "openings": openings, "bridged": bridged}


def one_pose_surfaces(lg: Any, polys: list[FloatArray]) -> tuple[int, int]:
    """Surfaces whose echoes come from a single robot pose, and the fewest poses of any."""
    from sonarproc.surfaces import echo_points

    r = lg.readings
    geo, ok, keep = own_echo_geometry(r, lg)
    if not polys:
        return 0, 0
    per = echo_points(polys, [False] * len(polys), geo, tol=EXPLAINED_TOL)
    pose = np.round(np.column_stack((r["x"], r["y"]))[ok][keep] / 0.0254)
    poses = [int(np.unique(pose[s.readings], axis=0).shape[0]) for s in per]
    return sum(p <= 1 for p in poses), min(poses)


def study(name: str, work: Path, *, drift: bool, worse: dict[str, float],
          stale: float) -> dict[str, Any]:  # fmt: skip
    """Simulate, drift, run and measure one scene."""
    from sonarproc.simulate import write_result
    from sonarsim import scenario_from_dict, simulate

    path = SCENES / f"{name}.yaml"
    data = yaml.safe_load(path.read_text(encoding="utf-8"))
    data.setdefault("imperfections", {}).update(worse)
    res = simulate(scenario_from_dict(data, base_dir=path.parent, source=str(path)))
    if stale:
        # whole readings go, as a driver that publishes only fresh values drops them
        keep = np.random.default_rng(int(data.get("seed", 0))).random(res.readings.size) >= stale
        res = dataclasses.replace(res, readings=res.readings[keep])
    rows = drifted_readings(res.readings, seed=int(data.get("seed", 0))) if drift else res.readings
    log = work / f"{name}.h5"
    log.unlink(missing_ok=True)
    write_result(dataclasses.replace(res, readings=rows), log, robot=f"sonarsim:{name}")
    out = work / name
    exe = Path(sys.executable).parent / "sonarproc"
    proc = subprocess.run([str(exe), "run", str(log), "--out", str(out), "--json"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    metrics = json.loads(proc.stdout)["metrics"]
    report = json.loads((out / "report.json").read_text(encoding="utf-8"))
    polys = read_surfaces(out / "surfaces.csv") if (out / "surfaces.csv").is_file() else []
    from sonarproc.pipeline import load_log
    from sonarproc.pipeline.alignment import align_log

    used, _ = align_log(load_log(log))  # the poses the run mapped with
    if not np.array_equal(used.readings["t"], res.readings["t"]):
        raise SystemExit(f"{name}: the log's readings are not in the simulation's order")
    beam = beams(res.readings, res.sensors, res.speed_of_sound, used.readings)
    frag = fragmentation(data, beam, polys)
    single, fewest = one_pose_surfaces(used, polys)
    q = report.get("quality", {})
    return {**frag, "surfaces": len(polys), "single_pose": single, "fewest_poses": fewest,
            "precision": metrics.get("precision_m"), "completeness": metrics.get("completeness"),
            "explained": q.get("explained_fraction"),
            "aligned": bool(report.get("alignment", {}).get("applied", False))}  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """Study the scenes; print the table."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True, help="folder for the logs and runs")
    ap.add_argument("--scene", action="append", help="a scene to study (default: SEEN)")
    ap.add_argument("--held-out", action="store_true", help="also study the HELD_OUT scenes")
    ap.add_argument("--no-drift", action="store_true", help="keep the true poses")
    ap.add_argument(
        "--stale",
        type=float,
        default=0.0,
        help="drop this share of the readings (a real driver drops stale values)",
    )
    ap.add_argument(
        "--spurious",
        type=float,
        default=0.0,
        help="this share of the firings hears a spurious echo",
    )
    args = ap.parse_args(argv)
    worse = {}
    if args.spurious:
        worse["spurious_probability"] = args.spurious
    args.work.mkdir(parents=True, exist_ok=True)
    print("| scene | long walls | surfaces per wall | mean | best share (min/mean) |"
          " openings bridged | surfaces (line) | one-pose | precision | completeness |"
          " explained | aligned |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in list(args.scene or SEEN) + (list(HELD_OUT) if args.held_out else []):
        f = study(name, args.work, drift=not args.no_drift, worse=worse, stale=args.stale)
        counts = [w["count"] for w in f["walls"]]
        best = [w["best"] for w in f["walls"]]
        tag = " (held out)" if name in HELD_OUT else ""
        mean = np.mean(counts) if counts else float("nan")
        shares = f"{min(best):.2f} / {np.mean(best):.2f}" if best else "-"
        expl = f["explained"] if f["explained"] is not None else float("nan")
        print(f"| {name}{tag} | {len(counts)} | {' '.join(map(str, counts))} | {mean:.2f} |"
              f" {shares} | {f['bridged']}/{f['openings']} | {f['surfaces']} |"
              f" {f['single_pose']} (fewest {f['fewest_poses']}) |"
              f" {100 * f['precision']:.1f} cm | {f['completeness']:.2f} | {expl:.2f} |"
              f" {'yes' if f['aligned'] else 'no'} |", flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())

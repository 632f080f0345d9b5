"""Benchmark: which truth the sonars saw, on the hour-long room log (time and peak memory).

The log is the one of :mod:`test_bench_run`: 90 000 readings of a 16-sonar ring wandering
in a 20 m x 20 m room whose walls are the truth (8 001 points at 1 cm). Timed:
:func:`sonarproc.surfaces.seen_truth` with the log's beams, and with wide beams (1.4 rad)
and a 5 cm tolerance (many more candidate pairs). The baseline, measured in the same run,
is the least a ball search must do: a KD-tree of the truth and a count of the truth points
in every reading's ball. Peak memory is the growth of this process's peak RSS during the
call (Linux: the peak is reset first). Target: under 150 MB extra.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest
from benchroom import write_room_log
from scipy.spatial import cKDTree

from sonarlog import read_log
from sonarproc.surfaces import seen_truth, truth_points

TARGET_MB = 150.0


def _status_mb(key: str) -> float:
    text = Path("/proc/self/status").read_text()
    match = re.search(rf"{key}:\s*(\d+)", text)
    return int(match.group(1)) / 1024 if match else float("nan")


def _peak_extra_mb(fn):  # type: ignore[no-untyped-def]
    """Run ``fn``; return its result, wall seconds and peak RSS growth (MB, NaN if unknown)."""
    try:
        Path("/proc/self/clear_refs").write_text("5")  # reset VmHWM to the current RSS
        base = _status_mb("VmRSS")
    except OSError:
        base = float("nan")
    t0 = time.perf_counter()
    out = fn()
    wall = time.perf_counter() - t0
    return out, wall, _status_mb("VmHWM") - base


def _best(fn, repeat: int = 3):  # type: ignore[no-untyped-def]
    runs = [_peak_extra_mb(fn) for _ in range(repeat)]
    return runs[0][0], min(r[1] for r in runs), max(r[2] for r in runs)


@pytest.mark.benchmark
def test_bench_seen_truth(tmp_path: Path) -> None:
    path = tmp_path / "hour.h5"
    write_room_log(path, 1.0)
    lg = read_log(path)
    r = lg.readings[np.isfinite(lg.readings["tof"])]
    tp = lg.transducer_poses(r)
    pts = np.concatenate(truth_points(lg.truth))
    args = (pts, tp.tx_xy, tp.tx_heading, tp.rx_xy, tp.rx_heading, lg.path_lengths(r))
    n = len(r)

    # the floor: the truth tree and a count of the points in every reading's ball (a ball
    # of the beam's half-width at the range, around the point on the axis)
    rng_m = 0.5 * lg.path_lengths(r)
    centre = tp.tx_xy + rng_m[:, None] * np.stack(
        (np.cos(tp.tx_heading), np.sin(tp.tx_heading)), axis=1
    )
    radius = rng_m * np.sin(tp.tx_half_beamwidth) + 0.02

    def floor() -> int:
        return int(cKDTree(pts).query_ball_point(centre, radius, return_length=True).sum())

    candidates, t_floor, _ = _best(floor)
    print(f"\nseen truth: {n} readings, {len(pts)} truth points, {candidates} ball candidates")
    print(f"  floor (truth tree + ball counts) {t_floor:.3f} s")
    seen_counts = []
    for name, beam, tol in (
        ("log beams, tol 2 cm", None, 0.02),
        ("1.4 rad beams, tol 5 cm", 1.4, 0.05),
    ):
        tb = tp.tx_half_beamwidth if beam is None else np.full(n, beam)
        rb = tp.rx_half_beamwidth if beam is None else np.full(n, beam)
        seen, wall, extra = _best(
            lambda tb=tb, rb=rb, tol=tol: seen_truth(
                *args, tx_half_beamwidth=tb, rx_half_beamwidth=rb, tol=tol
            )
        )
        print(
            f"  {name}: {wall:.3f} s (ratio to floor {wall / t_floor:.1f}), "
            f"peak extra {extra:.0f} MB (target {TARGET_MB:.0f}: ratio {extra / TARGET_MB:.2f}), "
            f"{int(seen.sum())} points seen"
        )
        seen_counts.append(int(seen.sum()))
    # the readings reach every wall of the room: all of the truth is seen either way
    assert seen_counts == [len(pts), len(pts)]

"""Convert the RoboND occupancy-grid recording to a readings CSV plus a sensors YAML.

Source: ``udacity/RoboND-OccupancyGridMappingAlgorithm`` (MIT), files ``Data/poses.txt``
and ``Data/measurement.txt``: one line per sonar scan, ``time x y theta`` and
``time r0 ... r7``. Units, as the repository's own ``solution.cpp`` reads them:
time in milliseconds, x and y in millimetres, theta in tenths of a degree, ranges in
millimetres; ranges at or beyond 5000 mm (the sensor's ``Zmax``; the file holds 5110
for "nothing heard") are no echo.

The robot is a Pioneer with eight front sonars. Their mounts are the Pioneer 3-DX's
front ring (ARIA's ``p3dx.p``, the same numbers as ``configs/sensors/pioneer3-dx.yaml``):
90, 50, 30, 10, -10, -30, -50, -90 degrees. The recording does not say in which order
its eight columns run; ``--order`` picks ARIA's (column 0 at +90 degrees, the robot's
left) or the reverse (column 0 at -90 degrees, the robot's right, as the course's own
sensor model assumes). ``--order reversed`` is the default: with it, echoes of the same
place heard by different sonars agree far more often (see PROVENANCE.md beside the
data), which a wrong order, mirroring every reading, would break.

Usage::

    python tools/real_logs/convert_robond.py tests/data/real/robond
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

#: Pioneer 3-DX front sonars in ARIA's order: x, y (m), heading (deg).
FRONT_RING = (
    (0.069, 0.136, 90.0),
    (0.114, 0.119, 50.0),
    (0.148, 0.078, 30.0),
    (0.166, 0.027, 10.0),
    (0.166, -0.027, -10.0),
    (0.148, -0.078, -30.0),
    (0.114, -0.119, -50.0),
    (0.069, -0.136, -90.0),
)
#: Ranges at or beyond this are no echo (the recording's Zmax, mm).
NO_ECHO_MM = 5000.0
#: A Pioneer sonar's half beam width (15 degrees) and usable range (m).
HALF_BEAM = math.radians(15.0)
MIN_RANGE, MAX_RANGE = 0.1, 5.0


def sensors_yaml(order: str) -> str:
    """The sensors YAML for the given column order (``aria`` or ``reversed``)."""
    mounts = FRONT_RING if order == "aria" else FRONT_RING[::-1]
    lines = [
        "# Pioneer front sonar ring (8 transducers), mounts in the robot base frame",
        f"# (x forward, y left), SI units. Column order: {order}. Written by",
        "# tools/real_logs/convert_robond.py.",
        "robot: pioneer-robond",
        "speed_of_sound: 343.3",
        "sensors:",
    ]
    for i, (x, y, h) in enumerate(mounts):
        lines.append(
            f"  - {{id: {i}, x: {x:.3f}, y: {y:.3f}, heading: {math.radians(h):.6f}, "
            f"half_beamwidth: {HALF_BEAM:.6f}, min_range: {MIN_RANGE}, max_range: {MAX_RANGE}}}"
        )
    return "\n".join(lines) + "\n"


def readings_csv(poses: np.ndarray, ranges: np.ndarray) -> str:
    """One CSV row per (scan, sonar); SI units; no-echo ranges flagged."""
    out = [
        "# RoboND occupancy-grid recording (MIT), converted by tools/real_logs/convert_robond.py",
        "t,tx,rx,range,x,y,theta,turret,flags",
    ]
    for k in range(poses.shape[0]):
        t = poses[k, 0] / 1000.0
        x, y = poses[k, 1] / 1000.0, poses[k, 2] / 1000.0
        th = math.radians(poses[k, 3] / 10.0)
        th = math.atan2(math.sin(th), math.cos(th))
        for i in range(ranges.shape[1]):
            r = ranges[k, i]
            flags = 1 if r >= NO_ECHO_MM else 0
            rng = "nan" if flags else f"{r / 1000.0:.3f}"
            out.append(f"{t:.3f},{i},{i},{rng},{x:.3f},{y:.3f},{th:.6f},{th:.6f},{flags}")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    """Convert ``DIR/poses.txt`` and ``DIR/measurement.txt`` into ``DIR/readings.csv``
    and ``DIR/sensors.yaml``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", type=Path, help="holds poses.txt and measurement.txt")
    ap.add_argument("--order", choices=("aria", "reversed"), default="reversed")
    ap.add_argument("--out", type=Path, default=None, help="output folder (default: FOLDER)")
    args = ap.parse_args(argv)
    try:
        poses = np.loadtxt(args.folder / "poses.txt", ndmin=2)
        meas = np.loadtxt(args.folder / "measurement.txt", ndmin=2)
    except (OSError, ValueError) as err:
        print(f"convert_robond: error: {err}", file=sys.stderr)
        return 2
    if poses.shape[1] != 4 or meas.shape[1] != 9 or poses.shape[0] != meas.shape[0]:
        print("convert_robond: error: expected poses (N x 4) and measurements (N x 9)",
              file=sys.stderr)  # fmt: skip
        return 2
    if not np.array_equal(poses[:, 0], meas[:, 0]):
        print("convert_robond: error: pose and measurement times differ", file=sys.stderr)
        return 2
    out = args.out or args.folder
    out.mkdir(parents=True, exist_ok=True)
    (out / "readings.csv").write_text(readings_csv(poses, meas[:, 1:]))
    (out / "sensors.yaml").write_text(sensors_yaml(args.order))
    return 0


if __name__ == "__main__":
    sys.exit(main())

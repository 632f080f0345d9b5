"""A sonarlog's own first echoes written as a Player ``writelog`` text log, as p2os would.

Each firing becomes a ``position2d`` line (the pose at the firing) and a ``sonar`` line
holding every transducer's latest range (the fired one new, the others repeated), in
Player's own number formats: times to the millisecond, ranges to the millimetre, the
geometry to the millimetre and 0.1 mrad. A transducer that has not fired yet reports its
``max_range`` (no echo), as the robot firmware does.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml

from sonarlog import FLAG_NO_ECHO, SonarLog

__all__ = ["at_player_precision", "write_player_from_log", "write_sensors_yaml"]


def at_player_precision(lg: SonarLog) -> SonarLog:
    """``lg`` with its own first echoes only, rounded to what a Player log holds.

    Times to the millisecond, positions and ranges to the millimetre, the heading to the
    milliradian (the base heading is the turret's: Player knows no turret), so the same
    readings can be written as a sonarlog and as a Player log.
    """
    r = lg.readings[(lg.readings["tx"] == lg.readings["rx"]) & (lg.readings["echo"] == 0)].copy()

    def rounded(v: np.ndarray, digits: int) -> np.ndarray:
        return np.array([float(f"{x:.{digits}f}") for x in v])  # as Player's text parses

    r["t"] = rounded(r["t"], 3)
    r["x"], r["y"] = rounded(r["x"], 3), rounded(r["y"], 3)
    r["theta"] = r["turret"] = rounded(r["turret"], 3)
    echo = (r["flags"] & FLAG_NO_ECHO) == 0
    c = lg.speed_of_sound
    r["tof"][echo] = 2.0 * rounded(0.5 * r["tof"][echo] * c, 3) / c
    return replace(lg, readings=r)


def write_sensors_yaml(path: Path, lg: SonarLog) -> Path:
    """The log's ``/sensors`` table as a sensors YAML (full float precision)."""
    rows = [
        {k: (int(s[k]) if k == "id" else float(s[k])) for k in lg.sensors.dtype.names or ()}
        for s in lg.sensors
    ]
    doc = {"robot": str(lg.attrs.get("robot", "")), "speed_of_sound": lg.speed_of_sound,
           "sensors": rows}  # fmt: skip
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return path


def write_player_from_log(path: Path, lg: SonarLog) -> int:
    """Write ``lg``'s own first echoes (tx == rx, echo 0) as a Player log; how many."""
    r = lg.readings
    r = r[(r["tx"] == r["rx"]) & (r["echo"] == 0)]
    s = lg.sensors
    row_of = {int(v): k for k, v in enumerate(s["id"])}
    current = np.array(s["max_range"], dtype=np.float64)
    geom = " ".join(
        f"{x:+07.3f} {y:+07.3f} {a:+07.4f}"
        for x, y, a in zip(s["x"], s["y"], s["heading"], strict=True)
    )
    t0 = float(r["t"][0]) if len(r) else 0.0
    lines = ["## Player version 3.0.2 ", "## File version 0.3.0 ",
             f"{t0:014.3f} 16777343 6665 sonar 00 004 001 {len(s)} {geom} "]  # fmt: skip
    half = 0.5 * r["tof"] * lg.speed_of_sound
    for i in range(len(r)):
        t = float(r["t"][i])
        j = row_of[int(r["rx"][i])]
        no_echo = bool(r["flags"][i] & FLAG_NO_ECHO) or not np.isfinite(half[i])
        current[j] = s["max_range"][j] if no_echo else half[i]
        pose = f"{r['x'][i]:+07.3f} {r['y'][i]:+07.3f} {r['turret'][i]:+04.3f}"
        lines.append(
            f"{t:014.3f} 16777343 6665 position2d 00 001 001 {pose} +0.000 +0.000 +0.000 0"
        )
        ranges = " ".join(f"{v:.3f}" for v in current)
        lines.append(f"{t:014.3f} 16777343 6665 sonar 00 001 001 {len(s)} {ranges} ")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return len(r)

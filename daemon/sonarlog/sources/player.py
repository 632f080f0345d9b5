"""Player/Stage text logs (the ``writelog`` driver, file format 0.3.0).

Each line is ``time host robot interface index type subtype payload``; ``##`` lines are
comments. The lines this reader uses:

==============  ====  =======  =====================================================
interface       type  subtype  payload
==============  ====  =======  =====================================================
``sonar``       1     1        ``count r0 r1 ...`` ranges (m)
``sonar``       1/4   2/1      ``count x0 y0 a0 ...`` transducer poses (m, rad), the
                               geometry (data message 1:2 or the 4:1 request reply)
``position2d``  1     1        ``px py pa vx vy va stall`` odometry (m, rad)
==============  ====  =======  =====================================================

Devices are named ``interface:index`` (``sonar:0``, ``position2d:0``). Mounts come from a
preset or sensors file when given, else from the log's sonar geometry with the Pioneer
beam figures (half beam width 15 degrees, 0.1-5.0 m), which is what Player logs mostly hold.
"""

from __future__ import annotations

import contextlib
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sonarlog.schema import SENSOR_DTYPE
from sonarlog.sources.assemble import RawValues
from sonarlog.sources.errors import SourceError
from sonarlog.sources.poses import PoseTrack
from sonarlog.sources.presets import SensorSet
from sonarlog.sources.stale import value_key
from sonarlog.sources.summary import ImportOptions, TopicRow

__all__ = ["PLAYER_BEAM", "PlayerContent", "is_player_log", "list_player", "read_player"]

#: Beam and range used with a log's own geometry: half beam width (rad), min and max (m).
PLAYER_BEAM = (math.radians(15.0), 0.1, 5.0)

_LINE = re.compile(rb"^\s*\d+(\.\d*)?\s+\d+\s+\d+\s+[a-z0-9_]+\s+\d+\s+\d+\s+\d+")


def is_player_log(path: Path) -> bool:
    """True for a text file that opens with Player's header or a Player data line."""
    if not path.is_file():
        return False
    try:
        with path.open("rb") as fh:
            head = fh.read(4096)
    except OSError:
        return False
    if head.startswith(b"## Player"):
        return True
    lines = [ln for ln in head.splitlines() if ln.strip() and not ln.startswith(b"#")]
    return bool(lines) and _LINE.match(lines[0]) is not None


@dataclass
class _Device:
    count: int = 0
    t: list[float] = field(default_factory=list)
    values: list[list[float]] = field(default_factory=list)
    geometry: list[float] | None = None


def _count(payload: list[float]) -> int | None:
    """The element count a message starts with, or None when it is not a count."""
    if not payload or not math.isfinite(payload[0]) or payload[0] < 0:
        return None
    n = payload[0]
    return int(n) if n == int(n) else None


def _parse(path: Path) -> tuple[dict[str, _Device], int]:
    devices: dict[str, _Device] = {}
    bad = 0
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise SourceError(f"{path}: cannot read ({err.strerror or err})") from err
    for line in text.splitlines():
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        f = line.split()
        try:
            t, iface, index, mtype, sub = float(f[0]), f[3], int(f[4]), int(f[5]), int(f[6])
            payload = [float(v) for v in f[7:]]
        except (ValueError, IndexError):
            bad += 1  # a line cut short by a killed logger, or an interface we do not read
            continue
        dev = devices.setdefault(f"{iface}:{index}", _Device())
        dev.count += 1
        if iface == "sonar" and ((mtype, sub) in ((1, 2), (4, 1))):
            n = _count(payload)
            if n is not None and len(payload) >= 1 + 3 * n:
                dev.geometry = payload[1 : 1 + 3 * n]
        elif iface == "sonar" and (mtype, sub) == (1, 1):
            n = _count(payload)
            if n is None or len(payload) < 1 + n:
                bad += 1
                continue
            dev.t.append(t)
            dev.values.append(payload[1 : 1 + n])
        elif iface == "position2d" and (mtype, sub) == (1, 1) and len(payload) >= 3:
            dev.t.append(t)
            dev.values.append(payload[:3])
    return devices, bad


def _pick(path: Path, devices: dict[str, _Device], iface: str, want: str | None) -> str:
    if want:
        if want not in devices or not want.startswith(f"{iface}:"):
            have = ", ".join(sorted(devices)) or "none"
            raise SourceError(f"{path}: no {iface} device {want!r} with data (devices: {have})")
        return want
    cands = sorted(n for n, d in devices.items() if n.startswith(f"{iface}:") and d.t)
    if not cands:
        what = "no sonar device" if iface == "sonar" else "no odometry (position2d device)"
        raise SourceError(f"{path}: {what} with data in this Player log")
    return cands[0]


def list_player(path: Path) -> list[TopicRow]:
    """The devices of a Player log and whether an import would use each."""
    devices, _ = _parse(path)
    if not devices:
        raise SourceError(f"{path}: empty Player log (no data lines)")
    used: dict[str, tuple[str, str]] = {}
    for iface, role in (("sonar", "sonar"), ("position2d", "odometry")):
        with contextlib.suppress(SourceError):
            used[_pick(path, devices, iface, None)] = (role, f"first {iface} device with data")
    return [
        TopicRow(n, n.split(":")[0], d.count, *used.get(n, ("", "not used")))
        for n, d in sorted(devices.items())
    ]


@dataclass(frozen=True)
class PlayerContent:
    """What a Player log gave."""

    raw: RawValues
    track: PoseTrack
    sensors: np.ndarray
    sonar: str
    odom: str
    sensors_from: str


def _table(path: Path, dev: _Device, spec: SensorSet | None, n: int) -> tuple[np.ndarray, str]:
    if spec is not None:
        if n > len(spec.table):
            raise SourceError(
                f"{path}: sonar lines hold {n} ranges but {spec.source} has {len(spec.table)}"
            )
        return spec.table, spec.source
    if dev.geometry is None:
        raise SourceError(
            f"{path}: no sonar geometry in the log; give a robot preset or a sensors file"
        )
    g = np.asarray(dev.geometry, dtype=np.float64).reshape(-1, 3)
    if n > len(g):
        raise SourceError(
            f"{path}: sonar lines hold {n} ranges but the geometry has {len(g)} poses"
        )
    table = np.zeros(len(g), dtype=SENSOR_DTYPE)
    table["id"] = np.arange(len(g))
    table["x"], table["y"], table["heading"] = g[:, 0], g[:, 1], g[:, 2]
    table["half_beamwidth"], table["min_range"], table["max_range"] = PLAYER_BEAM
    return table, "player geometry"


def read_player(path: Path, opts: ImportOptions, spec: SensorSet | None) -> PlayerContent:
    """Decode a Player log's sonar ranges, odometry and mounts."""
    devices, _ = _parse(path)
    if not devices:
        raise SourceError(f"{path}: empty Player log (no data lines)")
    sname = _pick(path, devices, "sonar", opts.sonar_topic)
    oname = _pick(path, devices, "position2d", opts.odom_topic)
    sonar, odom = devices[sname], devices[oname]
    counts = np.array([len(v) for v in sonar.values], dtype=np.int64)
    table, source = _table(path, sonar, spec, int(counts.max(initial=0)))
    flat = np.array([r for v in sonar.values for r in v], dtype=np.float64)
    idx = np.arange(flat.size) - np.repeat(np.cumsum(counts) - counts, counts)
    t = np.repeat(np.asarray(sonar.t, dtype=np.float64), counts)
    ids = table["id"][idx].astype(np.int64)
    raw = RawValues(t, ids, flat, value_key(flat), len(sonar.t))
    p = np.asarray(odom.values, dtype=np.float64).reshape(-1, 3)
    track = PoseTrack.of(odom.t, p[:, 0], p[:, 1], p[:, 2])
    return PlayerContent(raw, track, table, sname, oname, source)

"""Which readings of a real log its map leaves unexplained, and why (for docs/real-logs.md).

The run's quality figure (report.json ``quality``) counts the readings whose range the
map predicts within 5 cm by the first-echo model of ``--auto``: the nearest *specular*
point of a surface inside the reading's beam. This module sorts every reading the run
mapped (the same readings: :func:`sonarproc.pipeline.selection.select_beams`) by what
the map says about it, from the run's own surfaces (``surfaces.csv``):

- ``explained``: the specular prediction is within 5 cm;
- ``mispredicted``: there is a specular prediction, more than 5 cm off;
- ``beyond_a_surface``: no specular prediction (no mapped surface faces the sensor
  within its beam), yet a mapped surface crosses the beam nearer than the measured
  range. A smooth wall seen at an incidence beyond the half beam width sends its echo
  away; the sonar then hears something further: a gap in the wall (a doorway, a
  recess), a point reflector at such a gap (a door jamb), or a multipath echo;
- ``at_a_surface``: no specular prediction, but a mapped surface crosses the beam at
  the measured range (within 5 cm): a diffuse echo, or one from the end of a surface;
- ``at_a_point``: none of the above, but a point reflector the run reported (a corner,
  an edge) lies in the beam at the measured range;
- ``nothing_mapped``: nothing mapped in the beam at or before the measured range: a
  surface the map lacks.

The same figures per sensor direction: ``side`` (60 degrees or more off the robot's
heading: they face the walls a robot drives along), ``oblique`` (20 to 60 degrees),
``front`` (less than 20 degrees).
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

#: A range predicted within this is explained (the quality figure's 5 cm).
TOLERANCE = 0.05
#: Spacing (m) of the points surfaces are sampled at (the quality prediction's).
SPACING = 0.02
#: Readings per block when comparing every reading with every surface point (memory).
BLOCK = 256
CATEGORIES = ("explained", "mispredicted", "beyond_a_surface", "at_a_surface", "at_a_point",
              "nothing_mapped")  # fmt: skip
#: Sensor directions (degrees off the robot's heading) that name the groups.
GROUPS = (("side", 60.0, 181.0), ("oblique", 20.0, 60.0), ("front", 0.0, 20.0))


def read_map(path: Path) -> tuple[list[FloatArray], FloatArray]:
    """The polylines and the point features (P, 2) of a run's surfaces.csv."""
    polys: dict[int, list[tuple[float, float]]] = {}
    with path.open(newline="") as f:
        for row in csv.DictReader(f):
            polys.setdefault(int(row["surface"]), []).append((float(row["x"]), float(row["y"])))
    lines = [np.asarray(v) for _, v in sorted(polys.items()) if len(v) >= 2]
    points = np.asarray([v[0] for _, v in sorted(polys.items()) if len(v) == 1]).reshape(-1, 2)
    return lines, points


def _nearest_in_beam(
    xy: FloatArray, heading: FloatArray, half: FloatArray, targets: FloatArray, rng: FloatArray
) -> tuple[FloatArray, npt.NDArray[np.bool_]]:
    """Per reading: the distance to the nearest target inside its beam (inf if none), and
    whether a target inside the beam lies at its range within :data:`TOLERANCE`."""
    near = np.full(xy.shape[0], np.inf)
    at = np.zeros(xy.shape[0], dtype=bool)
    if targets.size == 0:
        return near, at
    for s in range(0, xy.shape[0], BLOCK):
        d = targets[None, :, :] - xy[s : s + BLOCK, None, :]
        dist = np.hypot(d[..., 0], d[..., 1])
        off = np.angle(
            np.exp(1j * (np.arctan2(d[..., 1], d[..., 0]) - heading[s : s + BLOCK, None]))
        )
        inside = np.abs(off) <= half[s : s + BLOCK, None]
        near[s : s + BLOCK] = np.where(inside, dist, np.inf).min(axis=1)
        at[s : s + BLOCK] = (inside & (np.abs(dist - rng[s : s + BLOCK, None]) <= TOLERANCE)).any(1)
    return near, at


def classify(log_path: Path, sensors: Path | None, robot: str | None, surfaces_csv: Path
             ) -> dict[str, dict[str, float]]:  # fmt: skip
    """Fractions of the mapped readings in each category, overall and per sensor group.

    Returns ``{"all": {...}, "side": {...}, ...}``: each maps the categories of the
    module notes, and ``readings`` (their count), to fractions of that group.
    """
    from sonarproc.params import RunParams
    from sonarproc.pipeline.run import load_log
    from sonarproc.pipeline.selection import select_beams
    from sonarproc.quality.predict import MapCurves, predict_paths, resample

    lg = load_log(log_path, sensors=sensors, robot=robot)
    beams, _ = select_beams(lg, RunParams())
    lines, points = read_map(surfaces_csv)
    n = int(beams.path.size)
    rng = 0.5 * beams.path
    p = beams.poses
    if lines:
        curves = MapCurves([resample(line, SPACING) for line in lines], list(range(len(lines))),
                           single=False)  # fmt: skip
        path, _ = predict_paths(curves, beams, np.arange(n, dtype=np.intp))
        samples = np.vstack(curves.curves)
    else:
        path, samples = np.full(n, np.nan), np.zeros((0, 2))
    predicted = np.isfinite(path)
    explained = predicted & (np.abs(rng - 0.5 * path) <= TOLERANCE)
    near, at_surface = _nearest_in_beam(p.tx_xy, p.tx_heading, p.tx_half_beamwidth, samples, rng)
    _, at_point = _nearest_in_beam(p.tx_xy, p.tx_heading, p.tx_half_beamwidth, points, rng)
    rest = ~predicted
    at_s = rest & at_surface
    beyond = rest & ~at_surface & (near < rng - TOLERANCE)
    at_p = rest & ~at_surface & ~beyond & at_point
    label = {
        "explained": explained,
        "mispredicted": predicted & ~explained,
        "beyond_a_surface": beyond,
        "at_a_surface": at_s,
        "at_a_point": at_p,
        "nothing_mapped": rest & ~at_s & ~beyond & ~at_p,
    }
    mount = np.degrees(np.abs(np.angle(np.exp(1j * (p.tx_heading - np.asarray(
        beams.readings["theta"], dtype=np.float64))))))  # fmt: skip
    groups = {"all": np.ones(n, dtype=bool)}
    groups.update({g: (mount >= lo) & (mount < hi) for g, lo, hi in GROUPS})
    out: dict[str, dict[str, float]] = {}
    for g, mask in groups.items():
        k = max(int(mask.sum()), 1)
        out[g] = {c: float((label[c] & mask).sum()) / k for c in CATEGORIES}
        out[g]["readings"] = float(mask.sum())
    return out

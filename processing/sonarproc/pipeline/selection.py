"""Which readings a run maps, their arcs, and the grid the map is drawn on.

Every way of building a map starts here: :func:`select_beams` keeps the readings a run
maps (and counts the others), computes their transducer poses, path lengths and arcs
once, and :func:`plan_grid` lays the grid over the arcs (or the requested bbox), so every
method of a comparison draws on the same cells.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from sonarlog import FLAG_CROSSTALK, FLAG_NO_ECHO, SonarLog, TransducerPoses
from sonarproc.arcs import ArcGeometry, arcs_of
from sonarproc.errors import InputError, NothingToMapError, ParameterError
from sonarproc.grid import Grid
from sonarproc.params import RunParams

__all__ = ["Beams", "make_grid", "plan_grid", "select_beams", "select_readings"]


@dataclass(frozen=True)
class Beams:
    """The readings a run maps, with their geometry (one row per reading).

    Attributes
    ----------
    readings : ndarray of READING_DTYPE
        The kept readings.
    poses : sonarlog.TransducerPoses
        World poses and half beamwidths of each reading's transmitter and receiver.
    path : ndarray
        Path lengths (m): tof x speed of sound.
    arcs : ArcGeometry
        The arcs of the readings, computed once and shared by the grid and the map.
    silent : sonarlog.TransducerPoses or None
        The poses of the sensors' own readings that heard nothing within their
        ``max_range`` (flagged no echo, or echoing beyond it): free space up to there.
    """

    readings: np.ndarray
    poses: TransducerPoses
    path: npt.NDArray[np.float64]
    arcs: ArcGeometry
    silent: TransducerPoses | None = None

    @property
    def robot_xy(self) -> npt.NDArray[np.float64]:
        """Robot positions at the readings, (N, 2)."""
        r = self.readings
        return np.column_stack((r["x"], r["y"])).astype(np.float64)


def select_readings(log_: SonarLog, *, drop_crosstalk: bool) -> tuple[np.ndarray, dict[str, int]]:
    """Keep the readings to map; count the skipped ones; refuse unusable input.

    Readings flagged out of range / no echo (bit 0) are skipped and counted, as are those
    whose range (half the path) lies outside the receiver's ``[min_range, max_range]``.

    Raises
    ------
    NothingToMapError
        No readings, or every reading skipped.
    InputError
        A kept reading with tof <= 0 or NaN.
    sonarlog.InvalidLogError
        A reading names a transducer id with no ``/sensors`` row.
    """
    r = log_.readings
    name = str(log_.path)
    total = len(r)
    if total == 0:
        raise NothingToMapError(f"{name}: the log holds no readings")
    log_.sensor_rows(r["tx"])  # raises on an unknown transducer id
    rows = log_.sensor_rows(r["rx"])
    flagged = (r["flags"] & FLAG_NO_ECHO) != 0
    crosstalk = (r["flags"] & FLAG_CROSSTALK) != 0
    keep = ~flagged
    if drop_crosstalk:
        keep &= ~crosstalk
    tof = r["tof"]
    bad = keep & ~(np.isfinite(tof) & (tof > 0))
    if np.any(bad):
        first = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{name}: {int(bad.sum())} reading(s) have tof <= 0 or NaN without the "
            f"out-of-range flag (first at row {first}, tof={float(tof[first])!r})"
        )
    rng = np.zeros(total)
    rng[keep] = 0.5 * log_.path_lengths(r[keep])
    lo, hi = log_.sensors["min_range"][rows], log_.sensors["max_range"][rows]
    outside = keep & ((rng < lo) | (rng > hi))
    keep &= ~outside
    counts = {
        "readings_total": total,
        "readings_used": int(keep.sum()),
        "skipped_out_of_range": int(flagged.sum() + outside.sum()),
        "flagged_no_echo": int(flagged.sum()),
        "beyond_sensor_range": int(outside.sum()),
        "flagged_crosstalk": int(crosstalk.sum()),
        "skipped_crosstalk": int((crosstalk & ~flagged).sum()) if drop_crosstalk else 0,
        "dropped_torn_rows": int(log_.dropped_rows),
    }
    if counts["readings_used"] == 0:
        raise NothingToMapError(
            f"{name}: all {total} readings are flagged or out of range; nothing to map"
        )
    return r[keep], counts


def select_beams(log_: SonarLog, params: RunParams) -> tuple[Beams, dict[str, int]]:
    """The readings a run keeps, their transducer poses, path lengths and arcs.

    Returns
    -------
    beams : Beams
    counts : dict
        Readings total, used and skipped (by reason).

    Raises
    ------
    NothingToMapError, InputError
        As :func:`select_readings`.
    """
    readings, counts = select_readings(log_, drop_crosstalk=params.drop_crosstalk)
    poses = log_.transducer_poses(readings)
    path = log_.path_lengths(readings)
    return Beams(readings, poses, path, arcs_of(poses, path), _silent(log_)), counts


def _silent(log_: SonarLog) -> TransducerPoses | None:
    """Poses of the own-echo readings that heard nothing within their sensor's range."""
    r = log_.readings
    own = r["tx"] == r["rx"]
    flagged = (r["flags"] & FLAG_NO_ECHO) != 0
    # echoes beyond the shortest max_range of any sensor first (few), then each its own
    far = ~flagged & (0.5 * log_.path_lengths(r) > float(log_.sensors["max_range"].min()))
    hi = log_.sensors["max_range"][log_.sensor_rows(r["rx"][far])]
    far[far] = 0.5 * log_.path_lengths(r[far]) > hi
    silent = r[own & (flagged | far)]
    return log_.transducer_poses(silent) if len(silent) else None


def make_grid(params: RunParams, bounds: tuple[float, float, float, float], source: str) -> Grid:
    """Grid over ``params.bbox``, or over the arcs' bounding box ``bounds``.

    Raises
    ------
    NothingToMapError
        If no arc touches the bbox.
    ParameterError
        If the map would exceed ``params.max_cells``.
    """
    if params.bbox is not None:
        xmin, xmax, ymin, ymax = params.bbox
        axmin, axmax, aymin, aymax = bounds
        if axmin > xmax or axmax < xmin or aymin > ymax or aymax < ymin:
            raise NothingToMapError(
                f"{source}: no arc touches the bbox {xmin:g},{xmax:g},{ymin:g},{ymax:g} "
                f"(the arcs span {axmin:.3g},{axmax:.3g},{aymin:.3g},{aymax:.3g})"
            )
    else:
        xmin, xmax, ymin, ymax = bounds
    # in floats first: a bbox spanning 1e308 m has no integer cell count
    nx = float(np.ceil((xmax - xmin) / params.cell)) + 1
    ny = float(np.ceil((ymax - ymin) / params.cell)) + 1
    if not nx * ny <= params.max_cells:
        raise ParameterError(
            "cell",
            f"{params.cell:g} m makes a map of {nx:.0f} x {ny:.0f} cells for {source} (at "
            f"most {params.max_cells} allowed); choose a bbox or a larger cell",
        )
    return Grid.covering(xmin, xmax, ymin, ymax, cell=params.cell)


def plan_grid(log_: SonarLog, params: RunParams, beams: Beams) -> Grid:
    """The grid of a run: ``params.bbox`` or the bounding box of the arcs.

    Raises
    ------
    NothingToMapError
        No reading makes an arc, or no arc touches the bbox.
    ParameterError
        The map would exceed ``params.max_cells``.
    """
    source = str(log_.path)
    if len(beams.arcs) == 0:
        raise NothingToMapError(
            f"{source}: no reading makes an arc (paths too short or outside the beams)"
        )
    return make_grid(params, beams.arcs.bounds(), source)

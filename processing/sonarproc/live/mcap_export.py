"""``sonarproc export --format mcap``: the live view's channels over a log's time span.

The file holds what ``sonarproc watch --foxglove`` would have served had it followed the
run: every reading (``/sonar/readings`` and ``/sonar/raw``, one message each, at its
firing time), pose, path and transforms, and the map growing: the live accumulator
(:class:`~sonarproc.pipeline.live.LiveAccumulator`) takes snapshots every
:func:`snapshot_times` of log time, and the final message on the map channels is the
run's own result (so ``/map/surfaces``, replayed, holds the run's surfaces). Opening the
file in the Foxglove app replays the run.

The file is written beside its destination and renamed into place: never a partial file.
"""

from __future__ import annotations

import logging
import math
import os
from pathlib import Path

import numpy as np

from sonarlog import SonarLog
from sonarlog.foxglove_messages import RobotPublisher
from sonarlog.sources import OutputExistsError
from sonarproc.errors import SonarprocError
from sonarproc.live.map_messages import MapPublisher
from sonarproc.params import RunParams
from sonarproc.pipeline.live import LiveAccumulator
from sonarproc.pipeline.result import RunResult

__all__ = ["MAX_SNAPSHOTS", "MIN_SNAPSHOT_GAP_S", "snapshot_times", "write_mcap"]

log = logging.getLogger(__name__)

#: Map snapshots in a recording: each redoes the whole map, so their number is bounded;
#: a replay shows the map grow in that many steps (plus the final result).
MAX_SNAPSHOTS = 20
#: Log time between snapshots at least (s): the live view's pace at its fastest.
MIN_SNAPSHOT_GAP_S = 5.0


def snapshot_times(t: np.ndarray) -> np.ndarray:
    """Log times (UNIX s) after which a snapshot is taken, before the end of the log.

    Examples
    --------
    >>> snapshot_times(np.array([0.0, 12.0])).tolist()
    [5.0, 10.0]
    >>> len(snapshot_times(np.linspace(0.0, 1000.0, 5)))
    19
    """
    if len(t) == 0:
        return np.zeros(0)
    t0, t1 = float(t[0]), float(t[-1])
    gap = max(MIN_SNAPSHOT_GAP_S, (t1 - t0) / MAX_SNAPSHOTS)
    return t0 + gap * np.arange(1, max(math.ceil((t1 - t0) / gap), 1))


def write_mcap(
    lg: SonarLog,
    result: RunResult,
    path: str | Path,
    *,
    params: RunParams | None = None,
    force: bool = False,
) -> Path:
    """Write ``lg`` and ``result`` as an MCAP recording of the live view's channels.

    Parameters
    ----------
    lg : sonarlog.SonarLog
        The log the run read.
    result : RunResult
        The run's result: the last map, surfaces and quality message.
    path : path-like
        The ``.mcap`` file.
    params : RunParams, optional
        With them, map snapshots of the growing log are recorded too (the morphological
        pipeline's live accumulator); without, only the final result.
    force : bool
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    OutputExistsError
        ``path`` exists and ``force`` is False.
    ImportError
        ``foxglove-sdk`` is not installed.
    """
    import foxglove

    dest = Path(path)
    if dest.exists() and not force:
        raise OutputExistsError(f"{dest}: exists already; pass --force to overwrite")
    tmp = dest.with_name(f".{dest.name}.part")
    context = foxglove.Context()
    robot = RobotPublisher(lg.sensors, lg.speed_of_sound, context=context)
    maps = MapPublisher(context=context)
    readings = lg.readings
    try:
        with foxglove.open_mcap(tmp, allow_overwrite=True, context=context):
            ends = np.searchsorted(readings["t"], snapshot_times(readings["t"]), side="right")
            acc = LiveAccumulator(lg, params) if params is not None else None
            start = 0
            for end in [*ends.tolist(), len(readings)]:
                batch = readings[start:end]
                start = end
                if len(batch) == 0:
                    continue
                robot.readings(batch)
                if acc is not None and end < len(readings):
                    _snapshot(acc, maps, batch)
            t_end = float(readings["t"][-1]) if len(readings) else 0.0
            maps.publish(result, t=t_end, readings=len(readings), last_reading_t=t_end)
        os.replace(tmp, dest)
    finally:
        tmp.unlink(missing_ok=True)
    return dest


def _snapshot(acc: LiveAccumulator, maps: MapPublisher, batch: np.ndarray) -> None:
    try:
        acc.add(batch)
        snap = acc.snapshot()
    except (SonarprocError, ValueError) as err:  # nothing to map yet: the replay waits
        log.debug("no snapshot: %s", err)
        return
    if snap is not None:
        t = float(batch["t"][-1])
        maps.publish(snap, t=t, readings=acc.n_readings, last_reading_t=t)

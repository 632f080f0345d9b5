"""A Foxglove WebSocket server with the robot's and the map's channels on it.

:class:`LiveServer` starts the SDK's server on its own :class:`foxglove.Context` (so
nothing else in the process publishes on it), bound to loopback unless told otherwise.
The SDK sends from its own threads: :meth:`foxglove.channels.SceneUpdateChannel.log`
only queues, and a client whose queue (:data:`BACKLOG_MESSAGES`) fills loses its oldest
messages (or is disconnected if its control queue fills), so a slow or stalled viewer
never holds up the publisher.
"""

from __future__ import annotations

import math
import threading
import time
from typing import TYPE_CHECKING

import numpy as np

from sonarlog.foxglove_messages import RobotPublisher
from sonarlog.foxglove_server import BACKLOG_MESSAGES, start_server
from sonarproc.live.map_messages import MapPublisher

if TYPE_CHECKING:
    from sonarproc.pipeline import RunResult

__all__ = ["BACKLOG_MESSAGES", "LiveServer", "serve_result"]

#: How often a served, finished run checks for new subscribers (s).
CATCH_UP_POLL_S = 0.1


class LiveServer:
    """Serve a run over the Foxglove WebSocket protocol.

    Parameters
    ----------
    host, port : str, int
        Where to listen; port 0 picks a free port (see :attr:`port`).
    sensors : numpy.ndarray
        The log's ``/sensors`` table.
    speed_of_sound : float
        m/s.
    name : str
        The server name clients show.

    Raises
    ------
    ImportError
        ``foxglove-sdk`` is not installed.
    OSError
        The port cannot be bound (the SDK's error is re-raised as ``OSError``).
    """

    def __init__(
        self,
        host: str,
        port: int,
        *,
        sensors: np.ndarray,
        speed_of_sound: float,
        name: str = "sonarmorph",
    ) -> None:
        import foxglove

        self.context = foxglove.Context()
        self.robot = RobotPublisher(sensors, speed_of_sound, context=self.context)
        self.map = MapPublisher(context=self.context)
        self._lock = threading.Lock()
        self._subscribed: set[str] = set()
        self._server = start_server(name, host, port, self.context, self._note_subscription)
        self.host = host

    @property
    def port(self) -> int:
        """The port the server listens on (the chosen one when asked for 0)."""
        return int(self._server.port)

    def _note_subscription(self, topic: str) -> None:
        """Server callback (an SDK thread): note the topic, :meth:`catch_up` resends it."""
        with self._lock:
            self._subscribed.add(topic)

    def catch_up(self) -> None:
        """Resend the map's and the path's current state on newly subscribed topics."""
        with self._lock:
            topics, self._subscribed = self._subscribed, set()
        if topics:
            now = time.time()
            self.map.resend(topics, t=now)
            self.robot.resend(topics, now)

    def readings(self, rows: np.ndarray) -> None:
        """Publish new readings (beams, raw rows, pose, path, transforms)."""
        self.catch_up()
        self.robot.readings(rows)

    def result(
        self,
        result: RunResult,
        *,
        t: float,
        readings: int = 0,
        last_reading_t: float = math.nan,
        update_s: float | None = None,
    ) -> dict[str, int]:
        """Publish what changed in a run's result (see :meth:`MapPublisher.publish`)."""
        return self.map.publish(
            result, t=t, readings=readings, last_reading_t=last_reading_t, update_s=update_s
        )

    def close(self) -> None:
        """Stop the server (clients are disconnected)."""
        self._server.stop()


def serve_result(
    server: LiveServer, readings: np.ndarray, result: RunResult, stop: threading.Event
) -> None:
    """Publish a finished run once (path, last pose, transforms, map), then serve it.

    Every client that subscribes later is sent the same state (:meth:`LiveServer.catch_up`)
    until ``stop`` is set.
    """
    server.robot.readings(readings, beams=False)
    t_last = float(readings["t"][-1]) if len(readings) else time.time()
    server.result(result, t=t_last, readings=len(readings), last_reading_t=t_last)
    while not stop.wait(CATCH_UP_POLL_S):
        server.catch_up()

"""Live view and recordings for the Foxglove app: WebSocket server, MCAP export.

The robot's channels (beams, raw readings, pose, path, transforms) come from
:mod:`sonarlog.foxglove_messages`, shared with ``sonard --foxglove``; this package adds the
map's (:mod:`sonarproc.live.map_messages`), the server (:class:`LiveServer`), the loop
behind ``sonarproc watch --foxglove`` (:func:`follow_live`) and ``sonarproc export
--format mcap`` (:func:`write_mcap`). All of it needs the optional ``foxglove-sdk``
(``pip install sonarmorph[live]``); importing this package does not.
"""

from sonarproc.live.endpoint import (
    DEFAULT_HOST,
    DEFAULT_PORT,
    INSTALL_HINT,
    foxglove_missing,
    parse_endpoint,
)

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "INSTALL_HINT", "foxglove_missing", "parse_endpoint"]

"""The Foxglove WebSocket server and JSON channels that ``sonard`` and ``sonarproc`` share.

Both the acquisition process (``sonard --foxglove``) and the processing commands
(``sonarproc watch|run --foxglove``) serve their channels the same way: one server per
:class:`foxglove.Context`, a bounded backlog per client so a stalled client never holds
the publisher up, and a callback on every subscription so a late client can be sent the
current state. Needs the optional ``foxglove-sdk`` (``pip install sonarmorph[live]``).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import foxglove

__all__ = ["BACKLOG_MESSAGES", "json_channel", "start_server"]

#: Messages queued per client before the SDK drops the oldest: about 40 s of readings at
#: 25 readings/s with two messages each; a map update adds a few.
BACKLOG_MESSAGES = 2048


def start_server(
    name: str,
    host: str,
    port: int,
    context: foxglove.Context,
    on_subscribe: Callable[[str], None],
) -> Any:
    """Serve ``context``'s channels at ``host:port``; ``on_subscribe(topic)`` on subscribe.

    Raises
    ------
    OSError
        The port cannot be bound (the SDK's own error, re-raised as the built-in it is).
    """
    import foxglove
    from foxglove.websocket import ChannelView, Client, ServerListener

    class Subscriptions(ServerListener):
        def on_subscribe(self, client: Client, channel: ChannelView) -> None:
            on_subscribe(str(channel.topic))

    try:
        return foxglove.start_server(
            name=name,
            host=host,
            port=port,
            context=context,
            message_backlog_size=BACKLOG_MESSAGES,
            server_listener=Subscriptions(),
        )
    except Exception as exc:  # the SDK raises its own error type for a bind failure
        raise OSError(f"cannot listen on {host}:{port}: {exc}") from exc


def json_channel(
    topic: str, schema_name: str, schema: dict[str, Any], context: foxglove.Context | None
) -> Any:
    """A channel of JSON messages described by a JSON Schema (``schema_name``)."""
    import foxglove

    return foxglove.Channel(
        topic,
        schema=foxglove.Schema(
            name=schema_name, encoding="jsonschema", data=json.dumps(schema).encode()
        ),
        message_encoding="json",
        context=context,
    )

"""A Foxglove WebSocket protocol client for the tests (``websockets``, no SDK).

Speaks the Foxglove WebSocket protocol (the ws-protocol spec, v1 messages). It offers
both subprotocol names: ``foxglove.websocket.v1`` (the spec's) and ``foxglove.sdk.v1``
(the name the Foxglove SDK's server has accepted since 0.18, with the same messages).
It reads the server's JSON ``serverInfo`` and ``advertise`` messages, subscribes to
every advertised channel, and decodes the binary message-data frames (opcode 1,
``uint32`` subscription id, ``uint64`` log time in ns, payload, little-endian) with
each channel's schema: JSON as JSON, protobuf with :class:`protowire.ProtoSchema`
built from the advertised ``FileDescriptorSet``.
"""

from __future__ import annotations

import asyncio
import base64
import json
import os
import socket
import struct
import time
from dataclasses import dataclass, field
from typing import Any

from protowire import ProtoSchema

SUBPROTOCOLS = ("foxglove.websocket.v1", "foxglove.sdk.v1")
OP_MESSAGE_DATA = 1


@dataclass
class Received:
    """One message; :attr:`data` decodes it (on first use: receiving stays fast)."""

    topic: str
    log_time_ns: int
    received: float  # time.time() when it arrived
    payload: bytes
    decoder: Any = field(repr=False, default=None)
    _data: Any = field(repr=False, default=None)

    @property
    def data(self) -> Any:
        """The decoded message (a dict)."""
        if self._data is None:
            self._data = self.decoder(self.payload)
        return self._data


@dataclass
class Session:
    """What a client saw: the advertised channels and the decoded messages."""

    server_info: dict[str, Any] = field(default_factory=dict)
    channels: dict[int, dict[str, Any]] = field(default_factory=dict)
    messages: list[Received] = field(default_factory=list)

    def on(self, topic: str) -> list[Received]:
        """The messages received on ``topic``, in order."""
        return [m for m in self.messages if m.topic == topic]

    def topics(self) -> dict[str, dict[str, Any]]:
        """Advertised channels by topic."""
        return {c["topic"]: c for c in self.channels.values()}


def _decoder(channel: dict[str, Any]) -> Any:
    if channel["encoding"] == "json":
        return lambda payload: json.loads(bytes(payload))
    if channel["encoding"] == "protobuf":
        schema = ProtoSchema(base64.b64decode(channel["schema"]))
        name = channel["schemaName"]
        return lambda payload: schema.decode(name, bytes(payload))
    raise AssertionError(f"unexpected encoding {channel['encoding']!r}")


async def collect(
    url: str,
    *,
    seconds: float,
    until: Any = None,
    expect_topics: int = 0,
    on_message: Any = None,
    subscribe_last: str | None = None,
) -> Session:
    """Connect, subscribe to every channel, and decode messages for ``seconds``.

    ``until(session)`` returning True ends it earlier. Channels advertised later are
    subscribed to as they come; ``expect_topics`` waits (within ``seconds``) for that many.
    ``on_message(message)`` is called with each message as it arrives (from the thread
    running the client: a test collecting in a thread learns what arrived, and when).
    ``subscribe_last`` names a topic subscribed to in a message of its own, after the
    subscription to the rest of its advertisement: a server handles one client's messages
    in order, so a message on that topic shows the other subscriptions are in place.
    """
    import websockets
    from websockets.exceptions import ConnectionClosed

    session = Session()
    decoders: dict[int, Any] = {}
    sub_topic: dict[int, int] = {}
    next_sub = 1
    deadline = time.monotonic() + seconds
    protocols = [websockets.Subprotocol(p) for p in SUBPROTOCOLS]
    async with websockets.connect(url, subprotocols=protocols, max_size=None) as ws:
        assert ws.subprotocol in SUBPROTOCOLS
        while time.monotonic() < deadline:
            try:
                frame = await asyncio.wait_for(ws.recv(), timeout=deadline - time.monotonic())
            except (TimeoutError, ConnectionClosed):  # time is up, or the server stopped
                break
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg["op"] == "serverInfo":
                    session.server_info = msg
                elif msg["op"] == "advertise":
                    subs, last = [], []
                    for ch in msg["channels"]:
                        session.channels[ch["id"]] = ch
                        decoders[ch["id"]] = _decoder(ch)
                        sub_topic[next_sub] = ch["id"]
                        sub = {"id": next_sub, "channelId": ch["id"]}
                        (last if ch["topic"] == subscribe_last else subs).append(sub)
                        next_sub += 1
                    for batch in (subs, last):
                        if batch:
                            await ws.send(json.dumps({"op": "subscribe", "subscriptions": batch}))
                continue
            frame = bytes(frame)
            if frame[0] != OP_MESSAGE_DATA:
                continue
            sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
            channel_id = sub_topic[sub_id]
            topic = session.channels[channel_id]["topic"]
            received = Received(topic, log_time, time.time(), frame[13:], decoders[channel_id])
            session.messages.append(received)
            if on_message is not None:
                on_message(received)
            if until is not None and len(session.channels) >= expect_topics and until(session):
                break
    return session


def collect_sync(url: str, **kwargs: Any) -> Session:
    """:func:`collect` from synchronous code."""
    return asyncio.run(collect(url, **kwargs))


def stalled_client(url: str) -> socket.socket:
    """Connect, subscribe to every channel advertised at once, then never read again.

    A bare socket speaking just enough WebSocket (RFC 6455: the upgrade request, the
    server's unmasked frames, one masked text frame): the server's queue for it fills,
    and the server must drop messages or the client, not wait for it. Close it at the
    end of the test.
    """
    host, port = url.removeprefix("ws://").rsplit(":", 1)
    sock = socket.create_connection((host, int(port)), timeout=10.0)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall(
        (
            f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
            f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
            f"Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: {', '.join(SUBPROTOCOLS)}"
            "\r\n\r\n"
        ).encode()
    )
    buf = b""
    while b"\r\n\r\n" not in buf:
        buf += sock.recv(4096)
    head, buf = buf.split(b"\r\n\r\n", 1)
    assert head.startswith(b"HTTP/1.1 101"), head
    channels: list[dict[str, Any]] = []
    while not channels:
        while True:
            frame = _frame(buf)
            if frame is not None:
                break
            buf += sock.recv(65536)
        opcode, payload, buf = frame
        if opcode == 1 and json.loads(payload)["op"] == "advertise":
            channels = json.loads(payload)["channels"]
    subs = [{"id": i + 1, "channelId": ch["id"]} for i, ch in enumerate(channels)]
    sock.sendall(_masked_text(json.dumps({"op": "subscribe", "subscriptions": subs}).encode()))
    return sock


def _frame(buf: bytes) -> tuple[int, bytes, bytes] | None:
    """``(opcode, payload, rest)`` of the first complete server frame in ``buf``, or None."""
    if len(buf) < 2:
        return None
    n, at = buf[1] & 0x7F, 2
    if n == 126:
        if len(buf) < 4:
            return None
        n, at = struct.unpack_from(">H", buf, 2)[0], 4
    elif n == 127:
        if len(buf) < 10:
            return None
        n, at = struct.unpack_from(">Q", buf, 2)[0], 10
    if len(buf) < at + n:
        return None
    return buf[0] & 0x0F, buf[at : at + n], buf[at + n :]


def _masked_text(payload: bytes) -> bytes:
    mask = os.urandom(4)
    n = len(payload)
    head = bytes([0x81]) + (
        bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + struct.pack(">H", n)
    )
    return head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(payload))


if __name__ == "__main__":  # a client process a test can kill: python foxglove_client.py URL
    import sys

    collect_sync(sys.argv[1], seconds=float(sys.argv[2]) if len(sys.argv) > 2 else 60.0)

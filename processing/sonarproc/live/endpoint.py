"""Where a live view listens (``[HOST:]PORT``) and whether the Foxglove SDK is installed."""

from __future__ import annotations

import importlib.util

from sonarproc.errors import ParameterError

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "INSTALL_HINT", "foxglove_missing", "parse_endpoint"]

#: Loopback only by default: exposing the port to a network is an explicit choice.
DEFAULT_HOST = "127.0.0.1"
#: The Foxglove app's default WebSocket port.
DEFAULT_PORT = 8765
INSTALL_HINT = "--foxglove needs the Foxglove SDK: pip install 'sonarmorph[live]'"


def foxglove_missing() -> bool:
    """Whether ``foxglove-sdk`` is not installed (the live view and MCAP export need it)."""
    return importlib.util.find_spec("foxglove") is None


def parse_endpoint(text: str, *, option: str = "--foxglove") -> tuple[str, int]:
    """``"HOST:PORT"``, ``"PORT"`` or ``""`` as ``(host, port)``; port 0 picks a free one.

    Raises
    ------
    ParameterError
        Not a port in 0..65535, or an empty host.

    Examples
    --------
    >>> parse_endpoint("8765"), parse_endpoint("0.0.0.0:0"), parse_endpoint("")
    (('127.0.0.1', 8765), ('0.0.0.0', 0), ('127.0.0.1', 8765))
    >>> parse_endpoint("[::1]:9000")
    ('::1', 9000)
    """
    text = text.strip()
    if not text:
        return DEFAULT_HOST, DEFAULT_PORT
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host = DEFAULT_HOST
    host = host.strip("[]")
    if sep and not host:
        raise ParameterError(option, f"needs a host before ':', got {text!r}")
    try:
        port = int(port_text)
    except ValueError:
        raise ParameterError(
            option, f"must be [HOST:]PORT with PORT 0..65535, got {text!r}"
        ) from None
    if not 0 <= port <= 65535:
        raise ParameterError(option, f"port must be 0..65535 (0: a free one), got {port}")
    return host, port

"""Where a live view listens (``[HOST:]PORT``) and whether the Foxglove SDK is installed."""

from __future__ import annotations

import importlib.util

from sonarlog.foxglove_messages import parse_endpoint as _parse
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
    """
    if not text.strip():
        return DEFAULT_HOST, DEFAULT_PORT
    try:
        return _parse(text, default_host=DEFAULT_HOST)
    except ValueError as err:
        raise ParameterError(option, str(err)) from None

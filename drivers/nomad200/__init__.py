"""Nomad 200 robot: packet codec, serial client and an emulated robot.

Importing this package registers the emulator's ``nomad://`` pyserial URL scheme (see
:mod:`nomad200.protocol_nomad`).
"""

import serial as _serial

from nomad200.client import Client, open_clients
from nomad200.codec import Cmd, MvMode, Packet
from nomad200.errors import (
    NomadDisconnected,
    NomadError,
    NomadNak,
    NomadPortBusy,
    NomadProtocolError,
    NomadTimeout,
)
from nomad200.state import Configuration, PoseAttachment, SonarScan, State, StateMask

if "nomad200" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("nomad200")

__all__ = [
    "Client",
    "Cmd",
    "Configuration",
    "MvMode",
    "NomadDisconnected",
    "NomadError",
    "NomadNak",
    "NomadPortBusy",
    "NomadProtocolError",
    "NomadTimeout",
    "Packet",
    "PoseAttachment",
    "SonarScan",
    "State",
    "StateMask",
    "open_clients",
]

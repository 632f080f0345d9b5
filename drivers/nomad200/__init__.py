"""Nomad 200 robot: packet codec, serial client and an emulated robot.

The robot's fixed facts live here once: :data:`BAUD_RATES` (the serial line speeds) and
:mod:`nomad200.ring` (the sonar ring geometry in SI units).

Importing this package registers the emulator's ``nomad://`` pyserial URL scheme (see
:mod:`nomad200.protocol_nomad`).
"""

import serial as _serial

from nomad200 import ring
from nomad200.client import Client, open_clients
from nomad200.codec import BAUD_RATES, BaudRate, Cmd, MvMode, Packet
from nomad200.errors import (
    NomadDisconnected,
    NomadError,
    NomadNak,
    NomadPortBusy,
    NomadProtocolError,
    NomadTimeout,
)
from nomad200.mask import POSE_FIELDS, VELOCITY_FIELDS, StateMask
from nomad200.replies import Configuration, SonarScan
from nomad200.state import PoseAttachment, State

if "nomad200" not in _serial.protocol_handler_packages:
    _serial.protocol_handler_packages.append("nomad200")

__all__ = [
    "BAUD_RATES",
    "POSE_FIELDS",
    "VELOCITY_FIELDS",
    "BaudRate",
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
    "ring",
]

"""sonarlog v1: the HDF5 log of pose-tagged sonar time-of-flight readings.

The format is sonarlog v1 (docs/formats.md). :class:`LogWriter` appends crash-safely (SWMR, batched
writes, a flush + fsync at least every half second); :func:`read_log` validates, recovers the
intact prefix of a damaged file and computes transducer world poses in one vectorised call.
"""

from sonarlog.acoustics import speed_of_sound_at
from sonarlog.errors import InvalidLogError, SonarLogError
from sonarlog.reader import SonarLog, TransducerPoses, read_log
from sonarlog.recover import RecoveryReport, default_recovered_path, recover_log
from sonarlog.schema import (
    DEFAULT_SPEED_OF_SOUND,
    EVENT_DTYPE,
    FLAG_CROSSTALK,
    FLAG_NO_ECHO,
    FORMAT,
    FORMAT_VERSION,
    POSE_DTYPE,
    READING_DTYPE,
    SENSOR_DTYPE,
    empty_readings,
)
from sonarlog.superblock import writer_closed
from sonarlog.writer import LogWriter

__all__ = [
    "DEFAULT_SPEED_OF_SOUND",
    "EVENT_DTYPE",
    "FLAG_CROSSTALK",
    "FLAG_NO_ECHO",
    "FORMAT",
    "FORMAT_VERSION",
    "POSE_DTYPE",
    "READING_DTYPE",
    "SENSOR_DTYPE",
    "InvalidLogError",
    "LogWriter",
    "RecoveryReport",
    "SonarLog",
    "SonarLogError",
    "TransducerPoses",
    "default_recovered_path",
    "empty_readings",
    "read_log",
    "recover_log",
    "speed_of_sound_at",
    "writer_closed",
]

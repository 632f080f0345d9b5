"""sonarlog v1: the HDF5 log of pose-tagged sonar time-of-flight readings.

The format is sonarlog v1 (docs/formats.md). :class:`LogWriter` appends crash-safely
(SWMR, batched writes, a flush + fsync at least every half second); :func:`read_log`
validates, recovers the intact prefix of a damaged file, says how the file ended
(:attr:`SonarLog.log_state`, :meth:`SonarLog.integrity_warning`) and computes transducer
world poses in one vectorised call.
"""

from sonarlog.acoustics import speed_of_sound_at
from sonarlog.errors import InvalidLogError, SonarLogError
from sonarlog.reader import SonarLog, TransducerPoses, read_log
from sonarlog.recover import (
    RecoveryReport,
    default_recovered_path,
    finalise_crashed_log,
    recover_log,
)
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
from sonarlog.state import CRASHED_ATTR, LogState, SuperblockInfo, read_superblock, writer_closed
from sonarlog.writer import LogWriter

__all__ = [
    "CRASHED_ATTR",
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
    "LogState",
    "LogWriter",
    "RecoveryReport",
    "SonarLog",
    "SonarLogError",
    "SuperblockInfo",
    "TransducerPoses",
    "default_recovered_path",
    "empty_readings",
    "finalise_crashed_log",
    "read_log",
    "read_superblock",
    "recover_log",
    "speed_of_sound_at",
    "writer_closed",
]

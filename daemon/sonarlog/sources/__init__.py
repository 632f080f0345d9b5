"""Logs from the robots people have: ROS 1 and ROS 2 bags and Player logs in, ROS 2 bags out.

Reading gives an in-memory :class:`sonarlog.SonarLog` and an :class:`ImportSummary`::

    log, summary = read_source("pioneer.bag", robot="pioneer3-dx")
    import_to_sonarlog("pioneer.bag", "pioneer.h5", robot="pioneer3-dx")
    for row in list_source("pioneer.bag"): ...

:func:`write_rosbag2` writes a log (and fitted surfaces) as a ROS 2 bag for RViz or
Foxglove. Sonar topics, odometry and mounts are found automatically (see
:mod:`sonarlog.sources.rosbag`); robot presets are in :mod:`sonarlog.sources.presets`.

The names below are imported from their modules when first used: a readings CSV needs
only the presets and the range checks, not the bag and Player readers.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sonarlog.sources.dispatch import (
        SourceFormat,
        detect_format,
        import_to_sonarlog,
        list_source,
        read_source,
        register_format,
        source_formats,
        write_sonarlog,
    )
    from sonarlog.sources.errors import OutputExistsError, SourceError
    from sonarlog.sources.presets import SensorSet, load_sensors, preset_names
    from sonarlog.sources.rosbag_out import RosbagExport, write_rosbag2
    from sonarlog.sources.summary import ImportCounts, ImportOptions, ImportSummary, TopicRow

__all__ = [
    "ImportCounts",
    "ImportOptions",
    "ImportSummary",
    "OutputExistsError",
    "RosbagExport",
    "SensorSet",
    "SourceError",
    "SourceFormat",
    "TopicRow",
    "detect_format",
    "import_to_sonarlog",
    "list_source",
    "load_sensors",
    "preset_names",
    "read_source",
    "register_format",
    "source_formats",
    "write_rosbag2",
    "write_sonarlog",
]

# the module of each public name
_HOME = {
    "SourceFormat": "dispatch",
    "detect_format": "dispatch",
    "import_to_sonarlog": "dispatch",
    "list_source": "dispatch",
    "read_source": "dispatch",
    "register_format": "dispatch",
    "source_formats": "dispatch",
    "write_sonarlog": "dispatch",
    "OutputExistsError": "errors",
    "SourceError": "errors",
    "SensorSet": "presets",
    "load_sensors": "presets",
    "preset_names": "presets",
    "RosbagExport": "rosbag_out",
    "write_rosbag2": "rosbag_out",
    "ImportCounts": "summary",
    "ImportOptions": "summary",
    "ImportSummary": "summary",
    "TopicRow": "summary",
}


def __getattr__(name: str) -> Any:
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{home}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))

"""Echoes under the transducer physics: specular, corner and edge, thresholded, time-walked.

For each monostatic channel (a transducer that fires and listens) the candidates are the
specular echoes of every surface (planes, curves and cylinders, whose reflection point
is the one facing the sensor) found by the geometric search with the beam widened to
:func:`sonarsim.transducer.search_half_angle`, plus the point echoes of
:mod:`sonarsim.reflectors`. Occlusion is applied to both (a nearer surface blocks the
path). Each candidate's amplitude (:func:`sonarsim.transducer.amplitude`) must clear the
threshold; its range reads long by the time walk; the ranging board reports the first
echo above the threshold (Kleeman & Kuc 1995), which :mod:`sonarsim.simulation`
selects after the receiver's blanking (``min_range``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sonarsim.geometry import FloatArray, wrap_angle
from sonarsim.reflectors import point_echoes
from sonarsim.search import pair_echoes
from sonarsim.specular import Sensors
from sonarsim.surfaces import Circle
from sonarsim.transducer import TransducerParams, amplitude, search_half_angle, time_walk
from sonarsim.world import World

IntArray = NDArray[np.intp]


def cylinder_divergence(world: World, surface: IntArray, r: FloatArray) -> FloatArray:
    """Echo strength of a cylinder relative to a plane at the same range: ``R / (R + r)``.

    A convex mirror of radius ``R`` widens a horizontal ray tube of the pulse by
    ``1 + 2 r / R`` on reflection, so after the round trip the tube is
    ``2 r (1 + r / R)`` wide instead of a plane's ``2 r``; vertically a cylinder is flat.
    1 for every other surface (curved walls' focusing is not modelled).
    """
    radius = np.array([s.radius if isinstance(s, Circle) else 0.0 for s in world.surfaces])
    rad = radius[surface] if surface.size else np.zeros(0)
    cyl = rad > 0.0
    return np.asarray(np.where(cyl, rad / np.where(cyl, rad + r, 1.0), 1.0))


@dataclass(frozen=True)
class HeardEchoes:
    """Echoes above the threshold: channel, path (m, time walk included), surface."""

    channel: IntArray
    path: FloatArray
    surface: IntArray


def transducer_echoes(
    world: World, sensors: Sensors, inst: IntArray, params: TransducerParams,
    speed_of_sound: float,
) -> HeardEchoes:  # fmt: skip
    """All echoes above the threshold on monostatic channels ``inst`` (rows of ``sensors``).

    Returns
    -------
    HeardEchoes
        ``channel`` indexes ``inst``; paths include twice the time-walk range bias.
    """
    c = speed_of_sound
    rmin = float(sensors.min_range.min(initial=0.0)) if len(sensors) else 0.0
    search = search_half_angle(params, rmin, c)
    wide = Sensors(
        sensors.xy, sensors.heading, np.full(len(sensors), search), sensors.min_range,
        sensors.max_range,
    )  # fmt: skip
    ev = pair_echoes(world, wide, inst, inst, max_order=1)
    s_xy = sensors.xy[inst[ev.firing]]
    rel = ev.point - s_xy
    theta = np.abs(wrap_angle(np.arctan2(rel[:, 1], rel[:, 0]) - sensors.heading[inst[ev.firing]]))
    a_spec = amplitude(theta, theta, 0.5 * ev.path, params.plane_reflectivity, 2.0, params, c)
    a_spec = a_spec * cylinder_divergence(world, ev.surface, 0.5 * ev.path)
    ok = a_spec >= params.threshold
    pts = point_echoes(world, world.segments, sensors, inst, params, c, search)
    channel = np.concatenate([ev.firing[ok], pts.channel])
    path = np.concatenate([ev.path[ok], pts.path])
    amp = np.concatenate([a_spec[ok], pts.amp])
    surface = np.concatenate([ev.surface[ok], pts.surface])
    path = path + 2.0 * time_walk(amp, params, c)
    return HeardEchoes(channel.astype(np.intp), path, surface.astype(np.intp))

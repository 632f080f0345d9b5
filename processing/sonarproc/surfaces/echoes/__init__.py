"""Echo geometry: where each reading's echo came from, and the fits refined through it.

:mod:`.specular` is the one implementation of echo points (the foot of a reading on a
surface and the point at the measured range along it), used by the surface refit and by
``--auto``; :mod:`.tangents` finds walls from the readings' tangent votes;
:mod:`.screen`, :mod:`.occlusion` and :mod:`.dirbins` judge fits by the readings they
explain or contradict; :mod:`.refine` refits every surface through its echo points.
"""

"""Odometry drift correction: a smooth correction of the pose track from the echoes.

A robot's odometry drifts: after tens of metres the same wall, seen again, appears
offset by tens of centimetres, and the map shows it twice. This package estimates a
smooth correction of the logged poses so that echoes of the same wall seen at different
times agree, before any surface is mapped:

1. the track is parametrised by travel (distance plus turn) and correction nodes are
   placed about every metre of it (2 or 3 m where the echoes are too few for 1 m:
   :func:`align_poses`; :mod:`~sonarproc.align.track`); each reading's
   correction interpolates its two nodes' (the heading by travel, the position by
   distance driven);
2. every usable reading gives a line-of-sight echo point (:mod:`~sonarproc.align.echoes`);
3. echo points are matched to local lines of the echo points of *other* stretches of
   the track (:mod:`~sonarproc.align.matching`, :class:`scipy.spatial.cKDTree`);
4. a pose graph, odometry ties between consecutive nodes plus the matched echoes'
   point-to-line distances, is solved by :func:`scipy.optimize.least_squares` with a
   robust loss and a sparse Jacobian (:mod:`~sonarproc.align.graph`); matching and
   solving alternate until the correction settles.

:func:`align_poses` returns an :class:`Alignment` (corrected poses, raw and corrected
paths, how far they differ, cost before and after); :func:`corrected_readings` applies
it to a copy of the readings.
"""

from sonarproc.align.poses import Alignment, align_poses, align_readings, corrected_readings

__all__ = ["Alignment", "align_poses", "align_readings", "corrected_readings"]

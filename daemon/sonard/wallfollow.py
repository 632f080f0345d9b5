"""Wall following with the side sonar, for room runs like the paper's Fig. 21.

The robot drives in velocity mode (VM) with the turret turning with the base, so the side
sonar (4 on the left, 12 on the right) keeps looking square to the path. Each side echo
becomes a wall point in the odometry frame (from the firing pose of the reading); a line
fitted through the points of the last ``WINDOW_M`` metres of path gives the wall direction
and the robot's distance to it. Distances are measured from the robot centre (range from
the transducer face + ring radius). The heading command is the wall direction plus a
correction proportional to the distance error (``gain`` rad/m, at most ``MAX_CUT``), and
the turn rate steers towards that heading.

When the front sonar (0, and 1 / 15 when they fire) sees an obstacle closer than the
follow distance plus ``CORNER_MARGIN``, the robot stops and turns 90 degrees away from the
wall (an inside corner), then follows the new wall. Without side echoes (a doorway, an
outside edge) it keeps the last wall direction. The step ends after ``length`` metres of
path; the path driven survives a link fault (the step resumes).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from sonard.acquisition import Acquisition
from sonard.motion import NO_PROGRESS_S, MotionError, turn_to, wrap
from sonard.plan import Plan
from sonard.plan_steps import FRONT_SONAR, WallFollow
from sonard.ring import RING_RADIUS

__all__ = ["WallFollower"]

WINDOW_M = 0.6
MAX_CUT = math.radians(20.0)
HEADING_GAIN = 1.5  # rad/s per rad of heading error
CORNER_MARGIN = 0.25
RESEND_S = 0.5
#: path length that counts as progress (m): the driving speed is at least 0.02 m/s, so the
#: robot covers it in under a second of robot time (see sonard.motion.NO_PROGRESS_S)
PROGRESS_M = 0.01
_FRONT_SET = (FRONT_SONAR, 1, 15)


class WallFollower:
    """State of one wall-follow step (path driven, wall points, wall direction)."""

    def __init__(self, step: WallFollow, plan: Plan) -> None:
        self.step = step
        self.plan = plan
        self.sign = 1.0 if step.side == "left" else -1.0
        self.travelled = 0.0
        self.points: deque[tuple[float, float, float]] = deque()
        self.wall_dir: float | None = None
        self._last_xy: tuple[float, float] | None = None
        self._front = {s for s in _FRONT_SET if s in plan.sonars}
        self._ahead: dict[int, float] = {}

    def _update_path(self, st: Any) -> None:
        xy = (st.x, st.y)
        if self._last_xy is not None:
            self.travelled += math.hypot(xy[0] - self._last_xy[0], xy[1] - self._last_xy[1])
        self._last_xy = xy

    def _add_wall_points(self, acq: Acquisition) -> None:
        rows = acq.latest
        if not len(rows):
            return
        sel = rows[(rows["rx"] == self.step.side_sonar) & (rows["flags"] == 0)]
        if not len(sel):
            return
        r = sel["tof"] * self.plan.speed_of_sound / 2 + RING_RADIUS
        bearing = sel["turret"] + self.sign * math.pi / 2
        px = sel["x"] + r * np.cos(bearing)
        py = sel["y"] + r * np.sin(bearing)
        for x, y in zip(px.tolist(), py.tolist(), strict=True):
            self.points.append((self.travelled, x, y))
        while self.points and self.points[0][0] < self.travelled - WINDOW_M:
            self.points.popleft()

    def _update_front(self, acq: Acquisition) -> None:
        """Keep the newest range ahead (m from the centre) per front sonar."""
        rows = acq.latest
        for s in self._front:
            sel = rows[rows["rx"] == s] if len(rows) else rows
            if len(sel):
                last = sel[-1]
                r = math.inf if last["flags"] else float(last["tof"]) * self.plan.speed_of_sound / 2
                cosine = 1.0 if s == FRONT_SONAR else math.cos(math.radians(22.5))
                self._ahead[s] = r * cosine + RING_RADIUS

    def _wall_estimate(self, st: Any) -> tuple[float, float] | None:
        """(wall direction, distance error) from the wall points, or None."""
        if len(self.points) < 3:
            return None
        pts = np.array([(x, y) for _, x, y in self.points])
        centre = pts.mean(axis=0)
        _, _, vt = np.linalg.svd(pts - centre, full_matrices=False)
        u = vt[0]
        if u[0] * math.cos(st.steer) + u[1] * math.sin(st.steer) < 0:
            u = -u
        spread = float(np.ptp((pts - centre) @ u))
        if spread < 0.1:
            return None
        d = abs(u[0] * (st.y - centre[1]) - u[1] * (st.x - centre[0]))
        return math.atan2(u[1], u[0]), d - self.step.distance

    def run(self, acq: Acquisition) -> None:
        """Drive until ``length`` metres of path are done (resumable)."""
        s = self.step
        st = acq.poll()
        # the side sonar must look square to the path: turret along the steering
        if abs(wrap(st.turret - st.steer)) > math.radians(0.5):
            acq.set_speed(s.speed, s.turn_speed, s.turn_speed)
            turn_to(acq, None, st.steer, s.turn_speed)
        self._last_xy = None
        self.points.clear()
        last_cmd: tuple[float, float] | None = None
        last_sent = -math.inf
        mark = (self.travelled, float(st.clock))  # progress: path length at a robot time
        while self.travelled < s.length:
            st = acq.poll()
            self._update_path(st)
            if self.travelled > mark[0] + PROGRESS_M or st.clock < mark[1]:
                mark = (self.travelled, float(st.clock))
            elif st.clock - mark[1] > NO_PROGRESS_S:
                raise MotionError(
                    f"wall following made no progress for {NO_PROGRESS_S:g} s of robot time "
                    f"({self.travelled:.2f} of {s.length:g} m done)"
                )
            self._add_wall_points(acq)
            self._update_front(acq)
            if self.wall_dir is None:
                self.wall_dir = st.steer
            if min(self._ahead.values(), default=math.inf) < s.distance + CORNER_MARGIN:
                acq.stop()
                acq.set_speed(s.speed, s.turn_speed, s.turn_speed)
                turn = wrap(st.steer - self.sign * math.pi / 2)
                turn_to(acq, turn, wrap(turn + st.turret - st.steer), s.turn_speed)
                self.points.clear()
                self._ahead.clear()
                self.wall_dir = turn
                self._last_xy = None
                last_cmd = None
                mark = (self.travelled, float(acq.state.clock))  # the turn was progress
                continue
            est = self._wall_estimate(st)
            err = 0.0
            if est is not None:
                self.wall_dir, err = est
            cut = max(-MAX_CUT, min(MAX_CUT, s.gain * err))
            want = self.wall_dir + self.sign * cut
            w = max(-s.turn_speed, min(s.turn_speed, HEADING_GAIN * wrap(want - st.steer)))
            cmd = (s.speed, round(w, 3))
            now = st.clock  # robot time: an emulator in fast mode runs it ahead of ours
            if cmd != last_cmd or now - last_sent > RESEND_S:
                acq.move_velocity(s.speed, w, w)
                last_cmd, last_sent = cmd, now
        acq.stop()

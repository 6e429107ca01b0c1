"""The robot at its own traffic signals: stop on red (then turn right on red), stop or go on yellow.

Every signal line its route crosses (sim/signal_rules.route_signal_lines) is, in turn, a wall
for its front bumper while its head demands a stop, by the state the robot last read from it
in its own observation (red if it has never read it):

* green: no wall;
* yellow: a wall if it can stop at a comfortable deceleration (sim/signal_rules.must_stop),
  else it goes on through that line even if the head turns red before it gets there;
* red: a wall; where its route turns right just after the line (by more than
  RIGHT_TURN_MIN_RAD within RIGHT_TURN_LOOKAHEAD_M) right turn on red is allowed: once it has
  come to rest for the line (the stop-sign rule, agents/robot/stop.stopped_at_line: at the line
  or, as the first car, a few metres short of it) the wall is lifted and it goes when the cross traffic lets it (its right-of-way claims, in the MPC).

A line the robot's front has passed by more than `near_m` is behind it; one it has passed while
moving (it could not stop) it does not stop for in the middle of the junction.
"""

from __future__ import annotations

import numpy as np

from marl_social.agents.robot.stop import StopSignConfig, stop_wall, stopped_at_line
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.signal_rules import must_stop, route_signal_lines
from marl_social.sim.signals import RED, YELLOW

RIGHT_TURN_LOOKAHEAD_M = 25.0  # how far past the line a right turn counts [m]
RIGHT_TURN_MIN_RAD = np.radians(45.0)  # heading change to the right that makes a right turn
# within near_m of the line and at most this fast, the wall moves to where braking at
# SETTLE_DECEL_MPS2 brings its front: it comes to rest there (the plan's last creep towards
# the line would keep it above the rest speed) [m/s]
SETTLE_SPEED_MPS = 1.0
SETTLE_DECEL_MPS2 = 1.0  # [m/s^2]


def turns_right_after(route: Route, s_m: float) -> bool:
    """Whether the route turns right by RIGHT_TURN_MIN_RAD within RIGHT_TURN_LOOKAHEAD_M of s_m."""
    s = np.linspace(s_m, min(s_m + RIGHT_TURN_LOOKAHEAD_M, route.length_m), 26)
    _, heading = route.point_at(s)
    turn = np.unwrap(heading)
    return bool(np.min(turn - turn[0]) <= -RIGHT_TURN_MIN_RAD)


class SignalStops:
    """The robot's signal lines and what its own heads demand (module docstring).

    Args:
        route: the robot's route.
        road_map: the static map (stop lines, lanes, signal heads).
        robot_length_m: its length [m].
        config: when it counts as having stopped (the stop-sign rule).
    """

    def __init__(self, route: Route, road_map: RoadMap, robot_length_m: float,
                 config: StopSignConfig | None = None):
        self.config = config or StopSignConfig()
        self.lines_m, self.heads = route_signal_lines(route, road_map)
        self.right_on_red = np.array([turns_right_after(route, s) for s in self.lines_m],
                                     dtype=bool)
        self._half = 0.5 * robot_length_m
        self.reset()

    def reset(self) -> None:
        """A new episode: no head read yet, no line served."""
        self.seen: dict[int, int] = {}
        self.rest_s = 0.0
        self._served: set[int] = set()  # lines it has stopped at (right turn on red)
        self._go: set[int] = set()  # lines it passes on yellow

    def update(self, s0: float, v0: float, dt_s: float, signal_states: dict) -> float:
        """Read its heads; the arc length its centre must stay behind [m] (inf: none).

        Called once per planning step.

        Args:
            s0: its arc length along its route (footprint centre) [m].
            v0: its speed [m/s].
            dt_s: time since the last call [s].
            signal_states: {head index: state} of the heads it reads now (its observation).
        """
        self.seen.update(signal_states)
        if not len(self.lines_m):  # no signal line on its route
            return np.inf
        c = self.config
        front = s0 + self._half
        due = np.flatnonzero(self.lines_m + c.near_m >= front)
        if not len(due):
            return np.inf
        k = int(due[0])
        line = float(self.lines_m[k])
        state = self.seen.get(int(self.heads[k]), RED)
        if k in self._go or k in self._served:
            return np.inf
        if not must_stop(state, v0, line - front):  # green, or a yellow too late to stop for
            if state == YELLOW:
                self._go.add(k)
            return np.inf
        if front > line and v0 >= c.rest_mps:  # over the line already: it does not stop inside
            return np.inf
        wall = line
        if abs(line - front) <= c.near_m and v0 <= SETTLE_SPEED_MPS:
            # close and slow: it comes to rest where a gentle stop brings it
            wall = min(line, front + v0 * v0 / (2.0 * SETTLE_DECEL_MPS2))
        if state == RED and self.right_on_red[k]:
            if stopped_at_line(line, front, v0, c):
                self.rest_s += dt_s
            else:
                self.rest_s = 0.0
            if self.rest_s >= c.hold_s:
                self._served.add(k)
                self.rest_s = 0.0
                return np.inf
            wall = min(wall, stop_wall(line, front, self.rest_s > 0.0, c))
        return wall - self._half

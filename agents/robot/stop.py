"""Stop signs on the robot's route: stop at the line, wait at rest, then go.

Every stop line of kind "stop_sign" that the robot's route crosses (RoadMap.stop_lines; one
with a lane index counts only where the route runs the way that lane does) is, in turn, a wall
for the robot's front bumper at the line, until the robot has come to rest there: slower than
`rest_mps` for `hold_s` with its front within `near_m` past the line and at most `pull_up_m`
short of it (`stopped_at_line`: a complete stop behind the line, as the first car at it, is the
stop the line demands; a robot that has stopped a few metres short completes its stop where it
stands and then goes, it does not creep up and stop a second time). Then the line is cleared
and the robot goes; what else it plans for (tracked objects, hidden-pedestrian
hypotheses, pedestrians at a crosswalk) still holds, in the MPC. A line the robot's front has
passed by more than `near_m` without stopping (it could not stop: it started too close) is
behind it: the robot does not stop in the middle of the junction.

Lines of kind "signal" are not handled here: a signal's state is not part of the static map;
agents/robot/signal_stop.py obeys them by the head the robot reads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.sim.road_map import RoadMap, Route


@dataclass(frozen=True)
class StopSignConfig:
    """When the robot counts as having stopped at a stop line.

    Attributes:
        near_m: its front bumper within this of the line (either side) is at the line [m].
        rest_mps: slower than this [m/s].
        hold_s: for at least this long [s].
        pull_up_m: a robot at rest with its front at most this far short of the line has
            stopped for it (`stopped_at_line`); one slower than pull_up_speed_mps but not at
            rest, more than near_m and at most this far short, drives up to it
            (`pull_up_target`) [m].
        pull_up_speed_mps: ... while slower than this [m/s].
    """

    near_m: float = 1.5
    rest_mps: float = 0.1
    hold_s: float = 0.5
    pull_up_m: float = 6.0
    pull_up_speed_mps: float = 2.0

    def __post_init__(self):
        if min(self.near_m, self.rest_mps, self.hold_s) <= 0.0:
            raise ValueError("StopSignConfig: near_m, rest_mps and hold_s must be > 0")
        if not (self.pull_up_m >= self.near_m and self.pull_up_speed_mps > 0.0):
            raise ValueError("StopSignConfig: need pull_up_m >= near_m and pull_up_speed_mps > 0")


def stopped_at_line(line_m: float, front_m: float, v0: float, config: StopSignConfig) -> bool:
    """Whether the robot is at rest for a stop line: the stop it demands, while it lasts hold_s.

    Slower than config.rest_mps with its front at most config.pull_up_m short of the line
    and at most config.near_m past it.

    Args:
        line_m: the line's arc length along the robot's route [m].
        front_m: the arc length of the robot's front bumper [m].
        v0: its speed [m/s].
        config: the stop-line rule.
    """
    short_m = line_m - front_m
    return bool(v0 < config.rest_mps and -config.near_m <= short_m <= config.pull_up_m)


def stop_wall(line_m: float, front_m: float, resting: bool, config: StopSignConfig) -> float:
    """Where the robot's front must stay behind while a line is due [m].

    The line; where the robot is at rest more than near_m short of it (`stopped_at_line`), its
    front: it completes its stop where it stands (creeping up would restart it).

    Args:
        line_m: the line's arc length [m].
        front_m: the robot's front bumper's arc length [m].
        resting: it has been at rest for the line since its last call (`rest_s` > 0).
        config: the stop-line rule.
    """
    if resting and line_m - front_m > config.near_m:
        return float(front_m)
    return float(line_m)


def pull_up_target(stop_at_m: float, s0: float, v0: float, config: StopSignConfig) -> float:
    """The arc length a slow robot short of its stop line drives up to (inf: none) [m].

    A robot slower than config.pull_up_speed_mps whose front stands more than near_m and at
    most pull_up_m short of the line it must stop at (stop_at_m: its centre's bound, from
    StopSigns / SignalStops) pulls up to it (the MPC's pull-up term); within near_m it is at
    the line already and may come to rest where it is. One at rest short of the line is
    stopping there (`stop_wall` puts its bound at its front): not pulled up.

    Args:
        stop_at_m: the arc length its centre must stay behind (inf: no line due) [m].
        s0: its centre's arc length [m].
        v0: its speed [m/s].
        config: the stop-line rule.
    """
    short_m = stop_at_m - s0  # its front's distance to the line [m] (inf: no line due)
    if v0 < config.pull_up_speed_mps and config.near_m < short_m <= config.pull_up_m:
        return float(stop_at_m)
    return np.inf


def stop_sign_arc_lengths(route: Route, road_map: RoadMap) -> np.ndarray:
    """(C,) ascending arc lengths [m] at which `route` crosses a stop-sign line it must obey.

    A line with a lane index counts where the route's direction agrees with that lane's (the
    lane's centreline heading at its point nearest the crossing); one without (-1) everywhere
    the route crosses it.
    """
    out = []
    for line in road_map.stop_lines:
        if line.kind != "stop_sign":
            continue  # signals: not in the static map's hands (module docstring)
        crossings = route.segment_crossings(line.segment)
        if line.lane >= 0 and len(crossings):  # RoadMap checked the index
            lane = Route(road_map.lanes[line.lane].centerline, f"lane {line.lane}")
            xy, heading = route.point_at(crossings)
            _, _, lane_heading = lane.project(xy)
            crossings = crossings[np.cos(heading - lane_heading) > 0.0]
        out.extend(crossings.tolist())
    return np.unique(np.asarray(out, dtype=np.float64))


class StopSigns:
    """The robot's stop-sign state along its route (module docstring).

    Args:
        route: the robot's route.
        road_map: the static map (its stop_lines and lanes).
        robot_length_m: the robot's length [m] (the constraint is on its front bumper).
        config: when the robot counts as stopped.
    """

    def __init__(self, route: Route, road_map: RoadMap, robot_length_m: float,
                 config: StopSignConfig | None = None):
        self.config = config or StopSignConfig()
        self.lines_m = stop_sign_arc_lengths(route, road_map)
        self._half = 0.5 * robot_length_m
        self.reset()

    def reset(self) -> None:
        """A new episode: every line ahead is still to be stopped at."""
        self.next_line: int | None = None  # index into lines_m, set on the first update
        self.rest_s = 0.0

    def update(self, s0: float, v0: float, dt_s: float) -> float:
        """Count the time at rest; the arc length the robot's centre must stay behind [m].

        Called once per planning step.

        Args:
            s0: the robot's arc length along its route (footprint centre) [m].
            v0: its speed [m/s].
            dt_s: time since the last call [s].

        Returns:
            The line's arc length minus half the robot's length [m]; inf if no line is due.
        """
        c = self.config
        front = s0 + self._half
        if self.next_line is None:  # lines behind the front at the start are not due
            self.next_line = int(np.searchsorted(self.lines_m, front - c.near_m))
        while (self.next_line < len(self.lines_m)
               and front > self.lines_m[self.next_line] + c.near_m):
            self.next_line += 1  # passed without stopping (it could not)
            self.rest_s = 0.0
        if self.next_line >= len(self.lines_m):
            return np.inf
        line = float(self.lines_m[self.next_line])
        if stopped_at_line(line, front, v0, c):
            self.rest_s += dt_s
        else:
            self.rest_s = 0.0
        if self.rest_s >= c.hold_s:  # stopped: go (the next line, if any, is further on)
            self.next_line += 1
            self.rest_s = 0.0
            return self.update(s0, v0, 0.0) if self.next_line < len(self.lines_m) else np.inf
        return stop_wall(line, front, self.rest_s > 0.0, c) - self._half

"""Physical metrics of the robot (group "episode"): collisions, speeds, braking, right of way.

The right-of-way metrics are measured against the scenario's conflict areas: on a map with a
crosswalk, the first crosswalk and the first pedestrian (the paper's scenario); elsewhere the
conflict zones on the robot's route (sim/road_map.ConflictZone) and the agents whose routes
have the right of way there (sim/route_rules.route_conflicts). Each metric is a short function
of (trace, road_map, robot) registered in `marl_social.metrics.registry`; the helpers below give
the per-agent series they share.
"""

from __future__ import annotations

import numpy as np

from marl_social.metrics.registry import register_metric
from marl_social.sim.costs import crosswalk_occupancy, zone_occupancy
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.route_rules import RouteConflict, route_conflicts
from marl_social.sim.signals import GREEN
from marl_social.sim.trace import Trace

HARD_BRAKE_MPS2 = 5.0  # braking harder than this counts as a hard brake [m/s^2]
OCCUPIED_FRACTION = 0.5  # crosswalk / zone occupancy above this counts as "in it"
PASSED_FRACTION = 0.01  # ... and below this as clear of it
YIELD_WINDOW_S = 2.0  # a right-of-way agent in the zone within this of the robot: not yielded
FORCING_LOOKAHEAD_S = 3.0  # the robot is "in the way" of a human within this time ahead [s]
FORCING_MARGIN_M = 10.0  # ... plus this distance [m]
IN_PATH_HALF_WIDTH_M = 2.5  # ... and this close to its path (half a lane + half a car) [m]
IN_LANE_HALF_WIDTH_M = 1.75  # ... or its front this close to the path (inside the lane) [m]
FORCING_PREDICT_S = 1.0  # ... now or this long later, at its current speed [s]
# forced braking is reported to this many decimals of a m/s^2: a step's effective acceleration
# is a speed difference over the step, so a human's -3 m/s^2 action reads 3.000000000000007 or
# 2.9999999999999982 by rounding error, and a threshold at one of the humans' candidate
# accelerations (3 m/s^2) would otherwise count that action by chance
FORCED_DECEL_DECIMALS = 6
NAN = float("nan")


# ------------------------------------------------------------------------------ shared series


def pedestrian_indices(trace: Trace) -> list[int]:
    """Trace indices of the agents whose role is "pedestrian", in trace order."""
    return [i for i, role in enumerate(trace.roles) if role == "pedestrian"]


def agent_occupancy(trace: Trace, agent: int, road_map: RoadMap) -> np.ndarray:
    """(T+1,) occupancy of the first crosswalk by one agent's bounding circle, in [0, 1].

    Args:
        trace: the episode's trace.
        agent: trace index of the agent.
        road_map: the map; it must have a crosswalk.
    """
    return crosswalk_occupancy(trace.states[:, agent, :2], trace.bounding_radius_m[agent],
                               road_map.crosswalks[0])


def _walk_coordinate(xy: np.ndarray, crosswalk) -> np.ndarray:
    """(...) position along a crosswalk's walking direction from its centre of points (..., 2) [m]."""
    rel = np.asarray(xy, dtype=np.float64) - crosswalk.center
    return rel[..., 0] * np.cos(crosswalk.walk_heading_rad) + rel[..., 1] * np.sin(
        crosswalk.walk_heading_rad)


def pedestrian_before_robot_lane(trace: Trace, road_map: RoadMap, robot: str,
                                 pedestrian: int) -> np.ndarray:
    """(T+1,) bool: the pedestrian has not yet walked past the robot's lane on the crosswalk.

    Along the first crosswalk's walking direction, in the direction the pedestrian's route
    walks: its centre short of the far edge of the lane the robot's route crosses it in (the
    map's lane nearest the crossing; its half width). All True where that cannot be told (no
    route crossing the walk, no lanes): then only the crosswalk counts. Where the crosswalk
    spans just the robot's lane and the one it starts from (curb to curb), in the crosswalk is
    short of that edge; on a wider one (a real street's), a pedestrian past it walks away
    from the robot's path, behind it.

    Args:
        trace: the episode's trace.
        road_map: the map (routes, lanes, the first crosswalk).
        robot: the robot's name.
        pedestrian: the pedestrian's trace index.
    """
    everywhere = np.ones(len(trace.times_s), dtype=bool)
    crosswalk = road_map.crosswalks[0]
    route = road_map.routes.get(robot)
    walk_route = road_map.routes.get(trace.names[pedestrian])
    if route is None or walk_route is None or not road_map.lanes:
        return everywhere
    heading = np.array([np.cos(crosswalk.walk_heading_rad), np.sin(crosswalk.walk_heading_rad)])
    half = 0.5 * crosswalk.length_m + 1.0
    crossings = route.segment_crossings(
        np.array([crosswalk.center - half * heading, crosswalk.center + half * heading]))
    if not len(crossings):
        return everywhere
    crossing_xy = route.point_at(float(crossings[0]))[0]
    lateral = [abs(float(Route(lane.centerline).project(crossing_xy[None])[1][0]))
               for lane in road_map.lanes]
    half_lane = 0.5 * road_map.lanes[int(np.argmin(lateral))].width_m
    ends = _walk_coordinate(walk_route.points[[0, -1]], crosswalk)
    direction = 1.0 if ends[1] >= ends[0] else -1.0
    ahead = direction * (_walk_coordinate(trace.states[:, pedestrian, :2], crosswalk)
                         - _walk_coordinate(crossing_xy, crosswalk))
    return ahead <= half_lane


def robot_conflicts(trace: Trace, road_map: RoadMap, robot: str) -> tuple[RouteConflict, ...]:
    """The conflict zones on the robot's route (empty if the map has no route for it)."""
    route = road_map.routes.get(robot)
    return route_conflicts(route, road_map) if route is not None else ()


def zone_series(trace: Trace, agent: int, polygon: np.ndarray) -> np.ndarray:
    """(T+1,) occupancy of a conflict zone by one agent's bounding circle, in [0, 1].

    Args:
        trace: the episode's trace.
        agent: trace index of the agent.
        polygon: (V, 2) the zone's outline, counter-clockwise [m].
    """
    xy = trace.states[:, agent, None, :2]  # (T+1, 1, 2): one circle per state
    radius = np.full(xy.shape[:2], trace.bounding_radius_m[agent])
    return zone_occupancy(xy, radius, polygon)


def right_of_way_agents(trace: Trace, road_map: RoadMap, zone_index: int,
                        robot: str) -> list[int]:
    """Trace indices of the agents other than the robot whose route has the right of way in a zone.

    Args:
        trace: the episode's trace.
        road_map: the map with every agent's route.
        zone_index: index into road_map.conflict_zones.
        robot: the robot's name (excluded).
    """
    out = []
    for i, name in enumerate(trace.names):
        route = road_map.routes.get(name)
        if name == robot or route is None:
            continue
        if any(c.zone_index == zone_index and not c.yields
               for c in route_conflicts(route, road_map)):
            out.append(i)
    return out


def _robot_speeds(trace: Trace, robot: str) -> np.ndarray:
    """(n_active,) the robot's speeds while active [m/s]."""
    r = trace.index(robot)
    return trace.states[:, r][trace.active[:, r], 3]


def _robot_accel(trace: Trace, robot: str) -> np.ndarray:
    """(n_active_steps,) the robot's applied accelerations in the steps it starts active [m/s^2]."""
    r = trace.index(robot)
    if not len(trace.accel_mps2):
        return np.zeros(0)
    return trace.accel_mps2[:, r][trace.active[1:, r]]


def _max_decel_mps2(trace: Trace, robot: str) -> float:
    """Largest braking of the robot [m/s^2] (>= 0; 0 without steps)."""
    accel = _robot_accel(trace, robot)
    return float(max(0.0, -accel.min())) if len(accel) else 0.0


# ------------------------------------------------------------------------------ metrics


@register_metric("collision", "robot_collision", group="episode")
def collisions(trace: Trace, road_map: RoadMap, robot: str) -> tuple[bool, bool]:
    """Any agent touched anything; the robot touched anything."""
    if not len(trace.collided):
        return False, False
    return bool(trace.collided.any()), bool(trace.collided[:, trace.index(robot)].any())


@register_metric("mean_speed_mps", "min_speed_mps", group="episode")
def robot_speeds(trace: Trace, road_map: RoadMap, robot: str) -> tuple[float, float]:
    """Mean and smallest robot speed while active [m/s] (nan if never active)."""
    speeds = _robot_speeds(trace, robot)
    if not len(speeds):
        return NAN, NAN
    return float(speeds.mean()), float(speeds.min())


@register_metric("max_decel_mps2", "max_jerk_mps3", group="episode")
def robot_braking(trace: Trace, road_map: RoadMap, robot: str) -> tuple[float, float]:
    """Largest braking [m/s^2] (>= 0) and largest |change of acceleration| / dt [m/s^3]."""
    accel = _robot_accel(trace, robot)
    jerk = float(np.abs(np.diff(accel)).max() / DT_S) if len(accel) > 1 else 0.0
    return _max_decel_mps2(trace, robot), jerk


@register_metric("min_gap_pedestrian_m", group="episode")
def min_gap_pedestrian(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Smallest robot-pedestrian centre distance minus both bounding radii [m], >= 0.

    Conservative for the car's long sides; nan without a crosswalk, without a pedestrian or if
    the two are never active together.
    """
    peds = pedestrian_indices(trace)
    if not road_map.crosswalks or not peds:
        return NAN
    r, p = trace.index(robot), peds[0]
    both = trace.active[:, r] & trace.active[:, p]
    if not both.any():
        return NAN
    gaps = (np.linalg.norm(trace.states[:, r, :2] - trace.states[:, p, :2], axis=1)
            - trace.bounding_radius_m[r] - trace.bounding_radius_m[p])
    return float(max(gaps[both].min(), 0.0))


@register_metric("yielded", group="episode")
def yielded(trace: Trace, road_map: RoadMap, robot: str) -> bool:
    """The robot gave way: in no crosswalk with the pedestrian, in no zone in another's way.

    Crosswalk: the robot was never in the first crosswalk while the first pedestrian was in
    it and had not yet walked past the robot's lane (pedestrian_before_robot_lane: on a
    crosswalk from curb to curb of the robot's and the next lane, while it was in it at
    all). Conflict zones (those on its route where it yields): the robot was never in one while
    an agent with the right of way there reached it within YIELD_WINDOW_S, or was in it behind
    the robot along its own route (the robot in its way; merging behind it is giving way).
    True without either.
    """
    r = trace.index(robot)
    peds = pedestrian_indices(trace)
    if road_map.crosswalks and peds:
        p = peds[0]
        robot_in = (agent_occupancy(trace, r, road_map) > OCCUPIED_FRACTION) & trace.active[:, r]
        ped_in = agent_occupancy(trace, p, road_map) > OCCUPIED_FRACTION
        ped_in &= pedestrian_before_robot_lane(trace, road_map, robot, p)
        if np.any(robot_in & ped_in & trace.active[:, p]):
            return False
    window = round(YIELD_WINDOW_S / DT_S)
    for conflict in robot_conflicts(trace, road_map, robot):
        if not conflict.yields:
            continue
        polygon = conflict.zone.polygon
        robot_in = (zone_series(trace, r, polygon) > OCCUPIED_FRACTION) & trace.active[:, r]
        for j in right_of_way_agents(trace, road_map, conflict.zone_index, robot):
            if np.any(robot_in & _claims(trace, road_map, j, r, polygon, window)):
                return False
    return True


def _claims(trace: Trace, road_map: RoadMap, j: int, r: int, polygon: np.ndarray,
            window: int) -> np.ndarray:
    """(T+1,) bool: agent j enters the zone within `window` steps, or is in it behind agent r.

    Args:
        trace: the episode's trace.
        road_map: the map (j's route).
        j: trace index of the agent with the right of way.
        r: trace index of the robot.
        polygon: (V, 2) the zone's outline [m].
        window: the look-ahead [steps].
    """
    inside = (zone_series(trace, j, polygon) > OCCUPIED_FRACTION) & trace.active[:, j]
    entry = inside & ~np.concatenate([[False], inside[:-1]])
    count = np.concatenate([[0], np.cumsum(entry)])  # count[k]: entries before step k
    t = np.arange(len(inside))
    arrives = count[np.minimum(t + window, len(inside) - 1) + 1] - count[t + 1] > 0
    route = road_map.routes[trace.names[j]]
    s_j, _, _ = route.project(trace.states[:, j, :2])
    s_r, _, _ = route.project(trace.states[:, r, :2])
    return arrives | (inside & (s_j < s_r))


def _time_passed(occupancy: np.ndarray, times_s: np.ndarray) -> float:
    """First time [s] an occupancy series (T+1,) is clear after having been touched; nan if never."""
    entered = np.cumsum(occupancy > PASSED_FRACTION) > 0
    passed = np.flatnonzero(entered & (occupancy <= PASSED_FRACTION))
    return float(times_s[passed[0]]) if len(passed) else NAN


@register_metric("time_to_pass_s", group="episode")
def time_to_pass(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Time until the robot's bounding circle has entered and left the scenario's conflict area [s].

    The area: the first crosswalk if the map has one, else every conflict zone on the robot's
    route (the time it has left the last of them). The first time the robot no longer touches
    the area after touching it; nan if never, or without a crosswalk or zone on its route.
    """
    r = trace.index(robot)
    if road_map.crosswalks:
        return _time_passed(agent_occupancy(trace, r, road_map), trace.times_s)
    conflicts = robot_conflicts(trace, road_map, robot)
    if not conflicts:
        return NAN
    times = [_time_passed(zone_series(trace, r, c.zone.polygon), trace.times_s)
             for c in conflicts]
    return float(max(times))  # nan if any zone was never passed


def _in_path_distance(route: Route, xy_self: np.ndarray, xy_other: np.ndarray,
                      half_width_m: float = IN_PATH_HALF_WIDTH_M) -> np.ndarray:
    """(T+1,) how far ahead along `route` another agent is [m], inf where not on the path.

    Args:
        route: the human's route.
        xy_self: (T+1, 2) the human's positions [m].
        xy_other: (T+1, 2) the other agent's positions (or one point of it) [m].
        half_width_m: on the path: within this of the route [m].
    """
    s_self, _, _ = route.project(xy_self)
    s_other, lateral, _ = route.project(xy_other)
    ahead = s_other - s_self
    on_path = (ahead > 0.0) & (np.abs(lateral) <= half_width_m)
    return np.where(on_path, ahead, np.inf)


def _robot_in_path_distance(trace: Trace, road_map: RoadMap, r: int, route: Route,
                            xy_self: np.ndarray, v_self: np.ndarray) -> np.ndarray:
    """(T+1,) how far ahead along a human's `route` the robot is in its way [m] (inf: not).

    In its way: the robot's centre within IN_PATH_HALF_WIDTH_M of the route, or its front
    (a bounding radius ahead of its centre along its own route) inside the lane
    (IN_LANE_HALF_WIDTH_M), now or FORCING_PREDICT_S later, both at their current speeds
    along their routes (a robot rolling out of a side road into the lane ahead of the human is
    in its way before its centre is on it; one standing short of the lane is not).

    Args:
        trace: the episode's trace.
        road_map: the map (the robot's route; without one, its heading stands for it).
        r: the robot's trace index.
        route: the human's route.
        xy_self: (T+1, 2) the human's positions [m].
        v_self: (T+1,) the human's speeds [m/s].
    """
    s_self, _, _ = route.project(xy_self)
    self_later = route.point_at(s_self + np.maximum(v_self, 0.0) * FORCING_PREDICT_S)[0]
    xy, v = trace.states[:, r, :2], np.maximum(trace.states[:, r, 3], 0.0)
    reach = trace.bounding_radius_m[r]
    own = road_map.routes.get(trace.names[r])
    if own is not None:
        s, _, _ = own.project(xy)
        front = own.point_at(s + reach)[0]
        ahead = own.point_at(s + reach + v * FORCING_PREDICT_S)[0]
    else:
        heading = trace.states[:, r, 2]
        direction = np.column_stack([np.cos(heading), np.sin(heading)])
        front = xy + reach * direction
        ahead = front + (v * FORCING_PREDICT_S)[:, None] * direction
    return np.minimum.reduce([
        _in_path_distance(route, xy_self, xy),
        _in_path_distance(route, xy_self, front, IN_LANE_HALF_WIDTH_M),
        _in_path_distance(route, self_later, ahead, IN_LANE_HALF_WIDTH_M),
    ])


@register_metric("others_max_decel_mps2", group="episode")
def others_max_decel(trace: Trace, road_map: RoadMap, robot: str) -> float:
    """Hardest braking the robot forced on a human driver [m/s^2] (>= 0; 0 if none).

    A human's braking in a step counts as forced by the robot when, at the start of that
    step, the robot is in the human's way (`_robot_in_path_distance`: its centre on the
    human's route, or its front in the human's lane now or FORCING_PREDICT_S later), ahead
    closer than FORCING_LOOKAHEAD_S at the human's speed plus FORCING_MARGIN_M, and nearer
    along the route than any other agent's centre there (a car queued behind another brakes
    for that one) and than a signal stop line ahead of the human whose head shows red or
    yellow (a car stopping for its light; `trace.signal_states`). Both must be active.
    Rounded to FORCED_DECEL_DECIMALS (a -3 m/s^2 action is 3.0, not 3.000000000000007).
    """
    if not len(trace.accel_mps2):
        return 0.0
    r = trace.index(robot)
    worst = 0.0
    for h, role in enumerate(trace.roles):
        route = road_map.routes.get(trace.names[h])
        if role != "human" or route is None:
            continue
        xy_h = trace.states[:, h, :2]
        reach = trace.states[:, h, 3] * FORCING_LOOKAHEAD_S + FORCING_MARGIN_M
        dist = {j: np.where(trace.active[:, j],
                            _in_path_distance(route, xy_h, trace.states[:, j, :2]), np.inf)
                for j in range(len(trace.names)) if j not in (h, r)}
        robot_ahead = _robot_in_path_distance(trace, road_map, r, route, xy_h,
                                              trace.states[:, h, 3])
        dist[r] = np.where(trace.active[:, r], robot_ahead, np.inf)
        dist[-1] = _signal_line_distance(trace, road_map, route, xy_h)
        nearest_other = np.min([d for j, d in dist.items() if j != r], axis=0, initial=np.inf)
        forced = ((dist[r] <= reach) & (dist[r] < nearest_other)
                  & trace.active[:, h] & trace.active[:, r])[:-1]
        braking = -trace.accel_mps2[:, h][forced]
        if len(braking):
            worst = max(worst, float(braking.max()))
    return round(worst, FORCED_DECEL_DECIMALS)


def _signal_line_distance(trace: Trace, road_map: RoadMap, route: Route,
                          xy_self: np.ndarray) -> np.ndarray:
    """(T+1,) distance ahead along `route` to the nearest red or yellow signal stop line [m].

    inf where there is none (sim/signals.py heads, `trace.signal_states`).

    Args:
        trace: the episode's trace.
        road_map: the map (its signal heads and stop lines).
        route: the human's route.
        xy_self: (T+1, 2) the human's positions [m].
    """
    out = np.full(len(xy_self), np.inf)
    states = np.asarray(trace.signal_states)
    if states.ndim != 2 or not states.shape[1] or len(states) != len(xy_self):
        return out
    s_self, _, _ = route.project(xy_self)
    for k, head in enumerate(road_map.signal_heads):
        for s_line in route.segment_crossings(road_map.stop_lines[head.stop_line].segment):
            ahead = s_line - s_self
            stopping = (states[:, k] != GREEN) & (ahead > 0.0)
            out = np.where(stopping, np.minimum(out, ahead), out)
    return out


@register_metric("hard_brake", group="episode")
def hard_brake(trace: Trace, road_map: RoadMap, robot: str) -> bool:
    """max_decel_mps2 > HARD_BRAKE_MPS2."""
    return _max_decel_mps2(trace, robot) > HARD_BRAKE_MPS2

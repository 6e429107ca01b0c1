"""Where the signal situation can be built on a converted map: routes through a signalled junction.

The signal situation (Sun et al. 2019, Fig. 1 c: right turn on red, on a map's traffic light):
the robot in a lane of the light that turns right after its stop line; the cross traffic, a
straight movement of another signal group that ends up in the robot's exit direction and that
the robot's route conflicts with after its line (preferably where the map gives it the right of
way); and, as sensors, left-turners of a third group whose green (the "protected left") is a
phase in which the cross traffic has red. The map's cycle (signal_plan.py's default where the
map gives none) must have a phase that shows the left-turners green while the robot and the
cross traffic have red, and one that shows the cross traffic green while the robot and the
left-turners have red: the scene's two variants. A right turn on red gives way to every lane
it meets after its line: the conflict zones there give the other lane the right of way
(`SignalScenePlan.give_way`; the map's own rule holds while the lights work, and the robot
turns while its light is red).

`signal_plan_of(loaded, signal_id, needs)` gives the scene's geometry (SignalScenePlan) or a
SceneError naming why it cannot be built there.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from marl_social.maps.elements import LaneKey
from marl_social.maps.geometry import points_in_polygon, polyline_crossings
from marl_social.maps.scenes import (
    LanePath,
    SceneError,
    _heading,
    _length,
    lane_path,
)
from marl_social.sim.road_map import Route
from marl_social.sim.route_rules import on_lanes

MIN_TURN_RAD = math.radians(45.0)  # a movement turns (left or right) by at least this [rad]
MAX_STRAIGHT_RAD = math.radians(45.0)  # a straight movement turns by less than this [rad]
SAME_DIRECTION_RAD = math.radians(45.0)  # the cross traffic heads within this of the robot's exit
TURN_LOOKAHEAD_M = 50.0  # a movement: the lanes within this past the stop line's lane [m]
OCCLUDER_CUT_M = 5.0  # a route past the junction ends this far before an occluder on it [m]
MIN_BEYOND_M = 15.0  # ... and goes on at least this far past the movement's lanes [m]
GIVE_WAY_REACH_M = 80.0  # the right of way holds on the lanes this far before a zone [m]
READ_HEAD_BEFORE_M = 5.0  # a driver this far before its line must read a head of its light [m]
PHASE_VARIANTS = ("protected_left", "cross_green")


class SignalNeeds(NamedTuple):
    """How much road the signal situation needs before each stop line and past the junction.

    Attributes:
        robot_back_m: route before the robot's line (its start and its length) [m].
        cross_back_m: route before the cross traffic's line (its cars' starts and length) [m].
        left_back_m: route before the left-turners' line (their queue and length) [m].
        beyond_m: route past each line's lane after the movement's turn (required) [m].
        edge_extension_m: as ScenarioNeeds.edge_extension_m [m].
    """

    robot_back_m: float = 10.0
    cross_back_m: float = 65.0
    left_back_m: float = 25.0
    beyond_m: float = 30.0
    edge_extension_m: float = 40.0


DEFAULT_SIGNAL_NEEDS = SignalNeeds()


class Movement(NamedTuple):
    """A way through a junction from a signalled lane.

    Attributes:
        signal_id: the traffic light element controlling the lane.
        group: its signal group.
        keys: the signalled lane, then the lanes after it (TURN_LOOKAHEAD_M of them).
        line_m: arc length of the stop line along the signalled lane [m].
        turn_rad: heading change from the signalled lane's end to the last lane's end (+ left) [rad].
        exit_heading_rad: the last lane's heading at its end [rad].
    """

    signal_id: int
    group: str
    keys: tuple[LaneKey, ...]
    line_m: float
    turn_rad: float
    exit_heading_rad: float


class SignalScenePlan(NamedTuple):
    """The signal situation's geometry on one traffic light of a map.

    Attributes:
        signal_id: the robot's traffic light element.
        robot, cross, left_turn: the routes (crossing_m: each one's stop line) of the robot, the
            cross traffic and the left-turners.
        groups: the signal groups of the robot, the cross traffic and the left-turners.
        phase_indices: per PHASE_VARIANTS, the index of its phase in the map's cycle.
        speed_limit_mps: the robot's lane's speed limit [m/s].
        give_way: (zone, lane, ...) indices into the map's conflict_zones and lanes: the lanes
            that have the right of way over the robot's turn in that zone.
    """

    signal_id: int
    robot: LanePath
    cross: LanePath
    left_turn: LanePath
    groups: tuple[str, str, str]
    phase_indices: tuple[int, int]
    speed_limit_mps: float
    give_way: tuple[tuple[int, ...], ...] = ()


def _wrap(angle_rad: float) -> float:
    return math.remainder(angle_rad, 2.0 * math.pi)


def _centerline(loaded, key: LaneKey) -> np.ndarray:
    road_map, elements = loaded
    return road_map.lanes[elements.lanes[key].index].centerline


def _chains(loaded, key: LaneKey, wanted_m: float) -> list[tuple[LaneKey, ...]]:
    """Every chain of successors after `key` until wanted_m [m] of them (or the map's edge)."""
    _, elements = loaded
    out, stack = [], [((key,), 0.0)]
    while stack:
        chain, total = stack.pop()
        options = [k for k in elements.lanes[chain[-1]].successors if k not in chain]
        if total >= wanted_m or not options:
            out.append(chain)
            continue
        stack += [((*chain, k), total + _length(_centerline(loaded, k))) for k in options]
    return sorted(out)


def movements(loaded, signal_id: int) -> list[Movement]:
    """Every movement from the lanes of one traffic light element (Movement).

    Only those whose lanes cross the light's stop line (a driver stops where its route
    crosses the line: sim/signal_rules.route_signal_lines).
    """
    road_map, elements = loaded
    signal = elements.signals[signal_id]
    segment = road_map.stop_lines[signal.stop_line].segment
    out = []
    for key in signal.lanes:
        start = _heading(_centerline(loaded, key), at_end=True)
        for chain in _chains(loaded, key, TURN_LOOKAHEAD_M):
            hits = polyline_crossings(
                np.concatenate([_centerline(loaded, k) for k in chain[:2]]), segment)
            if not len(hits):
                continue
            end = _heading(_centerline(loaded, chain[-1]), at_end=True)
            out.append(Movement(signal_id, signal.group, chain, float(hits[0]),
                                _wrap(end - start), end))
    return out


def _phase(plan, green: str, red: tuple[str, ...]) -> int:
    """Index of the first phase showing `green` green and every group of `red` red (-1: none)."""
    for k, phase in enumerate(plan.phases):
        if green in phase.green and not set(red) & (set(phase.green) | set(phase.yellow)):
            return k
    return -1


def _conflicting(loaded, a: tuple[LaneKey, ...], b: tuple[LaneKey, ...]) -> tuple[bool, bool]:
    """Whether lanes a and b conflict, and whether a zone gives one of b's lanes the priority."""
    _, elements = loaded
    found, priority = False, False
    for x in a:
        for y in b:
            conflict = elements.conflicts.get(tuple(sorted((x, y))))
            if conflict is not None:
                found = True
                priority |= y in conflict.priority
    return found, priority


def _path(loaded, movement: Movement, back_m: float, needs: SignalNeeds, name: str) -> LanePath:
    """The route of a movement: back_m [m] before its line, needs.beyond_m past its last lane."""
    road_map, elements = loaded
    beyond = sum(_length(_centerline(loaded, k)) for k in movement.keys[1:]) + needs.beyond_m
    own = _length(_centerline(loaded, movement.keys[0]))
    path = lane_path(loaded, movement.keys[0], movement.line_m,
                     (back_m + 10.0, beyond + own - movement.line_m), needs.edge_extension_m,
                     then=movement.keys[1:])
    hits = polyline_crossings(
        path.points, road_map.stop_lines[elements.signals[movement.signal_id].stop_line].segment)
    if not len(hits):
        raise SceneError(f"{name}: its route misses its stop line")
    path = path._replace(crossing_m=float(hits[0]))
    if path.crossing_m < back_m - 1e-6:
        raise SceneError(f"{name}: route too short before its line ({path.crossing_m:.0f} m, "
                         f"needs {back_m:.0f} m)")
    route = Route(path.points)
    start = path.crossing_m - back_m
    blocked = _occluder_crossings(_cut(path.points, route.length_m, start),
                                  road_map.static_polygons) + start
    through_m = path.crossing_m + sum(_length(_centerline(loaded, k)) for k in movement.keys) \
        - movement.line_m  # the end of the movement's lanes
    end = min(float(blocked[0]) - OCCLUDER_CUT_M if len(blocked) else route.length_m,
              route.length_m)
    if len(blocked) and blocked[0] < path.crossing_m:
        raise SceneError(f"{name}: its approach runs through an occluder of the map "
                         f"{path.crossing_m - blocked[0]:.0f} m before its line")
    if end < through_m + MIN_BEYOND_M:
        what = "runs through an occluder of the map" if len(blocked) else "is too short"
        raise SceneError(f"{name}: its route {what} before {MIN_BEYOND_M:.0f} m past the "
                         "junction")
    if not _reads_head(loaded, movement.signal_id, path):
        raise SceneError(f"{name}: an occluder of the map hides its light's heads from "
                         f"{READ_HEAD_BEFORE_M:.0f} m before its line")
    return path._replace(points=_cut(path.points, end))


def _reads_head(loaded, signal_id: int, path: LanePath) -> bool:
    """Whether a driver READ_HEAD_BEFORE_M before its line sees one of its light's heads.

    In front of the head (its visor) and no occluder on the sight line (perception/signal_view).
    """
    road_map, elements = loaded
    xy, _ = Route(path.points).point_at(path.crossing_m - READ_HEAD_BEFORE_M)
    for h in elements.signals[signal_id].heads:
        head = road_map.signal_heads[h]
        rel = xy - head.position
        if abs(_wrap(math.atan2(rel[1], rel[0]) - head.facing_rad)) > head.view_half_angle_rad:
            continue
        if not len(_occluder_crossings(np.array([xy, head.position]),
                                       road_map.static_polygons)):
            return True
    return False


def _occluder_crossings(points: np.ndarray, polygons) -> np.ndarray:
    """(K,) ascending arc lengths [m] along a polyline (P, 2) [m] where it enters an occluder.

    Edge crossings of every occluder's outline (a thin fence is crossed, not sampled), and 0
    where it starts inside one.
    """
    found = []
    lo, hi = points.min(axis=0), points.max(axis=0)
    for poly in polygons:
        if np.any(poly.max(axis=0) < lo) or np.any(poly.min(axis=0) > hi):
            continue
        found.extend(polyline_crossings(points, np.vstack([poly, poly[:1]])).tolist())
        if points_in_polygon(points[:1], poly)[0]:
            found.append(0.0)
    return np.sort(np.asarray(found, dtype=np.float64))


def _cut(points: np.ndarray, end_m: float, start_m: float = 0.0) -> np.ndarray:
    """The polyline (P, 2) [m] from arc length start_m to end_m [m]."""
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    if start_m <= 0.0 and end_m >= s[-1]:
        return points
    route = Route(points)
    inner = points[(s > start_m) & (s < end_m)]
    return np.vstack([route.point_at(start_m)[0], inner, route.point_at(min(end_m, s[-1]))[0]])


def _give_way(loaded, robot: LanePath, signalled: LaneKey) -> tuple[tuple[int, ...], ...]:
    """(zone, lanes...) of every conflict of a lane of the robot's route after its signalled lane.

    The lanes: the other lane and the lanes leading to it within GIVE_WAY_REACH_M (a car has
    the right of way from its approach on: sim/route_rules.priority_mask reads the lane it is
    on now), but none of the robot's own lanes and none the robot's route is on where it enters
    the zone (two lanes that merge overlap there: the robot would count as on the lane with
    the right of way, sim/route_rules.route_conflicts).
    """
    road_map, elements = loaded
    own = set(robot.keys)
    after = set(robot.keys[robot.keys.index(signalled) + 1:])
    route = Route(robot.points)
    s = np.arange(0.0, route.length_m, 0.5)
    xy, heading = route.point_at(s)
    out = []
    for (a, b), conflict in sorted(elements.conflicts.items()):
        if (a in after) == (b in after):
            continue
        inside = np.flatnonzero(road_map.conflict_zones[conflict.zone].contains(xy))
        if not len(inside):
            continue
        entry = slice(inside[0], inside[0] + 1)
        lanes = [elements.lanes[k].index
                 for k in _approach(loaded, b if a in after else a, GIVE_WAY_REACH_M)
                 if k not in own]
        lanes = [i for i in lanes
                 if not on_lanes([road_map.lanes[i]], xy[entry], heading[entry])[0]]
        if lanes:
            out.append((conflict.zone, *lanes))
    return tuple(out)


def _approach(loaded, key: LaneKey, reach_m: float) -> list[LaneKey]:
    """`key` and every lane leading to it within reach_m [m] (breadth first)."""
    _, elements = loaded
    found, frontier = [key], [(key, 0.0)]
    while frontier:
        lane, behind_m = frontier.pop(0)
        for pred in elements.lanes[lane].predecessors:
            if pred not in found and behind_m < reach_m:
                found.append(pred)
                frontier.append((pred, behind_m + _length(_centerline(loaded, pred))))
    return found


def signal_plan_of(loaded, signal_id: int,
                   needs: SignalNeeds = DEFAULT_SIGNAL_NEEDS) -> SignalScenePlan:
    """The signal situation on one traffic light element of a map (module docstring).

    Tries the light's right turns, then the cross movements (those the map gives the right of
    way first) and the left turns (the exit closest to the robot's first), and returns the
    first combination whose phases and routes fit.

    Raises:
        SceneError: the map has no such traffic light, or the situation cannot be built there.
    """
    _, elements = loaded
    if signal_id not in elements.signals:
        raise SceneError(f"element {signal_id} is no traffic light of the map (its traffic "
                         "lights: " + (", ".join(str(i) for i in sorted(elements.signals))
                                       or "none") + ")")
    own = elements.signals[signal_id].group
    rights = [m for m in movements(loaded, signal_id) if m.turn_rad <= -MIN_TURN_RAD]
    if not rights:
        raise SceneError(f"traffic light {signal_id}: no lane of it that crosses its stop line "
                         "turns right (right turn on red needs one)")
    others = [m for i in sorted(elements.signals) if i != signal_id
              for m in movements(loaded, i) if elements.signals[i].group != own]
    reasons = []
    for robot in rights:
        try:
            return _plan(loaded, robot, others, needs)
        except SceneError as err:
            reasons.append(str(err))
    unique = list(dict.fromkeys(reasons))
    raise SceneError(f"traffic light {signal_id}: " + "; ".join(unique[:2])
                     + ("; ..." if len(unique) > 2 else ""))


def _plan(loaded, robot: Movement, others: list[Movement], needs: SignalNeeds
          ) -> SignalScenePlan:
    road_map, elements = loaded
    name = f"lane {robot.keys[0].lanelet_id} turning right"
    after = robot.keys[1:]
    crosses = []
    for m in others:
        if abs(m.turn_rad) >= MAX_STRAIGHT_RAD \
                or abs(_wrap(m.exit_heading_rad - robot.exit_heading_rad)) > SAME_DIRECTION_RAD:
            continue
        found, priority = _conflicting(loaded, after, m.keys[1:])
        if found:
            crosses.append((not priority, m.keys, m))
    if not crosses:
        raise SceneError(f"{name}: no straight movement of another light joins or crosses "
                         "its way")
    lefts = sorted((abs(_wrap(m.exit_heading_rad - robot.exit_heading_rad)), m.keys, m)
                   for m in others if m.turn_rad >= MIN_TURN_RAD)
    if not lefts:
        raise SceneError(f"{name}: no left turn of another light to tell its phase")
    plan = road_map.signal_plan
    robot_path = _path(loaded, robot, needs.robot_back_m, needs, name)
    reasons = []
    for *_, cross in sorted(crosses):
        for *_, left in lefts:
            if left.group == cross.group:
                continue
            phases = (_phase(plan, left.group, (robot.group, cross.group)),
                      _phase(plan, cross.group, (robot.group, left.group)))
            if min(phases) < 0:
                reasons.append(f"{name}: no phase shows the left turn from lane "
                               f"{left.keys[0].lanelet_id} green with the cross traffic from "
                               f"lane {cross.keys[0].lanelet_id} red, or the other way round")
                continue
            try:
                cross_path = _path(loaded, cross, needs.cross_back_m, needs,
                                   f"cross traffic from lane {cross.keys[0].lanelet_id}")
                left_path = _path(loaded, left, needs.left_back_m, needs,
                                  f"left turn from lane {left.keys[0].lanelet_id}")
            except SceneError as err:
                reasons.append(str(err))
                continue
            return SignalScenePlan(robot.signal_id, robot_path, cross_path, left_path,
                                   (robot.group, cross.group, left.group), phases,
                                   elements.lanes[robot.keys[0]].speed_limit_mps,
                                   _give_way(loaded, robot_path, robot.keys[0]))
    raise SceneError("; ".join(list(dict.fromkeys(reasons))[:2]))

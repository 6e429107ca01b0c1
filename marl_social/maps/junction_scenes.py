"""Where the junction situation can be built on a converted map: routes through a junction.

The junction situation (Sun et al. 2019, Fig. 1 b, on a map's junction): the robot on a
minor approach, a lane that gives way at a conflict zone to a lane with the right of way (a
right-of-way element of the map, or right before left where nothing in the map decides it);
a hidden car on that major lane, approaching the zone; what hides it from the robot: the
map's occluders between the robot's start and the hidden car's, else a row of parked cars
along the major lane's curb on the robot's side (outside every lane); and, as sensors,
human drivers on other lanes of the junction that give way to the major road (they wait
for the hidden car, which they see). Junctions with traffic lights are the signal situation's:
their right-of-way elements only hold with the lights off.

`junction_plan(loaded, junction_id, needs)` gives the scene's geometry (JunctionPlan) or a
SceneError naming why it cannot be built there.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from marl_social.maps.elements import LaneKey
from marl_social.maps.geometry import points_in_polygon
from marl_social.maps.scenes import (
    PARKED_LENGTH_M,
    PARKED_WIDTH_M,
    ROUTE_CHECK_STEP_M,
    LanePath,
    SceneError,
    _hits_occluder,
    lane_path,
)
from marl_social.sim.road_map import Route

PARKED_GAP_M = 1.5  # between parked cars in a row [m]
PARKED_CURB_OFFSET_M = 0.4  # between the major lane's edge and a parked car [m]
PARKED_NEAR_M = 8.0  # the parked row ends this far before the conflict zone [m]
MIN_PARKED_CARS = 2  # fewer in a free place than this: no row
MAX_SENSORS = 2  # human sensors at most
ROUTE_CLEARANCE_M = 1.5  # a route keeps this far from the map's occluders (half a car + 0.6) [m]
ROUTE_SLACK_M = 10.0  # routes are asked this much longer at either end than needed: the
# smoothing (scenes.smooth_polyline) shortens them round bends and a step between lanes [m]
MIN_START_GAP_M = 10.0  # a sensor starts at least this far from every other agent's start [m]


class JunctionNeeds(NamedTuple):
    """How much road the junction situation needs.

    Attributes:
        approach_m: the robot's start before its conflict point along its route [m].
        hidden_m: the hidden car's start before the conflict point along the major lane [m].
        human_start_m: each sensor's start before its own conflict point [m].
        beyond_m: route past the conflict point (required) [m].
        parked_row_m: length of the parked row along the major lane, where one is needed [m].
        edge_extension_m: as ScenarioNeeds.edge_extension_m [m].
    """

    approach_m: float = 25.0
    hidden_m: float = 40.0
    human_start_m: float = 15.0
    beyond_m: float = 30.0
    parked_row_m: float = 30.0
    edge_extension_m: float = 40.0


DEFAULT_JUNCTION_NEEDS = JunctionNeeds()


class JunctionPlan(NamedTuple):
    """The junction situation's geometry on one junction of a map.

    Attributes:
        junction_id: the junction's id.
        robot: the robot's route (crossing_m: its conflict point).
        hidden: the hidden car's route along the major lane (crossing_m: the conflict point).
        sensors: the human sensors' routes (crossing_m: each one's conflict point with the
            major lane).
        parked_cars: (4, 2) outlines of the parked cars added (empty: the map's occluders
            hide the hidden car).
        speed_limit_mps: the robot's lane's speed limit [m/s].
    """

    junction_id: int
    robot: LanePath
    hidden: LanePath
    sensors: tuple[LanePath, ...]
    parked_cars: tuple[np.ndarray, ...]
    speed_limit_mps: float


def _conflict_s(loaded, key: LaneKey, zone: int) -> float:
    """Arc length along lane `key` of the centroid of conflict zone `zone` [m]."""
    road_map, elements = loaded
    centre = road_map.conflict_zones[zone].polygon.mean(axis=0)
    line = road_map.lanes[elements.lanes[key].index].centerline
    return float(Route(line).project(centre[None])[0][0])


def _blocked(a: np.ndarray, b: np.ndarray, polygons) -> bool:
    """Whether the sight line a -> b (2,) [m] passes through any polygon (points 0.5 m apart)."""
    n = max(int(np.linalg.norm(b - a) / 0.5), 2)
    points = a + np.linspace(0.0, 1.0, n)[:, None] * (b - a)
    return _hits_occluder(points[1:-1], polygons)


def _parked_row(loaded, major: LanePath, needs: JunctionNeeds, side: int,
                keep_clear: np.ndarray) -> list[np.ndarray]:
    """Parked cars along the major lane's `side` curb before the conflict point, off every lane.

    Each (4, 2) [m]; a car overlapping a lane of the map or within 2 m of a point of
    keep_clear (N, 2) (the robot's route) is left out.
    """
    road_map, elements = loaded
    route = Route(major.points)
    lanes = [road_map.lanes[e.index].polygon() for e in elements.lanes.values()]
    cars = []
    s = major.crossing_m - PARKED_NEAR_M - 0.5 * PARKED_LENGTH_M
    while s > major.crossing_m - PARKED_NEAR_M - needs.parked_row_m and s > 0.0:
        xy, heading = route.point_at(s)
        along = np.array([math.cos(float(heading)), math.sin(float(heading))])
        normal = side * np.array([-along[1], along[0]])
        centre = xy + (0.5 * major.width_m + PARKED_CURB_OFFSET_M + 0.5 * PARKED_WIDTH_M) * normal
        a, w = 0.5 * PARKED_LENGTH_M * along, 0.5 * PARKED_WIDTH_M * normal
        car = np.array([centre - a - w, centre + a - w, centre + a + w, centre - a + w])
        if w[0] * a[1] - w[1] * a[0] > 0:  # counter-clockwise
            car = car[::-1]
        on_lane = any(points_in_polygon(car, lane).any() for lane in lanes)
        near_route = np.min(np.linalg.norm(keep_clear - centre, axis=1)) < 2.0 + PARKED_LENGTH_M
        if not on_lane and not near_route:
            cars.append(car)
        s -= PARKED_LENGTH_M + PARKED_GAP_M
    return cars


def _needed_points(path: LanePath, start_m: float, beyond_m: float) -> np.ndarray:
    """(N, 2) points [m] of a route from start_m to beyond_m past its crossing point."""
    route = Route(path.points)
    s = np.arange(max(start_m, 0.0), min(route.length_m, path.crossing_m + beyond_m),
                  ROUTE_CHECK_STEP_M)
    return route.point_at(s)[0]


def _side(route_points: np.ndarray, s_m: float, point: np.ndarray) -> int:
    """+1 if point lies left of the route at s_m, else -1."""
    xy, heading = Route(route_points).point_at(s_m)
    rel = point - xy
    return 1 if math.cos(float(heading)) * rel[1] - math.sin(float(heading)) * rel[0] > 0 else -1


def _yielding_pairs(loaded, junction) -> list[tuple[LaneKey, LaneKey, int]]:
    """(minor lane, major lane, zone) of every conflict of the junction one lane gives way at."""
    _, elements = loaded
    pairs = []
    for pair in junction.conflicts:
        conflict = elements.conflicts[pair]
        if len(conflict.priority) != 1:
            continue
        major = conflict.priority[0]
        minor = pair[0] if pair[1] == major else pair[1]
        pairs.append((minor, major, conflict.zone))
    return sorted(pairs, key=lambda p: (p[0].lanelet_id, p[0].inverted, p[1].lanelet_id))


def junction_plan(loaded, junction_id: int,
                  needs: JunctionNeeds = DEFAULT_JUNCTION_NEEDS) -> JunctionPlan:
    """The junction situation on one junction of a map (module docstring).

    Tries each conflict of the junction where one lane gives way, by the minor lane's id, and
    returns the first where the routes fit and something hides the major lane.

    Raises:
        SceneError: the map has no such junction, or the situation cannot be built there.
    """
    _, elements = loaded
    if junction_id not in elements.junctions:
        raise SceneError(f"element {junction_id} is no junction of the map")
    junction = elements.junctions[junction_id]
    if junction.signals:
        raise SceneError(f"junction {junction_id}: signalized (its right of way holds with the "
                         "lights off; the signal situation's)")
    pairs = _yielding_pairs(loaded, junction)
    if not pairs:
        raise SceneError(f"junction {junction_id}: no conflict where the map says who gives way")
    reasons = []
    for minor, major, zone in pairs:
        try:
            return _plan(loaded, junction_id, (minor, major, zone), pairs, needs)
        except SceneError as err:
            reasons.append(str(err))
    unique = list(dict.fromkeys(reasons))
    return _raise(junction_id, unique)


def _raise(junction_id: int, reasons: list[str]):
    raise SceneError(f"junction {junction_id}: " + "; ".join(reasons[:2])
                     + ("; ..." if len(reasons) > 2 else ""))


def _plan(loaded, junction_id: int, conflict: tuple, pairs: list, needs: JunctionNeeds
          ) -> JunctionPlan:
    road_map, elements = loaded
    minor, major, zone = conflict
    name = f"lane {minor.lanelet_id} giving way to {major.lanelet_id}"
    robot = lane_path(loaded, minor, _conflict_s(loaded, minor, zone),
                      (needs.approach_m + ROUTE_SLACK_M, needs.beyond_m + ROUTE_SLACK_M), needs.edge_extension_m)
    if len(set(robot.keys)) < len(robot.keys):
        raise SceneError(f"{name}: its route comes round to the same lane again")
    if robot.crossing_m < needs.approach_m:
        raise SceneError(f"{name}: approach too short ({robot.crossing_m:.0f} m)")
    if Route(robot.points).length_m - robot.crossing_m < needs.beyond_m - 1.0:
        raise SceneError(f"{name}: route too short past the junction")
    hidden = lane_path(loaded, major, _conflict_s(loaded, major, zone),
                       (needs.hidden_m + ROUTE_SLACK_M, needs.beyond_m + ROUTE_SLACK_M), needs.edge_extension_m)
    if hidden.crossing_m < needs.hidden_m:
        raise SceneError(f"{name}: major road too short before it ({hidden.crossing_m:.0f} m)")
    approach = robot.keys[:robot.keys.index(minor) + 1]
    if set(approach) & set(hidden.keys):
        raise SceneError(f"{name}: the robot's approach runs along the major road's route (it "
                         "would drive ahead of the car it gives way to)")
    polygons = road_map.static_polygons
    for path, start in ((robot, robot.crossing_m - needs.approach_m),
                        (hidden, hidden.crossing_m - needs.hidden_m)):
        if _hits_occluder(_needed_points(path, start, needs.beyond_m), polygons,
                          ROUTE_CLEARANCE_M):
            raise SceneError(f"{name}: a route runs through (or along) an occluder of the map")
    robot_start = Route(robot.points).point_at(robot.crossing_m - needs.approach_m)[0]
    hidden_start = Route(hidden.points).point_at(hidden.crossing_m - needs.hidden_m)[0]
    parked: tuple[np.ndarray, ...] = ()
    if not _blocked(robot_start, hidden_start, polygons):
        side = _side(hidden.points, hidden.crossing_m - needs.hidden_m, robot_start)
        cars = _parked_row(loaded, hidden, needs, side,
                           _needed_points(robot, robot.crossing_m - needs.approach_m,
                                          needs.beyond_m))
        if len(cars) < MIN_PARKED_CARS or not _blocked(robot_start, hidden_start,
                                                       polygons + tuple(cars)):
            raise SceneError(f"{name}: nothing hides the major road from the robot's approach "
                             "(no occluder of the map, no free curb for parked cars)")
        parked = tuple(cars)
    sensors = []
    for other, other_major, other_zone in pairs:
        if other_major not in hidden.keys or other in (minor, major) or other in robot.keys \
                or len(sensors) >= MAX_SENSORS:
            continue
        path = lane_path(loaded, other, _conflict_s(loaded, other, other_zone),
                         (needs.human_start_m + ROUTE_SLACK_M,
                          needs.beyond_m + ROUTE_SLACK_M), needs.edge_extension_m)
        if path.crossing_m < needs.human_start_m or set(path.keys) & set(robot.keys) \
                or _hits_occluder(_needed_points(path, path.crossing_m - needs.human_start_m,
                                                 needs.beyond_m),
                                  polygons + parked, ROUTE_CLEARANCE_M):
            continue
        start = Route(path.points).point_at(path.crossing_m - needs.human_start_m)[0]
        taken = [robot_start, hidden_start, *(Route(q.points).point_at(
            q.crossing_m - needs.human_start_m)[0] for q in sensors)]
        if min(np.linalg.norm(start - xy) for xy in taken) < MIN_START_GAP_M:
            continue
        sensors.append(path)
    return JunctionPlan(junction_id, robot, hidden, tuple(sensors), parked,
                        elements.lanes[minor].speed_limit_mps)

"""Where a paper situation can be built on a converted map: routes through its elements.

The crosswalk situation (Sun et al. 2019, Fig. 2) on a map's crosswalk: the robot's route
runs through the crosswalk along the map's lanes (the lane crossing it, its predecessors for
the approach and its successors beyond; at a fork the straightest continuation), a human
driver in the lane beside it in the same direction (a lane-change neighbour, or an adjacent
lane a car may not change to) hides a pedestrian waiting at the crosswalk's end on the human's
side; without such a lane, a parked car along the right curb hides the pedestrian.

`crosswalk_plan(loaded, crosswalk_id, needs)` gives the scene's geometry (CrosswalkPlan) or a
SceneError naming why it cannot be built there; `listing.scene_listing(loaded)` says it for every
element of a map (`marl-social scenes`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from marl_social.maps.elements import LaneKey
from marl_social.maps.errors import MapError
from marl_social.maps.geometry import points_in_polygon, polyline_crossings
from marl_social.sim.road_map import Route

SITUATIONS = ("crosswalk", "junction", "signal")
MIN_CROSSING_SIN = math.sin(math.radians(45.0))  # a lane crosses a walk at >= 45 deg
WALK_AXIS_MARGIN_M = 0.5  # the walk axis reaches this far past the crosswalk's ends [m]
PARKED_LENGTH_M, PARKED_WIDTH_M = 4.5, 1.8  # a parked car's footprint [m]
PARKED_CURB_GAP_M = 0.3  # between the lane's edge and a parked car [m]
PARKED_BEFORE_CROSSWALK_M = 3.0  # a parked car ends this far before the crosswalk [m]
PEDESTRIAN_CLEARANCE_M = 0.5  # a pedestrian's start keeps this far from every occluder [m]
SMOOTH_STEP_M, SMOOTH_HALF_WINDOW_M = 1.0, 4.0  # routes resampled and averaged (smooth_polyline)
ROUTE_CHECK_STEP_M = 1.0  # routes are checked against occluders at points this far apart [m]


class SceneError(MapError):
    """A scene cannot be built on a map element (one line naming the element and why)."""


class ScenarioNeeds(NamedTuple):
    """How much road a scene needs around its element.

    Attributes:
        approach_m: the robot's start before the crosswalk along its route [m].
        behind_start_m: route wanted behind the robot's start (not required) [m].
        beyond_m: route past the crosswalk (required) [m].
        human_lead_m: how far the human starts ahead of the robot [m].
        curb_offset_m: the pedestrian waits this far past the crosswalk's end [m].
        edge_extension_m: where the lanes end at the map's edge (a lane without predecessors
            or successors), a route may go on straight past it for up to this much [m].
    """

    approach_m: float = 60.0
    behind_start_m: float = 10.0
    beyond_m: float = 30.0
    human_lead_m: float = 20.0
    curb_offset_m: float = 1.0
    edge_extension_m: float = 40.0


DEFAULT_NEEDS = ScenarioNeeds()


class LanePath(NamedTuple):
    """A chain of lanes as one polyline.

    Attributes:
        keys: the lanes in travel order (LaneKeys).
        points: (P, 2) the chained centre lines [m].
        crossing_m: arc length at which it crosses the crosswalk's walk axis [m].
        width_m: the width of the lane crossing the crosswalk [m].
        extended_m: (before, after) how far it goes on straight past the map's edge [m].
    """

    keys: tuple[LaneKey, ...]
    points: np.ndarray
    crossing_m: float
    width_m: float
    extended_m: tuple[float, float] = (0.0, 0.0)


class CrosswalkPlan(NamedTuple):
    """The crosswalk situation's geometry on one crosswalk of a map.

    Attributes:
        crosswalk_id: the crosswalk lanelet's id.
        robot: the robot's LanePath.
        human: the human's LanePath (None: a parked car occludes instead).
        side: where the human (or the parked car) and the pedestrian are: +1 left, -1 right
            of the robot.
        parked_car: (4, 2) the parked car's footprint [m] (None with a human).
        pedestrian_path: (2, 2) the pedestrian's start on the curb and its route's end [m].
        speed_limit_mps: the robot's lane's speed limit [m/s].
    """

    crosswalk_id: int
    robot: LanePath
    human: LanePath | None
    side: int
    parked_car: np.ndarray | None
    pedestrian_path: np.ndarray
    speed_limit_mps: float


def _length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def _heading(points: np.ndarray, at_end: bool) -> float:
    d = points[-1] - points[-2] if at_end else points[1] - points[0]
    return math.atan2(d[1], d[0])


def _turn(a: float, b: float) -> float:
    """|b - a| wrapped to [0, pi] [rad]."""
    return abs((b - a + math.pi) % (2.0 * math.pi) - math.pi)


def walk_axis(crosswalk, margin_m: float = WALK_AXIS_MARGIN_M) -> np.ndarray:
    """(2, 2) the crosswalk's walking axis, curb to curb and margin_m beyond each end [m]."""
    along = np.array([math.cos(crosswalk.walk_heading_rad), math.sin(crosswalk.walk_heading_rad)])
    half = 0.5 * crosswalk.length_m + margin_m
    return np.array([crosswalk.center - half * along, crosswalk.center + half * along])


def crossing_lanes(loaded, crosswalk_id: int) -> dict[LaneKey, float]:
    """{lane: arc length [m] at which its centre line crosses the walk axis} of a crosswalk.

    Only lanes that cross the walk at MIN_CROSSING_SIN or steeper (not lanes running along it).
    """
    road_map, elements = loaded
    crosswalk = road_map.crosswalks[elements.crosswalks[crosswalk_id].index]
    axis = walk_axis(crosswalk)
    walk = axis[1] - axis[0]
    walk = walk / np.linalg.norm(walk)
    found = {}
    for key, lane in elements.lanes.items():
        line = road_map.lanes[lane.index].centerline
        s = polyline_crossings(line, axis)
        if len(s):
            _, heading = Route(line).point_at(float(s[0]))
            if abs(math.cos(float(heading)) * walk[1] - math.sin(float(heading)) * walk[0]) \
                    >= MIN_CROSSING_SIN:
                found[key] = float(s[0])
    return found


def _chain(loaded, key: LaneKey, wanted_m: float, backwards: bool) -> list[LaneKey]:
    """Lanes before (backwards) or after `key` until wanted_m [m] of them (the straightest)."""
    road_map, elements = loaded
    chain, total = [], 0.0
    current = key
    while total < wanted_m:
        here = road_map.lanes[elements.lanes[current].index].centerline
        options = elements.lanes[current].predecessors if backwards else \
            elements.lanes[current].successors
        options = [k for k in options if k not in chain and k != key]
        if not options:
            break
        heading = _heading(here, at_end=not backwards)

        def turn(k, heading=heading):
            other = road_map.lanes[elements.lanes[k].index].centerline
            return _turn(heading, _heading(other, at_end=backwards)), k

        current = min(options, key=turn)
        chain.append(current)
        total += _length(road_map.lanes[elements.lanes[current].index].centerline)
    return chain[::-1] if backwards else chain


def lane_path(loaded, key: LaneKey, crossing_m: float, reach: tuple[float, float],
              edge_extension_m: float = 0.0, then: tuple[LaneKey, ...] = ()) -> LanePath:
    """The chain of lanes through `key`, reach = (before, after) [m] of the crossing point.

    After `key` come the lanes of `then` (successors in turn: a chosen way through a
    junction), then the straightest continuation. Where the chain stops at the map's edge
    short of the reach, it goes on straight (along its end's heading) for up to
    edge_extension_m [m].
    """
    road_map, elements = loaded
    own = road_map.lanes[elements.lanes[key].index]
    before = _chain(loaded, key, reach[0] - crossing_m, backwards=True)
    chosen_m = sum(_length(road_map.lanes[elements.lanes[k].index].centerline) for k in then)
    after = [*then, *_chain(loaded, then[-1] if then else key,
                            reach[1] - (_length(own.centerline) - crossing_m) - chosen_m,
                            backwards=False)]
    keys = (*before, key, *after)
    parts = [road_map.lanes[elements.lanes[k].index].centerline for k in keys]
    points = [parts[0]]
    for part in parts[1:]:  # consecutive lanes share their end points: drop the repeat
        join = 1 if np.linalg.norm(part[0] - points[-1][-1]) < 1e-3 else 0
        points.append(part[join:])
    chained = np.concatenate(points)
    keep = np.ones(len(chained), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(chained, axis=0), axis=1) > 1e-3
    chained = chained[keep]
    crossing = sum(_length(p) for p in parts[:len(before)]) + crossing_m
    extended = [0.0, 0.0]
    if not elements.lanes[keys[0]].predecessors:  # the map's edge behind
        extended[0] = min(max(reach[0] - crossing, 0.0), edge_extension_m)
    if not elements.lanes[keys[-1]].successors:  # the map's edge ahead
        extended[1] = min(max(reach[1] - (_length(chained) - crossing), 0.0), edge_extension_m)
    if extended[0] > 0.0:
        back = chained[0] - chained[1]
        chained = np.vstack([chained[0] + extended[0] * back / np.linalg.norm(back), chained])
        crossing += extended[0]
    if extended[1] > 0.0:
        ahead = chained[-1] - chained[-2]
        chained = np.vstack([chained, chained[-1] + extended[1] * ahead / np.linalg.norm(ahead)])
    smooth = smooth_polyline(chained)
    crossing_xy = Route(chained).point_at(crossing)[0]
    crossing = float(Route(smooth).project(crossing_xy[None])[0][0])
    return LanePath(keys, smooth, crossing, own.width_m, (extended[0], extended[1]))


def smooth_polyline(points: np.ndarray, step_m: float = SMOOTH_STEP_M,
                    half_window_m: float = SMOOTH_HALF_WINDOW_M) -> np.ndarray:
    """(Q, 2) a polyline (P, 2) [m] resampled every step_m [m], averaged over a window.

    Each point is the mean over half_window_m [m] either side (the ends kept; past them the
    line goes on straight).

    A map's centre lines are digitized: a few degrees of kink between half-metre segments
    would read as tight curves (a planner's curvature speed bound), which the lanes are not.
    """
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    n = max(math.ceil(s[-1] / step_m), 1)
    half = max(round(half_window_m / step_m), 0)
    grid = np.linspace(-half * s[-1] / n, s[-1] + half * s[-1] / n, n + 1 + 2 * half)

    def at(u: np.ndarray) -> np.ndarray:  # linear inside, straight on past the ends
        xy = np.column_stack([np.interp(u, s, points[:, 0]), np.interp(u, s, points[:, 1])])
        head = (points[1] - points[0]) / s[1]
        tail = (points[-1] - points[-2]) / (s[-1] - s[-2])
        xy[u < 0] = points[0] + u[u < 0, None] * head
        xy[u > s[-1]] = points[-1] + (u[u > s[-1], None] - s[-1]) * tail
        return xy

    samples = at(grid)
    kernel = np.ones(2 * half + 1) / (2 * half + 1)
    smooth = np.column_stack([np.convolve(samples[:, k], kernel, mode="valid") for k in (0, 1)])
    smooth[0], smooth[-1] = points[0], points[-1]
    return smooth


def _hits_occluder(points: np.ndarray, polygons, clearance_m: float = 0.0) -> bool:
    """Whether any point (N, 2) [m] lies in (or within clearance_m of) an occluder."""
    for poly in polygons:
        lo, hi = poly.min(axis=0) - clearance_m, poly.max(axis=0) + clearance_m
        near = np.all((points >= lo) & (points <= hi), axis=1)
        if not near.any():
            continue
        if clearance_m == 0.0:
            if points_in_polygon(points[near], poly).any():
                return True
            continue
        route = Route(np.concatenate([poly, poly[:1]]))
        _, lateral, _ = route.project(points[near])
        if points_in_polygon(points[near], poly).any() or (np.abs(lateral) < clearance_m).any():
            return True
    return False


def _route_points(path: LanePath, start_m: float) -> np.ndarray:
    route = Route(path.points)
    s = np.arange(max(start_m, 0.0), route.length_m, ROUTE_CHECK_STEP_M)
    return route.point_at(s)[0]


def _side_of(path: LanePath, point: np.ndarray) -> int:
    """+1 if point lies left of the path at its crossing, else -1."""
    route = Route(path.points)
    xy, heading = route.point_at(path.crossing_m)
    rel = point - xy
    return 1 if math.cos(float(heading)) * rel[1] - math.sin(float(heading)) * rel[0] > 0 else -1


def _parked_car(path: LanePath, crosswalk, side: int) -> np.ndarray:
    """(4, 2) a parked car along the lane's `side` edge, just before the crosswalk [m]."""
    route = Route(path.points)
    near_edge = path.crossing_m - 0.5 * crosswalk.width_m - PARKED_BEFORE_CROSSWALK_M
    s_mid = near_edge - 0.5 * PARKED_LENGTH_M
    xy, heading = route.point_at(s_mid)
    along = np.array([math.cos(float(heading)), math.sin(float(heading))])
    normal = side * np.array([-along[1], along[0]])
    center = xy + (0.5 * path.width_m + PARKED_CURB_GAP_M + 0.5 * PARKED_WIDTH_M) * normal
    a, w = 0.5 * PARKED_LENGTH_M * along, 0.5 * PARKED_WIDTH_M * normal
    return np.array([center - a - w, center + a - w, center + a + w, center - a + w])


def crosswalk_plan(loaded, crosswalk_id: int, needs: ScenarioNeeds = DEFAULT_NEEDS,
                   occluder: str = "auto") -> CrosswalkPlan:
    """The crosswalk situation on one crosswalk of a map (module docstring).

    Args:
        loaded: the LoadedMap.
        crosswalk_id: the crosswalk lanelet's id.
        needs: how much road the scene needs.
        occluder: "auto" (a human beside the robot, else a parked car), "human" or "parked".

    Raises:
        SceneError: the map has no such crosswalk, or the situation cannot be built there
            (the message says why).
    """
    road_map, elements = loaded
    if crosswalk_id not in elements.crosswalks:
        raise SceneError(f"element {crosswalk_id} is no crosswalk of the map (its crosswalks: "
                         f"{', '.join(str(i) for i in sorted(elements.crosswalks)) or 'none'})")
    crossing = crossing_lanes(loaded, crosswalk_id)
    if not crossing:
        raise SceneError(f"crosswalk {crosswalk_id}: no lane a car may use crosses it")
    crosswalk = road_map.crosswalks[elements.crosswalks[crosswalk_id].index]
    reasons = []
    for option in _options(loaded, crossing, occluder):
        try:
            return _plan(loaded, crosswalk_id, crosswalk, option, needs)
        except SceneError as err:
            reasons.append(str(err))
    if not reasons:
        what = {"human": "a lane beside a crossing lane in the same direction",
                "parked": "a crossing lane with a free right curb",
                "auto": "a lane beside a crossing lane or a free right curb"}[occluder]
        reasons.append(f"no occluder place: needs {what}")
    raise _why_not(crosswalk_id, reasons)


def _why_not(crosswalk_id: int, reasons: list[str]) -> SceneError:
    """One SceneError listing the first three distinct reasons."""
    unique = list(dict.fromkeys(reasons))
    return SceneError(f"crosswalk {crosswalk_id}: " + "; ".join(unique[:3])
                     + ("; ..." if len(unique) > 3 else ""))


def _options(loaded, crossing: dict[LaneKey, float], occluder: str):
    """(robot lane, human lane or None, side, crossing) to try, best first.

    A human on the right, on the left, then a parked car on a right curb; each by lanelet id.
    """
    _, elements = loaded
    humans, parked = [], []
    for key in sorted(crossing):
        for side in (-1, 1):
            for beside in elements.lanes[key].beside(side):
                if beside in crossing:
                    humans.append((side != -1, key, beside, side))
        if not elements.lanes[key].beside(-1):
            parked.append((key, None, -1))
    ordered = [(k, b, s) for _, k, b, s in sorted(humans)] if occluder != "parked" else []
    if occluder != "human" and (occluder == "parked" or not humans):
        ordered += parked
    return [(key, beside, side, crossing) for key, beside, side in ordered]


def _plan(loaded, crosswalk_id: int, crosswalk, option, needs: ScenarioNeeds) -> CrosswalkPlan:
    road_map, elements = loaded
    key, beside, side, crossing = option
    lane_name = f"lane {key.lanelet_id}" + (" (inverted)" if key.inverted else "")
    before = needs.approach_m + needs.behind_start_m
    robot = lane_path(loaded, key, crossing[key], (before, needs.beyond_m),
                      needs.edge_extension_m)
    if robot.crossing_m < needs.approach_m:
        raise SceneError(f"{lane_name}: route too short before it ({robot.crossing_m:.0f} m "
                         f"of lanes, needs {needs.approach_m:.0f} m)")
    beyond = Route(robot.points).length_m - robot.crossing_m
    if beyond < needs.beyond_m - 1.0:
        raise SceneError(f"{lane_name}: route too short after it ({beyond:.0f} m of lanes, "
                         f"needs {needs.beyond_m:.0f} m)")
    polygons = road_map.static_polygons
    start = robot.crossing_m - needs.approach_m
    if _hits_occluder(_route_points(robot, start), polygons):
        raise SceneError(f"{lane_name}: its route runs through an occluder of the map")
    human, parked = None, None
    if beside is not None:
        human_before = needs.approach_m - needs.human_lead_m
        human = lane_path(loaded, beside, crossing[beside],
                          (human_before + needs.behind_start_m, needs.beyond_m),
                          needs.edge_extension_m)
        if human.crossing_m < human_before:
            raise SceneError(f"lane {beside.lanelet_id} beside {lane_name}: route too short "
                             f"before it ({human.crossing_m:.0f} m, needs {human_before:.0f} m)")
        if _hits_occluder(_route_points(human, human.crossing_m - human_before), polygons):
            raise SceneError(f"lane {beside.lanelet_id} beside {lane_name}: its route runs "
                             "through an occluder of the map")
    else:
        parked = _parked_car(robot, crosswalk, side)
        if _hits_occluder(parked, polygons) or any(
                points_in_polygon(parked, road_map.lanes[other.index].polygon()).any()
                for k, other in elements.lanes.items() if k not in robot.keys):
            raise SceneError(f"{lane_name}: no free curb for a parked car before the crosswalk")
    pedestrian = _pedestrian_path(crosswalk, robot, side, needs.curb_offset_m)
    if _hits_occluder(pedestrian[:1], polygons, PEDESTRIAN_CLEARANCE_M):
        raise SceneError(f"{lane_name}: the curb at the crosswalk's end is inside an occluder")
    return CrosswalkPlan(crosswalk_id, robot, human, side, parked, pedestrian,
                         elements.lanes[key].speed_limit_mps)


def _pedestrian_path(crosswalk, robot: LanePath, side: int, curb_offset_m: float) -> np.ndarray:
    """(2, 2) start (curb_offset_m past the crosswalk's end on `side`) and end of the walk [m]."""
    axis = walk_axis(crosswalk, 0.0)
    if _side_of(robot, axis[0]) != side:
        axis = axis[::-1]
    out = (axis[0] - axis[1]) / np.linalg.norm(axis[0] - axis[1])
    return np.array([axis[0] + curb_offset_m * out, axis[1] - 1.0 * out])

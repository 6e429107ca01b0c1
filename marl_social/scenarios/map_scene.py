"""A paper situation built around one element of a real map (maps/scenes.py).

`situation="crosswalk"` on a crosswalk of a Lanelet2 map (Sun et al. 2019, Fig. 2, on real
streets): the robot's route through the crosswalk along the map's lanes, a human driver in the
lane beside it in the same direction, human_lead_m ahead, hiding a pedestrian at the
crosswalk's end on the human's side (a parked car along the right curb where no such lane
exists), the map's occluders. The robot starts approach_m before the crosswalk. The scene's map
holds the map's lanes, crosswalks, stop lines, conflict zones, signals and occluders within
SCENE_MARGIN_M of the routes, in the map's own frame;
the robot's stages come from them as on any map. Where a
signal stands on the robot's approach, the map's cycle starts with its green (the situation is
the hidden pedestrian, not the light).

Variants: pedestrian = "crossing", "waiting" or "none", as in occluded_crosswalk; the same
randomization knobs (human_lead_m, human_speed_mps, human_beta, pedestrian_speed_mps,
pedestrian_start_delay_s).

`situation="junction"` (maps/junction_scenes.py, Fig. 1 b) and `situation="signal"`
(maps/signal_scenes.py, Fig. 1 c on a traffic light: the robot at rest at its red line turning
right, left-turners queued at theirs, cross traffic towards its line; the map's cycle started
at `phase` ("protected_left" or "cross_green"), `phase_elapsed_s` into it; the knobs and their
names are signalized_intersection's: n_humans, human_start_m, n_cross, cross_start_m,
cross_gap_m, cross_speed_mps, robot_start_back_m, human_beta).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from marl_social.maps import load_map
from marl_social.maps.junction_scenes import JunctionNeeds, junction_plan
from marl_social.maps.listing import scene_listing
from marl_social.maps.scenes import ScenarioNeeds, SceneError, crosswalk_plan
from marl_social.maps.signal_scenes import PHASE_VARIANTS, SignalNeeds, signal_plan_of
from marl_social.maps.traffic import TrafficRequest, traffic_paths
from marl_social.scenarios.base import (
    MAX_SENSOR_RANGE_M,
    MAX_VEHICLE_SPEED_MPS,
    HiddenAgent,
    Scenario,
    ScenarioLayout,
)
from marl_social.scenarios.crosswalk_agents import (
    CrosswalkParams,
    human_spec,
    pedestrian_spec,
    robot_spec,
)
from marl_social.sim.agent_spec import AgentSpec, VehicleParams
from marl_social.sim.road_map import RoadMap, Route, StopLine
from marl_social.sim.signals import SignalController

SITUATIONS = ("crosswalk", "junction", "signal")
HIDDEN_VARIANTS = ("near", "none")  # the junction's hidden car
OCCLUDERS = ("auto", "human", "parked")
SCENE_MARGIN_M = 30.0  # the scene's map: what lies within this of its routes [m]
MAX_APPROACH_M = 200.0  # the robot's farthest start before the crosswalk [m]
MAX_CURB_OFFSET_M = 3.0  # the pedestrian's farthest wait past the crosswalk's end [m]
SIGNAL_GREEN_AHEAD_M = 250.0  # signals this close ahead of the robot's start start green [m]
LEFT_TURNER_SPACING_M = 7.5  # queue pitch of the signal's left-turners (front to front) [m]
MAX_LEFT_TURNERS = 3
MAX_CROSS = 2
MAX_TRAFFIC = 20


@dataclass(frozen=True)
class MapSceneParams(CrosswalkParams):
    """Map scene parameters (SI units; the agents' in CrosswalkParams).

    Attributes:
        map: a built-in map's name ("karlsruhe") or the path of a Lanelet2 .osm file.
        element: the Lanelet2 id of the element the scene is built around (0: the map's first
            element where the situation can be built; `marl-social scenes MAP` lists them).
        situation: "crosswalk" (the robot, a human beside it and a hidden pedestrian),
            "junction" (the robot giving way, a hidden car, human sensors) or "signal" (right
            turn on red; left-turners and cross traffic; module docstring).
        occluder: what hides the pedestrian: "human" (a driver in the lane beside the
            robot's), "parked" (a car along the right curb) or "auto" (a human where a lane
            beside allows one, else a parked car).
        approach_m: the robot's start before the crosswalk along its route [m].
        pedestrian_curb_offset_m: how far past the crosswalk's end the pedestrian waits [m].
        hidden_vehicle: the junction's hidden car on the major road: "near" or "none".
        hidden_m: its start before the conflict point [m].
        hidden_speed_mps: its initial and desired speed [m/s].
        junction_approach_m: the robot's start before its conflict point at a junction [m].
        junction_robot_speed_mps: its initial speed there [m/s].
        human_start_m: each human sensor's start before its conflict point [m]; at a signal,
            the first left-turner's front before its stop line [m].
        sensor_speed_mps: the human sensors' initial speed [m/s] (their desired speed:
            human_desired_speed_mps, at most the lane's limit).
        phase: at a signal, the phase running at t = 0: "protected_left" (the left-turners'
            green, the cross traffic's red) or "cross_green".
        phase_elapsed_s: how long it has run at t = 0 [s] (less than its duration).
        n_humans: at a signal, left-turners (0-3), queued LEFT_TURNER_SPACING_M apart, at rest.
        n_cross: at a signal, cross cars (0-2); the first one's front cross_start_m before its
            line, the next cross_gap_m (front to front) behind it, at cross_speed_mps (also
            their desired speed) [m, m, m/s].
        cross_start_m, cross_gap_m, cross_speed_mps: see n_cross.
        robot_start_back_m: at a signal, how far the robot's front starts before its line (at
            rest) [m].
        n_traffic: extra human drivers on the map's lanes near the element (0-20, after the
            situation's agents; maps/traffic.py), starting at traffic_speed_mps (at most the
            robot's lane's limit; their desired speed human_desired_speed_mps, likewise).
        traffic_speed_mps: see n_traffic [m/s].
        junction_robot_half_fov_deg, junction_robot_sensor_range_m, junction_robot_epsilon:
            the robot's view and tail threshold at a junction or signal (the T-intersection's: it looks
            sideways along the major road; with the crosswalk's 0.02 it would wait for ever
            for cars that nothing can tell it about), in place of robot_half_fov_deg,
            robot_sensor_range_m and robot_epsilon.
    """

    map: str = "karlsruhe"
    element: int = 0
    situation: str = "crosswalk"
    occluder: str = "auto"
    approach_m: float = 60.0
    pedestrian_curb_offset_m: float = 1.0
    hidden_vehicle: str = "near"
    hidden_m: float = 40.0
    hidden_speed_mps: float = 8.0
    junction_approach_m: float = 25.0
    junction_robot_speed_mps: float = 5.0
    human_start_m: float = 15.0
    sensor_speed_mps: float = 5.0
    junction_robot_half_fov_deg: float = 110.0
    junction_robot_sensor_range_m: float = 60.0
    junction_robot_epsilon: float = 0.05
    phase: str = "protected_left"
    phase_elapsed_s: float = 0.5
    n_humans: int = 2
    n_cross: int = 2
    cross_start_m: float = 40.0
    cross_gap_m: float = 18.0
    cross_speed_mps: float = 12.0
    robot_start_back_m: float = 0.5
    n_traffic: int = 0
    traffic_speed_mps: float = 5.0

    def __post_init__(self):
        super().__post_init__()
        for name in ("map", "situation", "occluder"):
            self._check(isinstance(getattr(self, name), str), name, "must be a string")
        self._check(self.situation in SITUATIONS, "situation",
                    f"must be one of {SITUATIONS}")
        self._check(self.phase in PHASE_VARIANTS, "phase", f"must be one of {PHASE_VARIANTS}")
        self._check_range("phase_elapsed_s", 0.0, 3600.0, "s")
        self._check(0 <= self.n_humans <= MAX_LEFT_TURNERS, "n_humans",
                    f"must be in [0, {MAX_LEFT_TURNERS}]")
        self._check(0 <= self.n_cross <= MAX_CROSS, "n_cross", f"must be in [0, {MAX_CROSS}]")
        self._check_range("cross_start_m", 0.0, MAX_APPROACH_M, "m")
        self._check_range("cross_gap_m", VehicleParams().length_m + 1.0, MAX_APPROACH_M, "m")
        self._check_range("cross_speed_mps", 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check_range("robot_start_back_m", 0.0, MAX_APPROACH_M, "m")
        self._check(0 <= self.n_traffic <= MAX_TRAFFIC, "n_traffic",
                    f"must be in [0, {MAX_TRAFFIC}]")
        self._check_range("traffic_speed_mps", 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check(self.occluder in OCCLUDERS, "occluder", f"must be one of {OCCLUDERS}")
        self._check(self.hidden_vehicle in HIDDEN_VARIANTS, "hidden_vehicle",
                    f"must be one of {HIDDEN_VARIANTS}")
        self._check_range("hidden_m", 10.0, MAX_APPROACH_M, "m")
        self._check_range("junction_approach_m", 5.0, MAX_APPROACH_M, "m")
        self._check_range("human_start_m", 2.0, MAX_APPROACH_M, "m")
        for name in ("hidden_speed_mps", "junction_robot_speed_mps", "sensor_speed_mps"):
            self._check_range(name, 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check_range("junction_robot_half_fov_deg", 0.0, 180.0, "deg", low_open=True)
        self._check_range("junction_robot_sensor_range_m", 0.0, MAX_SENSOR_RANGE_M, "m",
                          low_open=True)
        self._check(0.0 <= self.junction_robot_epsilon < 1.0, "junction_robot_epsilon",
                    "must be in [0, 1)")
        self._check(self.element >= 0, "element", "must be a Lanelet2 id (>= 0; 0: the first)")
        self._check_range("approach_m", 10.0, MAX_APPROACH_M, "m")
        self._check_range("pedestrian_start_delay_s", 0.0, 3600.0, "s")
        self._check_range("human_lead_m", 5.0, self.approach_m, "m")
        self._check_range("pedestrian_curb_offset_m", 0.0, MAX_CURB_OFFSET_M, "m")


def _near(points: np.ndarray, box: tuple[float, float, float, float]) -> bool:
    """Whether any point (N, 2) [m] lies in box (xmin, xmax, ymin, ymax) [m]."""
    x0, x1, y0, y1 = box
    return bool(np.any((points[:, 0] >= x0) & (points[:, 0] <= x1)
                       & (points[:, 1] >= y0) & (points[:, 1] <= y1)))


def scene_road_map(full: RoadMap, box: tuple[float, float, float, float],
                   extra_polygons: tuple[np.ndarray, ...] = (),
                   first_crosswalk: int = -1) -> RoadMap:
    """The part of a map within box (xmin, xmax, ymin, ymax) [m], in the map's frame.

    Lanes, crosswalks (full.crosswalks[first_crosswalk] first, the scene's crosswalk: the
    metrics' and the episode's stopping rules' "first crosswalk"; -1: the map's order),
    occluders and conflict zones with a point in the box; stop lines on
    the kept lanes (a lane-less one within the box); the signal heads of the kept stop lines
    with the map's plan; indices renumbered; extra_polygons added to the occluders. No
    routes.
    """
    lane_ids = [i for i, lane in enumerate(full.lanes) if _near(lane.centerline, box)]
    new_lane = {old: new for new, old in enumerate(lane_ids)}
    lines, new_line = [], {}
    for i, line in enumerate(full.stop_lines):
        if line.lane in new_lane or (line.lane == -1 and _near(line.segment, box)):
            new_line[i] = len(lines)
            lines.append(StopLine(line.segment, line.kind, new_lane.get(line.lane, -1)))
    heads = tuple(dataclasses.replace(h, stop_line=new_line[h.stop_line])
                  for h in full.signal_heads if h.stop_line in new_line)
    zones = tuple(dataclasses.replace(z, priority_lanes=tuple(
        new_lane[i] for i in z.priority_lanes if i in new_lane))
        for z in full.conflict_zones if _near(z.polygon, box))
    crosswalk_ids = [i for i, c in enumerate(full.crosswalks)
                     if i != first_crosswalk and _near(c.polygon(), box)]
    if first_crosswalk >= 0:
        crosswalk_ids.insert(0, first_crosswalk)
    return RoadMap(
        lanes=tuple(full.lanes[i] for i in lane_ids),
        crosswalks=tuple(full.crosswalks[i] for i in crosswalk_ids),
        static_polygons=tuple(p for p in full.static_polygons if _near(p, box))
        + tuple(extra_polygons),
        speed_limit_mps=full.speed_limit_mps,
        extent=box,
        stop_lines=tuple(lines),
        conflict_zones=zones, signal_heads=heads,
        signal_plan=full.signal_plan if heads else None)


class MapScene(Scenario):
    """A paper situation around one element of a Lanelet2 map (module docstring)."""

    name = "map_scene"
    params_cls = MapSceneParams
    variants = ({"pedestrian": "crossing"}, {"pedestrian": "waiting"}, {"pedestrian": "none"})

    def __init__(self, **overrides):
        super().__init__(**overrides)
        p: MapSceneParams = self.params
        loaded = load_map(p.map)
        element = p.element
        if element == 0:
            buildable = [e.element for e in scene_listing(loaded)
                         if e.situation == p.situation and not e.reason]
            if not buildable:
                raise SceneError(f"map {p.map}: no element where a {p.situation} scene can be "
                                 "built (`marl-social scenes` says why)")
            element = buildable[0]
        self.element_id = element
        if p.situation == "junction":
            self.plan = junction_plan(loaded, element, JunctionNeeds(
                approach_m=p.junction_approach_m, hidden_m=p.hidden_m,
                human_start_m=p.human_start_m))
            self.crosswalk_index = -1
            self.road_map = self._junction_map(loaded.road_map)
        elif p.situation == "signal":
            self.plan = signal_plan_of(loaded, element, self._signal_needs())
            phase = loaded.road_map.signal_plan.phases[
                self.plan.phase_indices[PHASE_VARIANTS.index(p.phase)]]
            if p.phase_elapsed_s >= phase.duration_s:
                raise SceneError(f"phase_elapsed_s {p.phase_elapsed_s:g} s: must be less than "
                                 f"the {p.phase} phase's {phase.duration_s:g} s on this map")
            self.crosswalk_index = -1
            self.road_map = self._signal_map(loaded.road_map)
        else:
            self._crosswalk(loaded, element)
        self.traffic = self._traffic(loaded)

    def _crosswalk(self, loaded, element: int) -> None:
        """The crosswalk situation's plan and map (or a SceneError)."""
        p: MapSceneParams = self.params
        if element not in loaded.elements.crosswalks:
            known = any(element in table for table in (
                loaded.elements.junctions, loaded.elements.signals, loaded.elements.stop_lines,
                loaded.elements.lanes and {k.lanelet_id for k in loaded.elements.lanes}))
            what = "is no crosswalk" if known else "is no element"
            raise SceneError(f"map {p.map}: element {element} {what} of the map, so no "
                             f"{p.situation} scene (its crosswalks: "
                             + (", ".join(str(i) for i in sorted(loaded.elements.crosswalks))
                                or "none") + ")")
        needs = ScenarioNeeds(approach_m=p.approach_m, human_lead_m=p.human_lead_m,
                              curb_offset_m=p.pedestrian_curb_offset_m)
        self.plan = crosswalk_plan(loaded, element, needs, p.occluder)
        self.crosswalk_index = loaded.elements.crosswalks[element].index
        self.road_map = self._scene_map(loaded.road_map)

    def _situation_paths(self) -> list:
        """The LanePaths of the situation's roles."""
        plan = self.plan
        if self.params.situation == "junction":
            return [plan.robot, plan.hidden, *plan.sensors]
        if self.params.situation == "signal":
            return [plan.robot, plan.cross, plan.left_turn]
        return [plan.robot] + ([plan.human] if plan.human is not None else [])

    def _traffic(self, loaded) -> tuple:
        """n_traffic routes near the element (maps/traffic.py; crossing_m: each start)."""
        p: MapSceneParams = self.params
        if p.n_traffic == 0:
            return ()
        starts = np.array([spec.initial_state[:2] for spec, _ in self._situation_agents()])
        avoid = frozenset(k for path in self._situation_paths() for k in path.keys)
        centre = Route(self.plan.robot.points).point_at(self.plan.robot.crossing_m)[0]
        paths = traffic_paths(loaded, TrafficRequest(p.n_traffic, centre, self.road_map.extent,
                                                     starts, avoid))
        if len(paths) < p.n_traffic:
            raise SceneError(f"map {p.map}: room for {len(paths)} traffic cars near element "
                             f"{self.element_id}, n_traffic={p.n_traffic} asked for")
        return paths

    def _scene_map(self, full: RoadMap) -> RoadMap:
        plan = self.plan
        points = [plan.robot.points, plan.pedestrian_path]
        if plan.human is not None:
            points.append(plan.human.points)
        everything = np.concatenate(points)
        lo, hi = everything.min(axis=0) - SCENE_MARGIN_M, everything.max(axis=0) + SCENE_MARGIN_M
        extra = () if plan.parked_car is None else (plan.parked_car,)
        return scene_road_map(full, (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])),
                              extra, self.crosswalk_index)

    def _junction_map(self, full: RoadMap) -> RoadMap:
        plan = self.plan
        everything = np.concatenate([plan.robot.points, plan.hidden.points,
                                     *(path.points for path in plan.sensors)])
        lo, hi = everything.min(axis=0) - SCENE_MARGIN_M, everything.max(axis=0) + SCENE_MARGIN_M
        return scene_road_map(full, (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])),
                              plan.parked_cars)

    def _signal_needs(self) -> SignalNeeds:
        """The road the signal situation needs before each line, from the agents' places."""
        p: MapSceneParams = self.params
        length = VehicleParams().length_m
        return SignalNeeds(
            robot_back_m=p.robot_start_back_m + length,
            cross_back_m=p.cross_start_m + max(p.n_cross - 1, 0) * p.cross_gap_m + length,
            left_back_m=p.human_start_m + max(p.n_humans - 1, 0) * LEFT_TURNER_SPACING_M
            + length)

    def _signal_map(self, full: RoadMap) -> RoadMap:
        """The scene's map; the zones of the robot's turn give the other lane the right of way."""
        plan = self.plan
        zones = list(full.conflict_zones)
        for zone, *lanes in plan.give_way:
            zones[zone] = dataclasses.replace(zones[zone], priority_lanes=tuple(lanes))
        full = dataclasses.replace(full, conflict_zones=tuple(zones))
        everything = np.concatenate([plan.robot.points, plan.cross.points,
                                     plan.left_turn.points])
        lo, hi = everything.min(axis=0) - SCENE_MARGIN_M, everything.max(axis=0) + SCENE_MARGIN_M
        return scene_road_map(full, (float(lo[0]), float(hi[0]), float(lo[1]), float(hi[1])))

    def hidden_agent(self) -> HiddenAgent | None:
        """What the scene hides (removed in the counterfactual).

        The pedestrian, behind the human's (or the parked) car (pedestrian="none"); at a
        junction, the car on the major road (hidden_vehicle="none"); at a signal, no agent:
        the cross traffic's phase (the counterfactual is the other phase).
        """
        p: MapSceneParams = self.params
        if p.situation == "signal":  # the cross traffic's phase (signalized_intersection's)
            other = next(phase for phase in PHASE_VARIANTS if phase != p.phase)
            return HiddenAgent((), {"phase": other}, f"phase_{p.phase}")
        if p.situation == "junction":
            if p.hidden_vehicle == "none":
                return None
            return HiddenAgent((f"human_{len(self.plan.sensors)}",), {"hidden_vehicle": "none"},
                               "p_vehicle")
        if p.pedestrian == "none":
            return None
        return HiddenAgent(("pedestrian_0",), {"pedestrian": "none"}, "p_pedestrian")

    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        """Robot, human (or none: a parked car) and pedestrian on the scene's map (no rng)."""
        p: MapSceneParams = self.params
        specs, routes = [], {}
        agents = self._situation_agents()
        agents += self._traffic_cars(sum(spec.role == "human" for spec, _ in agents))
        for spec, route in agents:
            specs.append(spec)
            routes[spec.name] = route
        base = self.road_map
        road_map = RoadMap(lanes=base.lanes, crosswalks=base.crosswalks,
                           static_polygons=base.static_polygons, routes=routes,
                           speed_limit_mps=self.plan.speed_limit_mps, extent=base.extent,
                           stop_lines=base.stop_lines, conflict_zones=base.conflict_zones,
                           signal_heads=base.signal_heads, signal_plan=base.signal_plan)
        return ScenarioLayout(road_map, tuple(specs), p, self._signals(routes["robot_0"]))

    def _situation_agents(self) -> list[tuple[AgentSpec, Route]]:
        """The situation's agents and routes (robot first)."""
        p: MapSceneParams = self.params
        if p.situation == "junction":
            return [self._junction_robot(), *self._sensors(), *self._hidden_car()]
        if p.situation == "signal":
            return [self._signal_robot(), *self._left_turners(), *self._cross_traffic()]
        return [self._robot(), *self._human(), *self._pedestrian()]

    def _traffic_cars(self, first: int) -> list[tuple[AgentSpec, Route]]:
        """The traffic: human_<first> ... at traffic_speed_mps, at most their lane's limit."""
        p: MapSceneParams = self.params
        out = []
        for k, path in enumerate(self.traffic):
            name = f"human_{first + k}"
            route = Route(path.points, name)
            limit = self.plan.speed_limit_mps
            spec = human_spec(p, name, self._start(route, path.crossing_m,
                                                   min(p.traffic_speed_mps, limit)))
            out.append((dataclasses.replace(spec, v_desired_mps=min(
                p.human_desired_speed_mps, limit)), route))
        return out

    def _signals(self, robot_route: Route) -> SignalController | None:
        """The map's cycle, started at the phase that shows the robot's approach green.

        The crosswalk situation is about the hidden pedestrian: a signal ahead of the robot
        (SIGNAL_GREEN_AHEAD_M or less past its start) starts its green; else the cycle's start.
        """
        plan = self.road_map.signal_plan
        if plan is None:
            return None
        p: MapSceneParams = self.params
        if p.situation == "signal":
            return SignalController(plan, self.plan.phase_indices[PHASE_VARIANTS.index(p.phase)],
                                    p.phase_elapsed_s)
        start_m = self.plan.robot.crossing_m - (p.junction_approach_m if p.situation == "junction"
                                                else p.approach_m)
        lines = {i for i, line in enumerate(self.road_map.stop_lines)
                 if any(0.0 <= s - start_m <= SIGNAL_GREEN_AHEAD_M
                        for s in robot_route.segment_crossings(line.segment))}
        groups = {h.group for h in self.road_map.signal_heads if h.stop_line in lines}
        phase = next((k for k, ph in enumerate(plan.phases) if groups <= set(ph.green)), 0)
        return SignalController(plan, phase, 0.0)

    @staticmethod
    def _start(route: Route, s_m: float, speed_mps: float) -> np.ndarray:
        xy, heading = route.point_at(s_m)
        return np.array([xy[0], xy[1], float(heading), speed_mps])

    def _robot(self) -> tuple[AgentSpec, Route]:
        p: MapSceneParams = self.params
        route = Route(self.plan.robot.points, "robot_0")
        start = self._start(route, self.plan.robot.crossing_m - p.approach_m, p.robot_speed_mps)
        return robot_spec(p, start), route

    def _junction_robot(self) -> tuple[AgentSpec, Route]:
        p: MapSceneParams = self.params
        route = Route(self.plan.robot.points, "robot_0")
        start = self._start(route, self.plan.robot.crossing_m - p.junction_approach_m,
                            min(p.junction_robot_speed_mps, self.plan.speed_limit_mps))
        junction = dataclasses.replace(p, robot_half_fov_deg=p.junction_robot_half_fov_deg,
                                       robot_sensor_range_m=p.junction_robot_sensor_range_m,
                                       robot_epsilon=p.junction_robot_epsilon)
        return robot_spec(junction, start), route

    def _signal_robot(self) -> tuple[AgentSpec, Route]:
        """The robot at rest, its front robot_start_back_m before its line, the junction's view."""
        p: MapSceneParams = self.params
        route = Route(self.plan.robot.points, "robot_0")
        half = 0.5 * VehicleParams().length_m
        start = self._start(route, self.plan.robot.crossing_m - p.robot_start_back_m - half, 0.0)
        view = dataclasses.replace(p, robot_half_fov_deg=p.junction_robot_half_fov_deg,
                                   robot_sensor_range_m=p.junction_robot_sensor_range_m,
                                   robot_epsilon=p.junction_robot_epsilon)
        return robot_spec(view, start), route

    def _left_turners(self) -> list[tuple[AgentSpec, Route]]:
        """n_humans at rest in the left-turn lane, human_start_m and LEFT_TURNER_SPACING_M apart."""
        p: MapSceneParams = self.params
        return self._queue(self.plan.left_turn, range(p.n_humans),
                           (p.human_start_m, LEFT_TURNER_SPACING_M), 0.0,
                           min(p.human_desired_speed_mps, self.plan.speed_limit_mps))

    def _cross_traffic(self) -> list[tuple[AgentSpec, Route]]:
        """n_cross cars towards their line at cross_speed_mps, cross_gap_m apart."""
        p: MapSceneParams = self.params
        return self._queue(self.plan.cross, range(p.n_humans, p.n_humans + p.n_cross),
                           (p.cross_start_m, p.cross_gap_m), p.cross_speed_mps,
                           p.cross_speed_mps)

    def _queue(self, path, indices, spacing_m: tuple, speed_mps: float,
               v_desired_mps: float) -> list[tuple[AgentSpec, Route]]:
        """Human drivers queued on `path` before its crossing point, one per index.

        Args:
            path: the lane path they drive (its points and crossing_m [m]).
            indices: their agent numbers (human_<k>).
            spacing_m: (the first car's front before the crossing point, the gap between
                consecutive cars) [m].
            speed_mps: their initial speed [m/s].
            v_desired_mps: their desired speed [m/s].
        """
        p: MapSceneParams = self.params
        first_m, gap_m = spacing_m
        half = 0.5 * VehicleParams().length_m
        out = []
        for j, k in enumerate(indices):
            name = f"human_{k}"
            route = Route(path.points, name)
            s = path.crossing_m - first_m - half - gap_m * j
            spec = human_spec(p, name, self._start(route, s, speed_mps))
            out.append((dataclasses.replace(spec, v_desired_mps=v_desired_mps), route))
        return out

    def _sensors(self) -> list[tuple[AgentSpec, Route]]:
        """The human sensors, human_start_m before their conflict points (human_0, ...)."""
        p: MapSceneParams = self.params
        out = []
        for k, path in enumerate(self.plan.sensors):
            route = Route(path.points, f"human_{k}")
            start = self._start(route, path.crossing_m - p.human_start_m, p.sensor_speed_mps)
            spec = human_spec(p, route.name, start)
            out.append((dataclasses.replace(spec, v_desired_mps=min(
                p.human_desired_speed_mps, self.plan.speed_limit_mps)), route))
        return out

    def _hidden_car(self) -> list[tuple[AgentSpec, Route]]:
        """The car on the major road, hidden_m before the conflict point (last; none: [])."""
        p: MapSceneParams = self.params
        if p.hidden_vehicle == "none":
            return []
        name = f"human_{len(self.plan.sensors)}"
        route = Route(self.plan.hidden.points, name)
        start = self._start(route, self.plan.hidden.crossing_m - p.hidden_m, p.hidden_speed_mps)
        spec = human_spec(p, name, start)
        return [(dataclasses.replace(spec, v_desired_mps=p.hidden_speed_mps), route)]

    def _human(self) -> list[tuple[AgentSpec, Route]]:
        p: MapSceneParams = self.params
        if self.plan.human is None:
            return []
        route = Route(self.plan.human.points, "human_0")
        start_m = self.plan.human.crossing_m - (p.approach_m - p.human_lead_m)
        return [(human_spec(p, "human_0", self._start(route, start_m, p.human_speed_mps)),
                 route)]

    def _pedestrian(self) -> list[tuple[AgentSpec, Route]]:
        p: MapSceneParams = self.params
        if p.pedestrian == "none":
            return []
        start, end = self.plan.pedestrian_path
        heading = math.atan2(end[1] - start[1], end[0] - start[0])
        return [(pedestrian_spec(p, start, heading),
                 Route(self.plan.pedestrian_path, "pedestrian_0"))]

"""The paper's T-intersection (Sun et al. 2019, section I, Fig. 1 b): right turn at a stop sign.

Right-hand traffic. The main road runs east-west along y = 0: one eastbound lane (south,
travelling +x), and north of it a westbound left-turn-only lane and a westbound through lane.
A parking lane along the south curb holds a row of parked cars west of the junction. The minor
road (the stem) comes from the south along x = 0 (northbound lane east of its centre line,
southbound lane west of it) and has a stop sign: a stop line across the northbound lane at the
south curb.

* The robot V0 (`robot_0`) waits at the stem's stop line and wants to turn right (east). It must
  yield to eastbound traffic coming from its left (west), but the parked cars hide that
  direction from it.
* The human drivers V1, V2 (`human_0` ... `human_<n-1>`, `n_humans` of them) approach in the
  westbound left-turn-only lane and turn left into the stem, across the eastbound lane. They
  see the eastbound lane; if an eastbound car is near they wait for it (the conflict-zone cost
  of agents/human.py), else they turn.
* The hidden car V3 (`human_<n_humans>`, absent for hidden_vehicle="none") drives east in the
  eastbound lane, starting hidden_near_m ("near": close enough that the left-turners must wait)
  or hidden_far_m ("far": far enough that they need not) west of the stem.

Conflict zones (sim/road_map.ConflictZone, priority: the eastbound lane): "left_turn_crossing",
where the left-turners cross the eastbound lane, and "right_turn_merge", where the robot joins
it. Geometry (lane centres, turning radii, the parking lane) is in the constants below.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import (
    MAX_VEHICLE_SPEED_MPS,
    HiddenAgent,
    Scenario,
    ScenarioLayout,
)
from marl_social.scenarios.intersection_agents import (
    IntersectionParams,
    human_spec,
    robot_spec,
)
from marl_social.scenarios.intersections import arc_points, box, parked_row, polyline
from marl_social.scenarios.roads import LANE_WIDTH_M
from marl_social.sim.agent_spec import AgentSpec, VehicleParams
from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route, StopLine

# -- the main road (y = 0 is its centre line between the two directions)
EASTBOUND_Y_M = -0.5 * LANE_WIDTH_M  # eastbound lane centre [m]
LEFT_TURN_LANE_Y_M = 0.5 * LANE_WIDTH_M  # westbound left-turn-only lane centre [m]
WESTBOUND_Y_M = 1.5 * LANE_WIDTH_M  # westbound through lane centre [m]
PARKING_LANE_WIDTH_M = 2.5  # parking lane along the south curb [m]
SOUTH_CURB_Y_M = -LANE_WIDTH_M - PARKING_LANE_WIDTH_M  # [m]
NORTH_CURB_Y_M = 2.0 * LANE_WIDTH_M  # [m]
MAIN_WEST_X_M = -250.0  # the main road's west end [m]
MAIN_EAST_X_M = 120.0  # its east end [m]
LEFT_TURN_LANE_START_X_M = 80.0  # the left-turn-only lane begins here [m]
# -- the stem (minor road from the south, x = 0 is its centre line)
NORTHBOUND_X_M = 0.5 * LANE_WIDTH_M  # the robot's lane [m]
SOUTHBOUND_X_M = -0.5 * LANE_WIDTH_M  # the left-turners' exit lane [m]
STEM_SOUTH_Y_M = -60.0  # the stem's south end [m]
STOP_LINE_Y_M = SOUTH_CURB_Y_M  # stop line across the northbound lane [m]
# -- turning paths (circular arcs between straight pieces)
RIGHT_TURN_RADIUS_M = 5.0  # the robot's right turn, northbound -> eastbound [m]
LEFT_TURN_RADIUS_M = LEFT_TURN_LANE_Y_M - STOP_LINE_Y_M  # westbound -> southbound [m]
LEFT_TURN_START_X_M = SOUTHBOUND_X_M + LEFT_TURN_RADIUS_M  # where the left turn begins [m]
# -- conflict zones: the eastbound lane where the left-turners cross it / the robot joins it
CROSSING_WEST_X_M = -4.0  # [m]
CROSSING_MERGE_X_M = 2.5  # boundary between the two zones [m]
MERGE_EAST_X_M = 14.0  # [m]
# -- parked cars and the agents' places
PARKED_Y_M = -LANE_WIDTH_M - 0.5 * PARKING_LANE_WIDTH_M  # parked cars' centre line [m]
PARKED_ROW_NEAR_X_M = -6.0  # the row begins this far west of the stem's centre line [m]
PARKED_ROW_LENGTH_M = 50.0  # and runs this far west [m]
PARKED_CAR = VehicleParams()  # parked cars have the default car footprint
HUMAN_SPACING_M = 12.0  # gap between successive left-turners' start positions [m]
EXTENT = (-70.0, 45.0, -35.0, 15.0)  # the area worth drawing [m]
HIDDEN_VARIANTS = ("none", "near", "far")
MAX_HUMANS = 3
MAX_PARKED_GAP_M = 20.0  # largest gap between parked cars [m]
# theta_R: the robot values comfort more than the default driver model (as in the crosswalk)


@dataclass(frozen=True)
class TIntersectionParams(IntersectionParams):
    """T-intersection parameters (SI units).

    The humans' (left-turners and V3) and the robot's parameters are IntersectionParams'
    (scenarios/intersection_agents.py); the fields below are this scenario's own.

    Attributes:
        hidden_vehicle: "none" (no eastbound car), "near" (it starts hidden_near_m west of the
            stem) or "far" (hidden_far_m west of it).
        hidden_near_m, hidden_far_m: V3's start distance west of the stem's centre line [m].
        hidden_speed_mps: V3's initial and desired speed [m/s].
        n_humans: left-turners (0-3); human_0 starts human_start_m before its turn, the next
            ones HUMAN_SPACING_M apart behind it.
        human_start_m: how far before the start of its turn human_0 starts [m].
        human_speed_mps, human_desired_speed_mps: left-turners' initial and cruise speeds [m/s].
        parked_gap_m: free space between two parked cars [m].
        robot_start_back_m: how far the robot's front starts behind the stop line [m].
        robot_desired_speed_mps, robot_sensor_range_m, robot_epsilon: IntersectionParams'
            fields with this scenario's defaults (11 m/s, 60 m, 0.05).
    """

    hidden_vehicle: str = "near"
    hidden_near_m: float = 40.0
    hidden_far_m: float = 140.0
    hidden_speed_mps: float = 11.0
    n_humans: int = 2
    human_start_m: float = 12.0
    human_speed_mps: float = 6.0
    human_desired_speed_mps: float = 11.0
    parked_gap_m: float = 1.0
    robot_start_back_m: float = 0.5
    robot_desired_speed_mps: float = 11.0
    robot_sensor_range_m: float = 60.0
    # above one arrival bin's long-run belief (hidden cars arriving at 0.05/s dwell about 1 s
    # in a 10 m bin, split over 2 speed bins: ~0.025): with 0.02 the robot would wait forever
    # for cars arriving where nothing can tell it about them
    robot_epsilon: float = 0.05

    def __post_init__(self):
        super().__post_init__()
        self._check(self.hidden_vehicle in HIDDEN_VARIANTS, "hidden_vehicle",
                    f"must be one of {HIDDEN_VARIANTS}")
        self._check(0 <= self.n_humans <= MAX_HUMANS, "n_humans", f"must be in [0, {MAX_HUMANS}]")
        west_room = -MAIN_WEST_X_M - 10.0
        self._check_range("hidden_near_m", 10.0, west_room, "m")
        self._check_range("hidden_far_m", 10.0, west_room, "m")
        self._check(self.hidden_far_m > self.hidden_near_m, "hidden_far_m",
                    f"must be greater than hidden_near_m ({self.hidden_near_m:g} m)")
        max_start = LEFT_TURN_LANE_START_X_M - LEFT_TURN_START_X_M - HUMAN_SPACING_M * MAX_HUMANS
        self._check_range("human_start_m", 0.0, max_start, "m")
        for name in ("hidden_speed_mps", "human_speed_mps", "human_desired_speed_mps"):
            self._check_range(name, 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check_range("parked_gap_m", 0.0, MAX_PARKED_GAP_M, "m")
        self._check_range("robot_start_back_m", 0.0, -STEM_SOUTH_Y_M + STOP_LINE_Y_M - 10.0, "m")


class TIntersection(Scenario):
    """Paper Fig. 1 b: the robot turns right at a stop sign; parked cars hide traffic from the left."""

    name = "t_intersection"
    params_cls = TIntersectionParams
    variants = ({"hidden_vehicle": "near"}, {"hidden_vehicle": "far"},
                {"hidden_vehicle": "none"})

    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        """Road, robot, left-turners and the hidden car (the layout does not depend on rng)."""
        p: TIntersectionParams = self.params
        lanes, zones, stop_line = self._road()
        robot, robot_route = self._robot()
        agents, routes = [robot], {robot.name: robot_route}
        for spec, route in self._left_turners() + self._hidden():
            agents.append(spec)
            routes[spec.name] = route
        road_map = RoadMap(
            lanes=lanes, crosswalks=(), static_polygons=tuple(self._parked_cars()),
            routes=routes, speed_limit_mps=p.speed_limit_mps, extent=EXTENT,
            stop_lines=(stop_line,), conflict_zones=zones,
        )
        return ScenarioLayout(road_map, tuple(agents), p)

    def hidden_agent(self) -> HiddenAgent | None:
        """V3, hidden by the parked cars (removed: hidden_vehicle="none")."""
        p: TIntersectionParams = self.params
        if p.hidden_vehicle == "none":
            return None
        return HiddenAgent((f"human_{p.n_humans}",), {"hidden_vehicle": "none"}, "p_vehicle")

    # -- paths -------------------------------------------------------------------------------
    @staticmethod
    def left_turn_path() -> np.ndarray:
        """(P, 2) westbound left-turn lane -> arc -> southbound stem lane [m]."""
        centre = (LEFT_TURN_START_X_M, STOP_LINE_Y_M)
        return polyline([[LEFT_TURN_LANE_START_X_M, LEFT_TURN_LANE_Y_M]],
                        arc_points(centre, LEFT_TURN_RADIUS_M, 0.5 * math.pi, math.pi),
                        [[SOUTHBOUND_X_M, STEM_SOUTH_Y_M]])

    @staticmethod
    def right_turn_path() -> np.ndarray:
        """(P, 2) northbound stem lane -> arc -> eastbound lane [m]."""
        centre = (NORTHBOUND_X_M + RIGHT_TURN_RADIUS_M, EASTBOUND_Y_M - RIGHT_TURN_RADIUS_M)
        return polyline([[NORTHBOUND_X_M, STEM_SOUTH_Y_M]],
                        arc_points(centre, RIGHT_TURN_RADIUS_M, math.pi, 0.5 * math.pi),
                        [[MAIN_EAST_X_M, EASTBOUND_Y_M]])

    def _road(self) -> tuple[tuple[Lane, ...], tuple[ConflictZone, ...], StopLine]:
        """Lanes (eastbound first: the priority lane), conflict zones and the stop line."""
        turn_start = np.array([[LEFT_TURN_START_X_M, LEFT_TURN_LANE_Y_M]])
        left_turn = self.left_turn_path()
        k = int(np.argmin(np.linalg.norm(left_turn - turn_start, axis=1)))
        right_turn = self.right_turn_path()
        lanes = (
            Lane(np.array([[MAIN_WEST_X_M, EASTBOUND_Y_M], [MAIN_EAST_X_M, EASTBOUND_Y_M]]),
                 LANE_WIDTH_M, "eastbound"),
            Lane(np.array([[MAIN_EAST_X_M, WESTBOUND_Y_M], [MAIN_WEST_X_M, WESTBOUND_Y_M]]),
                 LANE_WIDTH_M, "westbound"),
            Lane(left_turn[: k + 1], LANE_WIDTH_M, "westbound_left_turn_only"),
            Lane(left_turn[k:], LANE_WIDTH_M, "left_turn_into_stem"),
            Lane(right_turn, LANE_WIDTH_M, "stem_northbound_right_turn"),
        )
        eastbound = (0,)
        zones = (
            ConflictZone(box(CROSSING_WEST_X_M, CROSSING_MERGE_X_M, -LANE_WIDTH_M, 0.0),
                         "left_turn_crossing", eastbound),
            ConflictZone(box(CROSSING_MERGE_X_M, MERGE_EAST_X_M, -LANE_WIDTH_M, 0.0),
                         "right_turn_merge", eastbound),
        )
        stop_line = StopLine(np.array([[0.0, STOP_LINE_Y_M], [LANE_WIDTH_M, STOP_LINE_Y_M]]),
                             "stop_sign", lane=4)
        return lanes, zones, stop_line

    def _parked_cars(self) -> list[np.ndarray]:
        """The row of parked cars along the south curb, west of the stem."""
        return parked_row(PARKED_ROW_NEAR_X_M, PARKED_ROW_NEAR_X_M - PARKED_ROW_LENGTH_M,
                          PARKED_Y_M, PARKED_CAR.length_m, PARKED_CAR.width_m,
                          self.params.parked_gap_m)

    # -- agents ------------------------------------------------------------------------------
    def _robot(self) -> tuple[AgentSpec, Route]:
        """The robot at the stem's stop line, its front robot_start_back_m behind it."""
        p = self.params
        spec = robot_spec(p, NORTHBOUND_X_M, STOP_LINE_Y_M - p.robot_start_back_m)
        return spec, Route(self.right_turn_path(), "robot_0")

    def _left_turners(self) -> list[tuple[AgentSpec, Route]]:
        """n_humans cars in the left-turn-only lane, HUMAN_SPACING_M apart."""
        p: TIntersectionParams = self.params
        blind = (box(MAIN_WEST_X_M, CROSSING_WEST_X_M, -LANE_WIDTH_M, 0.0),) if p.human_blind \
            else ()
        out = []
        for k in range(p.n_humans):
            name = f"human_{k}"
            x = LEFT_TURN_START_X_M + p.human_start_m + HUMAN_SPACING_M * k
            spec = human_spec(p, name, [x, LEFT_TURN_LANE_Y_M, math.pi, p.human_speed_mps],
                                    p.human_desired_speed_mps, blind)
            out.append((spec, Route(self.left_turn_path(), name)))
        return out

    def _hidden(self) -> list[tuple[AgentSpec, Route]]:
        """V3 in the eastbound lane, near or far west of the stem (none for "none")."""
        p: TIntersectionParams = self.params
        if p.hidden_vehicle == "none":
            return []
        name = f"human_{p.n_humans}"
        x = -(p.hidden_near_m if p.hidden_vehicle == "near" else p.hidden_far_m)
        spec = human_spec(p, name, [x, EASTBOUND_Y_M, 0.0, p.hidden_speed_mps],
                                p.hidden_speed_mps)
        route = Route([[MAIN_WEST_X_M, EASTBOUND_Y_M], [MAIN_EAST_X_M, EASTBOUND_Y_M]], name)
        return [(spec, route)]

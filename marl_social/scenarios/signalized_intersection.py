"""The paper's signalized intersection (Sun et al. 2019, section I, Fig. 1 c): right turn on red.

Right-hand traffic, a four-way junction of a north-south and an east-west road; the junction
box is x in [JUNCTION_WEST_X_M, JUNCTION_EAST_X_M], y in [JUNCTION_SOUTH_Y_M,
JUNCTION_NORTH_Y_M].

* North-south road: a southbound through lane (west), the southbound left-turn-only lane
  (next to the centre line x = 0) and a northbound lane (east of it).
* East-west road: a westbound lane (north of y = 0) and two eastbound lanes (inner and curb).

Signals (sim/signals.py), one fixed-time controller with three groups: "ns_left" (the
protected southbound left turn), "ns_through" (the north-south through and right-turn
movements) and "ew" (the east-west through movements); phases in cycle order:
protected_left, left_yellow, all_red_1, ns_green, ns_yellow, all_red_2, cross_green,
cross_yellow, all_red_3. Three heads, each on the far side of its approach, facing it (its
visor hides it from the cross street): the southbound left-turners', the robot's (northbound)
and the cross traffic's (eastbound).

* The robot V0 (`robot_0`) approaches from the south and turns right into the eastbound curb
  lane. Its head (ns_through) is red in both variants: right turn on red, after stopping at
  the line and yielding to the eastbound traffic (conflict zone "right_turn_merge", priority:
  the eastbound curb lane).
* The left-turners V1, V2 (`human_0` ... `human_<n_humans-1>`) queue in the southbound
  left-turn-only lane; with a green arrow they turn left into the eastbound inner lane.
* The cross traffic V3, V4 (`human_<n_humans>` ..., `n_cross` of them) drives east in the curb
  lane towards its stop line, fast.

Variants (`phase`, the phase running at t = 0, `phase_elapsed_s` into it): "protected_left"
(the left-turners go, the cross traffic has red and stops: the robot may turn) and
"cross_green" (the cross traffic drives through, the left-turners wait).
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
from marl_social.scenarios.intersections import arc_points, box, polyline
from marl_social.scenarios.roads import LANE_WIDTH_M
from marl_social.sim.agent_spec import AgentSpec, VehicleParams
from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route, StopLine
from marl_social.sim.signals import SignalController, SignalHead, SignalPhase, SignalPlan

# -- the roads (x = 0 and y = 0 are their centre lines)
SOUTHBOUND_LEFT_X_M = -0.5 * LANE_WIDTH_M  # the left-turn-only lane's centre [m]
SOUTHBOUND_THROUGH_X_M = -1.5 * LANE_WIDTH_M  # [m]
NORTHBOUND_X_M = 0.5 * LANE_WIDTH_M  # the robot's lane [m]
WESTBOUND_Y_M = 0.5 * LANE_WIDTH_M  # [m]
EASTBOUND_INNER_Y_M = -0.5 * LANE_WIDTH_M  # the left-turners' exit lane [m]
EASTBOUND_CURB_Y_M = -1.5 * LANE_WIDTH_M  # the cross traffic's and the robot's exit lane [m]
JUNCTION_WEST_X_M = -2.0 * LANE_WIDTH_M  # [m]
JUNCTION_EAST_X_M = LANE_WIDTH_M  # [m]
JUNCTION_SOUTH_Y_M = -2.0 * LANE_WIDTH_M  # [m]
JUNCTION_NORTH_Y_M = LANE_WIDTH_M  # [m]
ROAD_END_M = 160.0  # every road runs this far from the junction's centre [m]
STOP_SETBACK_M = 2.5  # stop lines lie this far before the junction box (room for a crosswalk) [m]
LEFT_LINE_Y_M = JUNCTION_NORTH_Y_M + STOP_SETBACK_M  # the left-turners' stop line [m]
ROBOT_LINE_Y_M = JUNCTION_SOUTH_Y_M - STOP_SETBACK_M  # the robot's stop line [m]
CROSS_LINE_X_M = JUNCTION_WEST_X_M - STOP_SETBACK_M  # the cross traffic's stop line [m]
# -- turning paths
LEFT_TURN_RADIUS_M = JUNCTION_NORTH_Y_M - EASTBOUND_INNER_Y_M  # southbound -> eastbound [m]
RIGHT_TURN_RADIUS_M = 5.0  # the robot's turn, northbound -> eastbound curb lane [m]
# -- the right-turn merge zone (the curb lane east of the robot's stop line)
MERGE_WEST_X_M = 0.0  # [m]
MERGE_EAST_X_M = 14.0  # [m]
# -- signal heads: far side of each approach, facing it [m]
LEFT_HEAD_XY = (SOUTHBOUND_LEFT_X_M, JUNCTION_SOUTH_Y_M - 2.0)
ROBOT_HEAD_XY = (NORTHBOUND_X_M, JUNCTION_NORTH_Y_M + 5.5)
CROSS_HEAD_XY = (JUNCTION_EAST_X_M + 5.5, -1.0)
# -- the agents' places
HUMAN_SPACING_M = 7.5  # queue pitch of the left-turners (front to front) [m]
PHASES = ("protected_left", "cross_green")
MAX_HUMANS = 3
MAX_CROSS = 2
MAX_PHASE_S = 120.0  # longest phase [s]
EXTENT = (-60.0, 40.0, -40.0, 40.0)  # the area worth drawing [m]


@dataclass(frozen=True)
class SignalizedIntersectionParams(IntersectionParams):
    """Signalized intersection parameters (SI units).

    The humans' (left-turners and cross cars) and the robot's parameters are
    IntersectionParams' (scenarios/intersection_agents.py); the fields below are this
    scenario's own.

    Attributes:
        phase: the phase running at t = 0: "protected_left" or "cross_green".
        phase_elapsed_s: how long it has run at t = 0 [s] (less than its duration).
        left_green_s, ns_green_s, cross_green_s: durations of the green phases [s].
        yellow_s: every yellow phase's duration [s].
        all_red_s: every all-red clearance phase's duration [s].
        n_humans: left-turners (0-3); human_0's front starts human_start_m behind its stop
            line (every stop line lies STOP_SETBACK_M before the junction box), the next ones HUMAN_SPACING_M apart behind it.
        human_start_m: [m].
        human_speed_mps, human_desired_speed_mps: initial and cruise speed of the left-turners
            [m/s].
        n_cross: cross cars (0-2) in the eastbound curb lane; V3's front starts cross_start_m
            before its stop line, V4 cross_gap_m (front to front) behind it.
        cross_start_m, cross_gap_m: [m].
        cross_speed_mps: the cross cars' initial and desired speed [m/s].
        robot_start_back_m: how far the robot's front starts before its stop line [m].
    """

    phase: str = "protected_left"
    phase_elapsed_s: float = 0.5
    left_green_s: float = 10.0
    ns_green_s: float = 15.0
    cross_green_s: float = 20.0
    yellow_s: float = 3.5
    all_red_s: float = 1.5
    n_humans: int = 2
    human_start_m: float = 4.0
    human_speed_mps: float = 0.0
    human_desired_speed_mps: float = 10.0
    n_cross: int = 2
    cross_start_m: float = 40.0
    cross_gap_m: float = 18.0
    cross_speed_mps: float = 12.0
    robot_start_back_m: float = 0.5

    def __post_init__(self):
        super().__post_init__()
        self._check(self.phase in PHASES, "phase", f"must be one of {PHASES}")
        for name in ("left_green_s", "ns_green_s", "cross_green_s", "yellow_s", "all_red_s"):
            self._check_range(name, 0.0, MAX_PHASE_S, "s", low_open=True)
        duration = self.left_green_s if self.phase == "protected_left" else self.cross_green_s
        self._check(0.0 <= self.phase_elapsed_s < duration, "phase_elapsed_s",
                    f"must be in [0, {duration:g}) s (the {self.phase} phase's duration)")
        self._check(0 <= self.n_humans <= MAX_HUMANS, "n_humans", f"must be in [0, {MAX_HUMANS}]")
        self._check(0 <= self.n_cross <= MAX_CROSS, "n_cross", f"must be in [0, {MAX_CROSS}]")
        room = ROAD_END_M - LEFT_LINE_Y_M - HUMAN_SPACING_M * MAX_HUMANS - 10.0
        self._check_range("human_start_m", 0.0, room, "m")
        cross_room = ROAD_END_M + CROSS_LINE_X_M - 10.0
        self._check_range("cross_start_m", 0.0, cross_room, "m")
        self._check_range("cross_gap_m", VehicleParams().length_m + 1.0, cross_room, "m")
        self._check(self.cross_start_m + (MAX_CROSS - 1) * self.cross_gap_m <= cross_room,
                    "cross_gap_m", f"puts V4 beyond the road's west end (cross_start_m + "
                    f"cross_gap_m must be <= {cross_room:g} m)")
        for name in ("human_speed_mps", "human_desired_speed_mps", "cross_speed_mps"):
            self._check_range(name, 0.0, MAX_VEHICLE_SPEED_MPS, "m/s")
        self._check_range("robot_start_back_m", 0.0,
                          ROAD_END_M + ROBOT_LINE_Y_M - 10.0, "m")


# lane indices of the map
EASTBOUND_CURB, EASTBOUND_INNER, WESTBOUND, LEFT_ONLY, LEFT_TURN, SOUTHBOUND, NORTHBOUND = range(7)


class SignalizedIntersection(Scenario):
    """Paper Fig. 1 c: right turn on red; the left-turners tell the robot the cross traffic's phase."""

    name = "signalized_intersection"
    params_cls = SignalizedIntersectionParams
    variants = ({"phase": "protected_left"}, {"phase": "cross_green"})

    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        """Road, signals, robot, left-turners and cross traffic (independent of rng)."""
        p: SignalizedIntersectionParams = self.params
        lanes = self._lanes()
        stop_lines = self._stop_lines()
        plan = self.signal_plan()
        heads = (
            SignalHead(np.array(LEFT_HEAD_XY), 0.5 * math.pi, "ns_left", 0, name="southbound_left"),
            SignalHead(np.array(ROBOT_HEAD_XY), -0.5 * math.pi, "ns_through", 1,
                       name="northbound"),
            SignalHead(np.array(CROSS_HEAD_XY), math.pi, "ew", 2, name="eastbound"),
        )
        zones = (ConflictZone(box(MERGE_WEST_X_M, MERGE_EAST_X_M, JUNCTION_SOUTH_Y_M,
                                  EASTBOUND_CURB_Y_M + 0.5 * LANE_WIDTH_M),
                              "right_turn_merge", (EASTBOUND_CURB,)),)
        robot, robot_route = self._robot()
        agents, routes = [robot], {robot.name: robot_route}
        for spec, route in self._left_turners() + self._cross_traffic():
            agents.append(spec)
            routes[spec.name] = route
        road_map = RoadMap(
            lanes=lanes, crosswalks=(), static_polygons=(), routes=routes,
            speed_limit_mps=p.speed_limit_mps, extent=EXTENT, stop_lines=stop_lines,
            conflict_zones=zones, signal_heads=heads, signal_plan=plan,
        )
        controller = SignalController(plan, plan.phase_index(p.phase), p.phase_elapsed_s)
        return ScenarioLayout(road_map, tuple(agents), p, controller)

    def hidden_agent(self) -> HiddenAgent:
        """The cross traffic's phase: the robot sees the cross cars, not their head.

        No agent is hidden (the robot sees the cross cars from the start, there is nothing in
        the way); the counterfactual is the other phase of PHASES, in which the left-turners
        do what they do not do in this one (go on their arrow, or wait).
        """
        p: SignalizedIntersectionParams = self.params
        other = next(phase for phase in PHASES if phase != p.phase)
        return HiddenAgent((), {"phase": other}, f"phase_{p.phase}")

    def signal_plan(self) -> SignalPlan:
        """The fixed-time cycle (module docstring), with this scenario's durations."""
        p: SignalizedIntersectionParams = self.params
        return SignalPlan(("ns_left", "ns_through", "ew"), (
            SignalPhase("protected_left", p.left_green_s, green=("ns_left",)),
            SignalPhase("left_yellow", p.yellow_s, yellow=("ns_left",)),
            SignalPhase("all_red_1", p.all_red_s),
            SignalPhase("ns_green", p.ns_green_s, green=("ns_through",)),
            SignalPhase("ns_yellow", p.yellow_s, yellow=("ns_through",)),
            SignalPhase("all_red_2", p.all_red_s),
            SignalPhase("cross_green", p.cross_green_s, green=("ew",)),
            SignalPhase("cross_yellow", p.yellow_s, yellow=("ew",)),
            SignalPhase("all_red_3", p.all_red_s),
        ))

    # -- paths -------------------------------------------------------------------------------
    @staticmethod
    def left_turn_path() -> np.ndarray:
        """(P, 2) southbound left-turn lane -> arc -> eastbound inner lane [m]."""
        centre = (SOUTHBOUND_LEFT_X_M + LEFT_TURN_RADIUS_M, JUNCTION_NORTH_Y_M)
        return polyline([[SOUTHBOUND_LEFT_X_M, ROAD_END_M]],
                        arc_points(centre, LEFT_TURN_RADIUS_M, math.pi, 1.5 * math.pi),
                        [[ROAD_END_M, EASTBOUND_INNER_Y_M]])

    @staticmethod
    def right_turn_path() -> np.ndarray:
        """(P, 2) northbound lane -> arc -> eastbound curb lane [m]."""
        centre = (NORTHBOUND_X_M + RIGHT_TURN_RADIUS_M, EASTBOUND_CURB_Y_M - RIGHT_TURN_RADIUS_M)
        return polyline([[NORTHBOUND_X_M, -ROAD_END_M]],
                        arc_points(centre, RIGHT_TURN_RADIUS_M, math.pi, 0.5 * math.pi),
                        [[ROAD_END_M, EASTBOUND_CURB_Y_M]])

    @staticmethod
    def cross_path() -> np.ndarray:
        """(2, 2) the eastbound curb lane, west to east [m]."""
        return np.array([[-ROAD_END_M, EASTBOUND_CURB_Y_M], [ROAD_END_M, EASTBOUND_CURB_Y_M]])

    def _lanes(self) -> tuple[Lane, ...]:
        """The lanes, in the order of the lane-index constants (EASTBOUND_CURB first)."""
        left = self.left_turn_path()
        k = int(np.argmin(np.linalg.norm(left - [SOUTHBOUND_LEFT_X_M, JUNCTION_NORTH_Y_M],
                                         axis=1)))
        w = LANE_WIDTH_M
        return (
            Lane(self.cross_path(), w, "eastbound_curb"),
            Lane(np.array([[-ROAD_END_M, EASTBOUND_INNER_Y_M], [ROAD_END_M, EASTBOUND_INNER_Y_M]]),
                 w, "eastbound_inner"),
            Lane(np.array([[ROAD_END_M, WESTBOUND_Y_M], [-ROAD_END_M, WESTBOUND_Y_M]]), w,
                 "westbound"),
            Lane(left[: k + 1], w, "southbound_left_turn_only"),
            Lane(left[k:], w, "left_turn_to_east"),
            Lane(np.array([[SOUTHBOUND_THROUGH_X_M, ROAD_END_M],
                           [SOUTHBOUND_THROUGH_X_M, -ROAD_END_M]]), w, "southbound"),
            Lane(self.right_turn_path(), w, "northbound_right_turn"),
        )

    @staticmethod
    def _stop_lines() -> tuple[StopLine, ...]:
        """Signal stop lines: the left-turners', the robot's, the cross traffic's (head order)."""
        return (
            StopLine(np.array([[-LANE_WIDTH_M, LEFT_LINE_Y_M], [0.0, LEFT_LINE_Y_M]]),
                     "signal", lane=LEFT_ONLY),
            StopLine(np.array([[0.0, ROBOT_LINE_Y_M], [LANE_WIDTH_M, ROBOT_LINE_Y_M]]),
                     "signal", lane=NORTHBOUND),
            StopLine(np.array([[CROSS_LINE_X_M, JUNCTION_SOUTH_Y_M], [CROSS_LINE_X_M, 0.0]]),
                     "signal", lane=EASTBOUND_CURB),
        )

    # -- agents ------------------------------------------------------------------------------
    def _robot(self) -> tuple[AgentSpec, Route]:
        """The robot in the northbound lane, its front robot_start_back_m before its line."""
        p = self.params
        spec = robot_spec(p, NORTHBOUND_X_M, ROBOT_LINE_Y_M - p.robot_start_back_m)
        return spec, Route(self.right_turn_path(), "robot_0")

    def _left_turners(self) -> list[tuple[AgentSpec, Route]]:
        """n_humans cars queued in the left-turn-only lane, HUMAN_SPACING_M apart."""
        p: SignalizedIntersectionParams = self.params
        blind = ((box(-ROAD_END_M, JUNCTION_WEST_X_M, JUNCTION_SOUTH_Y_M, 0.0),)
                 if p.human_blind else ())
        half = 0.5 * VehicleParams().length_m
        out = []
        for k in range(p.n_humans):
            name = f"human_{k}"
            y = LEFT_LINE_Y_M + p.human_start_m + half + HUMAN_SPACING_M * k
            spec = human_spec(p, name, [SOUTHBOUND_LEFT_X_M, y, -0.5 * math.pi,
                                           p.human_speed_mps], p.human_desired_speed_mps, blind)
            out.append((spec, Route(self.left_turn_path(), name)))
        return out

    def _cross_traffic(self) -> list[tuple[AgentSpec, Route]]:
        """n_cross cars in the eastbound curb lane, V3 cross_start_m before its line."""
        p: SignalizedIntersectionParams = self.params
        half = 0.5 * VehicleParams().length_m
        out = []
        for k in range(p.n_cross):
            name = f"human_{p.n_humans + k}"
            x = CROSS_LINE_X_M - p.cross_start_m - half - p.cross_gap_m * k
            spec = human_spec(p, name, [x, EASTBOUND_CURB_Y_M, 0.0, p.cross_speed_mps],
                                    p.cross_speed_mps)
            out.append((spec, Route(self.cross_path(), name)))
        return out

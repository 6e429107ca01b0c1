"""The paper's scenario (Sun et al. 2019, section V, Fig. 2): an occluded crosswalk.

A straight road with two 3.5 m lanes in the +x direction and a crosswalk at x = crosswalk_x_m.
The robot drives in the left lane (y = +1.75 m), a human car in the right lane (y = -1.75 m)
human_lead_m ahead of it, and a pedestrian waits on the right sidewalk at the crosswalk. The
human car hides the pedestrian from the robot, whose sensor range is also limited; the human sees
the pedestrian. With the default numbers and every agent on the cruise baseline
(agents/cruise.py: the human brakes for the pedestrian it sees, the robot drives on until it
sees it), the robot first sees the pedestrian about 1.5 s before it reaches the crosswalk and
has to brake at its limit (tests/scenarios/test_scenarios.py measures it). Houses line both sidewalks.

Variants: pedestrian = "crossing" (starts to cross after pedestrian_start_delay_s),
"waiting" (stays on the curb) or "none" (no pedestrian agent).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import MAX_SPEED_LIMIT_MPS, HiddenAgent, Scenario, ScenarioLayout
from marl_social.scenarios.crosswalk_agents import (
    CrosswalkParams,
    human_spec,
    pedestrian_spec,
    robot_spec,
)
from marl_social.scenarios.roads import (
    LANE_WIDTH_M,
    road_extent,
    straight_lane,
    straight_route,
)
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.road_map import Crosswalk, Lane, RoadMap, Route

N_LANES = 2  # lanes in the +x direction: right (human) and left (robot)
HALF_ROAD_WIDTH_M = 0.5 * N_LANES * LANE_WIDTH_M  # curb to road centre [m]
LEFT_LANE_Y_M, RIGHT_LANE_Y_M = 0.5 * LANE_WIDTH_M, -0.5 * LANE_WIDTH_M  # lane centrelines [m]
SIDEWALK_WIDTH_M = 3.0
HOUSE_SETBACK_M = 2.0  # front gardens between sidewalk and houses [m]
HOUSE_LENGTH_M, HOUSE_DEPTH_M, HOUSE_GAP_M = 12.0, 8.0, 5.0
ROAD_START_X_M = -30.0
ROBOT_START_X_M = 0.0  # the robot starts here; crosswalk_x_m is measured from it [m]
EXTENT_MARGIN_M = 4.0  # drawn area beyond the houses' far walls [m]
BLIND_HALF_LENGTH_M = 6.0  # a blind human cannot see x within this of the crosswalk centre [m]
PEDESTRIAN_OVERSHOOT_M = 1.0  # the pedestrian's route ends this far past the far curb [m]
CROSSING_HEADING_RAD = math.pi / 2  # pedestrians cross the road towards +y [rad]
MAX_HUMANS = 4
HUMAN_SPACING_M = 20.0  # gap between successive human cars' start positions [m]
MAX_ROAD_END_X_M = 2000.0  # longest road (about 230 houses) [m]
MAX_CROSSWALK_WIDTH_M = 20.0  # widest crosswalk (along the road) [m]
MAX_START_DELAY_S = 3600.0  # latest time a crossing pedestrian steps off the curb [s]


@dataclass(frozen=True)
class OccludedCrosswalkParams(CrosswalkParams):
    """Occluded-crosswalk parameters (SI units; the agents' in CrosswalkParams).

    Attributes:
        crosswalk_x_m: crosswalk centre, ahead of the robot's start at x = 0 [m].
        crosswalk_width_m: extent of the crosswalk along the road [m].
        road_end_x_m: where the vehicles' routes end [m].
        speed_limit_mps: legal limit [m/s].
        human_blind: the human cannot see the pedestrian's side of the crosswalk (its view of
            the right sidewalk around the crosswalk is blocked), so it cannot act as a sensor.
        n_humans: number of human drivers (0-4). human_0 leads by human_lead_m in the right
            lane; human_k (k >= 1) follows in the same lane HUMAN_SPACING_M * k behind it (so
            the second one drives beside the robot). With 0 the pedestrian is not hidden by a
            car (only the robot's range limits its view). Every human gets the human_* knobs.
    """

    crosswalk_x_m: float = 60.0
    crosswalk_width_m: float = 4.0
    road_end_x_m: float = 150.0
    speed_limit_mps: float = 13.9
    human_blind: bool = False
    n_humans: int = 1

    def __post_init__(self):
        super().__post_init__()
        self._check(0 <= self.n_humans <= MAX_HUMANS, "n_humans", f"must be in [0, {MAX_HUMANS}]")
        self._check_range("crosswalk_x_m", 10.0, MAX_ROAD_END_X_M - 20.0, "m", low_open=True)
        self._check_range("crosswalk_width_m", 0.0, MAX_CROSSWALK_WIDTH_M, "m", low_open=True)
        self._check_range("road_end_x_m", 30.0, MAX_ROAD_END_X_M, "m", low_open=True)
        self._check(self.road_end_x_m > self.crosswalk_x_m + 20.0, "road_end_x_m",
                    "must be at least 20 m past the crosswalk")
        self._check_range("pedestrian_start_delay_s", 0.0, MAX_START_DELAY_S, "s")
        self._check(self.human_lead_m >= 5.0, "human_lead_m",
                    "must be >= 5 m (the cars would overlap)")
        self._check_range("human_lead_m", 5.0, MAX_ROAD_END_X_M, "m")
        self._check_range("pedestrian_curb_offset_m", 0.0, SIDEWALK_WIDTH_M - 0.3, "m")
        self._check_range("speed_limit_mps", 0.0, MAX_SPEED_LIMIT_MPS, "m/s", low_open=True)


def _houses(x_start: float, x_end: float, y_near: float, side: int) -> list[np.ndarray]:
    """Rectangular houses along one side of the road; side = +1 (left) or -1 (right)."""
    houses = []
    x = x_start
    while x + HOUSE_LENGTH_M <= x_end:
        y0, y1 = side * y_near, side * (y_near + HOUSE_DEPTH_M)
        houses.append(np.array([[x, y0], [x + HOUSE_LENGTH_M, y0],
                                [x + HOUSE_LENGTH_M, y1], [x, y1]]))
        x += HOUSE_LENGTH_M + HOUSE_GAP_M
    return houses


class OccludedCrosswalk(Scenario):
    """Paper Fig. 2: robot, human car and a pedestrian hidden from the robot by the human car."""

    name = "occluded_crosswalk"
    params_cls = OccludedCrosswalkParams
    variants = ({"pedestrian": "crossing"}, {"pedestrian": "waiting"}, {"pedestrian": "none"})

    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        """Road, robot, human cars and pedestrian (the layout does not depend on rng)."""
        p: OccludedCrosswalkParams = self.params
        lanes, crosswalk, houses = self._road()
        robot, robot_route = self._robot()
        agents, routes = [robot], {robot.name: robot_route}
        for spec, route in self._humans() + self._pedestrians():
            agents.append(spec)
            routes[spec.name] = route
        road_map = RoadMap(
            lanes=lanes, crosswalks=(crosswalk,), static_polygons=houses, routes=routes,
            speed_limit_mps=p.speed_limit_mps,
            extent=road_extent(ROAD_START_X_M, p.road_end_x_m, self._houses_y(),
                               EXTENT_MARGIN_M),
        )
        return ScenarioLayout(road_map, tuple(agents), p)

    def hidden_agent(self) -> HiddenAgent | None:
        """The pedestrian, hidden by the human's car (removed: pedestrian="none")."""
        if self.params.pedestrian == "none":
            return None
        return HiddenAgent(("pedestrian_0",), {"pedestrian": "none"}, "p_pedestrian")

    @staticmethod
    def _houses_y() -> float:
        """|y| of the houses' fronts: road, sidewalk and front garden [m]."""
        return HALF_ROAD_WIDTH_M + SIDEWALK_WIDTH_M + HOUSE_SETBACK_M

    def _road(self) -> tuple[tuple[Lane, ...], Crosswalk, tuple[np.ndarray, ...]]:
        """The two lanes (right, left), the crosswalk across both, and the houses (V, 2) [m]."""
        p: OccludedCrosswalkParams = self.params
        x0, x1 = ROAD_START_X_M, p.road_end_x_m
        lanes = (straight_lane(x0, x1, RIGHT_LANE_Y_M), straight_lane(x0, x1, LEFT_LANE_Y_M))
        crosswalk = Crosswalk(np.array([p.crosswalk_x_m, 0.0]), CROSSING_HEADING_RAD,
                              2.0 * HALF_ROAD_WIDTH_M, p.crosswalk_width_m)
        y_houses = self._houses_y()
        houses = tuple(_houses(x0, x1, y_houses, +1) + _houses(x0, x1, y_houses, -1))
        return lanes, crosswalk, houses

    def _robot(self) -> tuple[AgentSpec, Route]:
        """The robot in the left lane at x = ROBOT_START_X_M, with its model of the humans."""
        p: OccludedCrosswalkParams = self.params
        spec = robot_spec(p, [ROBOT_START_X_M, LEFT_LANE_Y_M, 0.0, p.robot_speed_mps])
        return spec, straight_route("robot_0", ROAD_START_X_M, p.road_end_x_m, LEFT_LANE_Y_M)

    def _humans(self) -> list[tuple[AgentSpec, Route]]:
        """n_humans cars in the right lane: human_0 human_lead_m ahead, then every HUMAN_SPACING_M."""
        p: OccludedCrosswalkParams = self.params
        blind = (self._blind_region(),) if p.human_blind else ()
        humans = []
        for k in range(p.n_humans):
            name = f"human_{k}"
            x = p.human_lead_m - HUMAN_SPACING_M * k
            spec = human_spec(p, name, [x, RIGHT_LANE_Y_M, 0.0, p.human_speed_mps], blind)
            humans.append((spec, straight_route(name, ROAD_START_X_M, p.road_end_x_m,
                                                RIGHT_LANE_Y_M)))
        return humans

    def _pedestrians(self) -> list[tuple[AgentSpec, Route]]:
        """The pedestrian on the right sidewalk at the crosswalk (none for pedestrian="none")."""
        p: OccludedCrosswalkParams = self.params
        if p.pedestrian == "none":
            return []
        curb_y = -(HALF_ROAD_WIDTH_M + p.pedestrian_curb_offset_m)
        far_y = HALF_ROAD_WIDTH_M + PEDESTRIAN_OVERSHOOT_M
        route = Route([[p.crosswalk_x_m, curb_y], [p.crosswalk_x_m, far_y]], "pedestrian_0")
        return [(pedestrian_spec(p, (p.crosswalk_x_m, curb_y), CROSSING_HEADING_RAD), route)]

    def _blind_region(self) -> np.ndarray:
        """(4, 2) the right sidewalk and right lane within BLIND_HALF_LENGTH_M of the crosswalk."""
        x, dx = self.params.crosswalk_x_m, BLIND_HALF_LENGTH_M
        y_far = -self._houses_y()  # the far edge of the right sidewalk's front gardens
        return np.array([[x - dx, y_far], [x + dx, y_far], [x + dx, 0.0], [x - dx, 0.0]])

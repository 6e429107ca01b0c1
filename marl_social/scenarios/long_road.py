"""A long straight multi-lane road full of cars: the scaling benchmark's scenario.

n_vehicles cars are spread over n_lanes lanes in the +x direction, staggered, spaced
spacing_m apart within a lane; one of them is the robot (`robot_0`), the rest are human drivers.
Every car has its own field of view (range, cone, occlusion by the others).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import MAX_SENSOR_RANGE_M, Scenario, ScenarioLayout, ScenarioParams
from marl_social.scenarios.roads import (
    LANE_WIDTH_M,
    lane_centres_y,
    road_extent,
    straight_lane,
    straight_route,
)
from marl_social.sim.agent_spec import AgentSpec, SensorParams
from marl_social.sim.road_map import Lane, RoadMap, Route

ROAD_START_X_M = -50.0  # the road and every route start here, behind the last car [m]
ROAD_BEYOND_CARS_M = 400.0  # the road runs this far past the front car's start [m]
SPEED_LIMIT_MARGIN_MPS = 2.0  # speed limit = speed_mps + this [m/s]
EXTENT_MARGIN_M = 5.0  # drawn area beyond the outer lane edges [m]
MIN_SPACING_M = 6.0  # closer cars in a lane would overlap [m]
MAX_SPEED_MPS = 20.0  # largest allowed speed_mps [m/s]
MAX_VEHICLES = 1000  # most cars on the road
SLOW_VEHICLES = 200  # more cars than this are warned about: steps grow with the count squared
MAX_SPACING_M = 1000.0  # largest gap between cars in a lane [m]


@dataclass(frozen=True)
class LongRoadParams(ScenarioParams):
    """Long-road parameters (SI units).

    Attributes:
        n_vehicles: number of cars (robot included).
        n_lanes: lanes in the +x direction.
        spacing_m: distance between consecutive cars in a lane [m].
        speed_mps: initial and desired speed [m/s].
        sensor_range_m, half_fov_deg: every car's field of view [m, deg].
    """

    n_vehicles: int = 30
    n_lanes: int = 4
    spacing_m: float = 25.0
    speed_mps: float = 12.0
    sensor_range_m: float = 50.0
    half_fov_deg: float = 70.0
    n_rays: int = 16

    def __post_init__(self):
        super().__post_init__()
        self._check_range("n_vehicles", 1, MAX_VEHICLES)
        if self.n_vehicles > SLOW_VEHICLES:
            warnings.warn(f"LongRoadParams.n_vehicles={self.n_vehicles}: a step costs about "
                          "the square of the car count (every car's field of view is tested "
                          f"against every other car), so above {SLOW_VEHICLES} cars steps take "
                          "tenths of a second to seconds (`marl-social bench env` measures "
                          "them)", RuntimeWarning, stacklevel=2)
        self._check(1 <= self.n_lanes <= 8, "n_lanes", "must be in [1, 8]")
        self._check(self.spacing_m >= MIN_SPACING_M, "spacing_m",
                    f"must be >= {MIN_SPACING_M:g} m (cars would overlap)")
        self._check_range("spacing_m", MIN_SPACING_M, MAX_SPACING_M, "m")
        self._check_range("speed_mps", 0.0, MAX_SPEED_MPS, "m/s")
        self._check_range("sensor_range_m", 0.0, MAX_SENSOR_RANGE_M, "m", low_open=True)
        self._check_range("half_fov_deg", 0.0, 180.0, "deg", low_open=True)


class LongRoad(Scenario):
    """n_vehicles cars on n_lanes straight lanes; car 0 is the robot, the others humans."""

    name = "long_road"
    params_cls = LongRoadParams
    variants = ({"n_vehicles": 6, "terminate_on_collision": False},)

    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        """The road and the cars (the layout does not depend on rng)."""
        p: LongRoadParams = self.params
        road_end_x = self._road_end_x()
        lanes, lane_y = self._road(road_end_x)
        agents, routes = self._vehicles(lane_y, road_end_x)
        half_width = 0.5 * p.n_lanes * LANE_WIDTH_M
        road_map = RoadMap(lanes=lanes, crosswalks=(), static_polygons=(), routes=routes,
                           speed_limit_mps=p.speed_mps + SPEED_LIMIT_MARGIN_MPS,
                           extent=road_extent(ROAD_START_X_M, road_end_x, half_width,
                                              EXTENT_MARGIN_M))
        return ScenarioLayout(road_map, tuple(agents), p)

    def _road_end_x(self) -> float:
        """The x where the road ends [m]: ROAD_BEYOND_CARS_M past the last slot of a lane."""
        p: LongRoadParams = self.params
        per_lane = math.ceil(p.n_vehicles / p.n_lanes)
        return per_lane * p.spacing_m + ROAD_BEYOND_CARS_M

    def _road(self, road_end_x: float) -> tuple[tuple[Lane, ...], np.ndarray]:
        """The n_lanes straight lanes and (n_lanes,) their centreline y [m]."""
        lane_y = lane_centres_y(self.params.n_lanes)
        lanes = tuple(straight_lane(ROAD_START_X_M, road_end_x, y) for y in lane_y)
        return lanes, lane_y

    def _vehicles(self, lane_y: np.ndarray,
                  road_end_x: float) -> tuple[list[AgentSpec], dict[str, Route]]:
        """The cars, lane by lane in turn, staggered by spacing_m / n_lanes; car 0 the robot.

        Args:
            lane_y: (n_lanes,) centreline y of the lanes [m].
            road_end_x: x where the road and the routes end [m].
        """
        p: LongRoadParams = self.params
        sensor = SensorParams(p.sensor_range_m, math.radians(p.half_fov_deg))
        agents, routes = [], {}
        for i in range(p.n_vehicles):
            lane, slot = i % p.n_lanes, i // p.n_lanes
            x = slot * p.spacing_m + (lane * p.spacing_m / p.n_lanes)
            name = "robot_0" if i == 0 else f"human_{i - 1}"
            routes[name] = straight_route(name, ROAD_START_X_M, road_end_x, lane_y[lane])
            agents.append(AgentSpec(
                name, "vehicle", "robot" if i == 0 else "human",
                np.array([x, lane_y[lane], 0.0, p.speed_mps]), sensor=sensor,
                v_desired_mps=p.speed_mps,
            ))
        return agents, routes

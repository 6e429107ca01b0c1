"""A long straight multi-lane road full of cars: the scaling benchmark's scenario.

n_vehicles cars are spread over n_lanes lanes in the +x direction, staggered, spaced
spacing_m apart within a lane; one of them is the robot (`robot_0`), the rest are human drivers.
Every car has its own field of view (range, cone, occlusion by the others).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from marl_social.scenarios.base import Scenario, ScenarioLayout, ScenarioParams
from marl_social.sim.agent_spec import AgentSpec, SensorParams
from marl_social.sim.road_map import Lane, RoadMap, Route

LANE_WIDTH_M = 3.5


@dataclass(frozen=True)
class LongRoadParams(ScenarioParams):
    """Attributes:
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
        self._check(self.n_vehicles >= 1, "n_vehicles", "must be >= 1")
        self._check(1 <= self.n_lanes <= 8, "n_lanes", "must be in [1, 8]")
        self._check(self.spacing_m >= 6.0, "spacing_m", "must be >= 6 m (cars would overlap)")
        self._check(0.0 <= self.speed_mps <= 20.0, "speed_mps", "must be in [0, 20] m/s")
        self._check(self.sensor_range_m > 0, "sensor_range_m", "must be > 0 m")
        self._check(0 < self.half_fov_deg <= 180, "half_fov_deg", "must be in (0, 180] deg")


class LongRoad(Scenario):
    name = "long_road"
    params_cls = LongRoadParams
    variants = ({"n_vehicles": 6, "terminate_on_collision": False},)

    def build(self, rng: np.random.Generator) -> ScenarioLayout:
        p: LongRoadParams = self.params
        per_lane = math.ceil(p.n_vehicles / p.n_lanes)
        length = per_lane * p.spacing_m + 400.0
        lane_y = (np.arange(p.n_lanes) - (p.n_lanes - 1) / 2) * LANE_WIDTH_M
        lanes = tuple(Lane(np.array([[-50.0, y], [length, y]]), LANE_WIDTH_M) for y in lane_y)
        sensor = SensorParams(p.sensor_range_m, math.radians(p.half_fov_deg))
        agents, routes = [], {}
        for i in range(p.n_vehicles):
            lane, slot = i % p.n_lanes, i // p.n_lanes
            x = slot * p.spacing_m + (lane * p.spacing_m / p.n_lanes)
            name = "robot_0" if i == 0 else f"human_{i - 1}"
            routes[name] = Route([[-50.0, lane_y[lane]], [length, lane_y[lane]]], name)
            agents.append(AgentSpec(
                name, "vehicle", "robot" if i == 0 else "human",
                np.array([x, lane_y[lane], 0.0, p.speed_mps]), sensor=sensor,
                v_desired_mps=p.speed_mps,
            ))
        half = 0.5 * p.n_lanes * LANE_WIDTH_M
        road_map = RoadMap(lanes=lanes, crosswalks=(), static_polygons=(), routes=routes,
                           speed_limit_mps=p.speed_mps + 2.0,
                           extent=(-50.0, length, -half - 5.0, half + 5.0))
        return ScenarioLayout(road_map, tuple(agents), p)

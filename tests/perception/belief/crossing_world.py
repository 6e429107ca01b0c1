"""A small synthetic crossing for the hidden-vehicle belief tests, simulated by the real World.

The robot drives east on y = 0 (lane 0, "east"). A northbound lane (lane 1, "north", x = 58)
crosses it; a building south-west of the crossing hides that lane's upstream part from the
robot. A southbound lane (lane 3, "south", x = 62) crosses it too but yields there (the conflict
zone lists only lane 1 as priority); lane 2 ("west", y = 3.5) is parallel to the robot's.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.envs.world import World
from marl_social.scenarios.base import ScenarioLayout, ScenarioParams
from marl_social.sim.agent_spec import AgentSpec, SensorParams
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import ConflictZone, Lane, RoadMap, Route

LANE_WIDTH_M = 3.5
NORTH_X_M = 58.0  # the northbound lane's centre line [m]
SOUTH_X_M = 62.0  # the southbound lane's centre line [m]
WEST_Y_M = 3.5  # the westbound (parallel) lane's centre line [m]
BUILDING = np.array([[20.0, -60.0], [56.0, -60.0], [56.0, -3.5], [20.0, -3.5]])
SPEED_LIMIT_MPS = 13.9
N_RAYS = 64
LANE_POINTS = {
    "east": [[-20.0, 0.0], [150.0, 0.0]],
    "north": [[NORTH_X_M, -80.0], [NORTH_X_M, 60.0]],
    "west": [[150.0, WEST_Y_M], [-20.0, WEST_Y_M]],
    "south": [[SOUTH_X_M, 60.0], [SOUTH_X_M, -80.0]],
}


def crossing_map(zones: bool = True, building: bool = True, routes: dict | None = None
                 ) -> RoadMap:
    """The map: four named lanes, the conflict zone (lane 1 has the right of way), the building.

    Args:
        zones: include the conflict zone (without it every crossing lane has priority).
        building: include the building that hides the northbound lane.
        routes: {agent name: Route} (default: the robot's, along lane 0).
    """
    lanes = tuple(Lane(np.array(p), LANE_WIDTH_M, name) for name, p in LANE_POINTS.items())
    zone = ConflictZone(np.array([[56.0, -1.75], [64.0, -1.75], [64.0, 1.75], [56.0, 1.75]]),
                        "crossing", priority_lanes=(1,))
    if routes is None:
        routes = {"robot_0": Route(LANE_POINTS["east"], "robot_0")}
    return RoadMap(lanes=lanes, crosswalks=(), static_polygons=(BUILDING,) if building else (),
                   routes=routes, speed_limit_mps=SPEED_LIMIT_MPS,
                   extent=(-20.0, 150.0, -80.0, 60.0), conflict_zones=(zone,) if zones else ())


def turning_map() -> RoadMap:
    """Lanes 0 (east) and 1 (north) of the crossing, and a human's approach lane (2) coming
    south at x = 54 that ends in a left turn (lane 3: south -> east, radius 8 m, centre
    (62, -14)) across the northbound lane; no building. The robot drives along lane 0."""
    theta = np.linspace(np.pi, 1.5 * np.pi, 24)
    turn = np.column_stack([62.0 + 8.0 * np.cos(theta), -14.0 + 8.0 * np.sin(theta)])
    lanes = (Lane(np.array(LANE_POINTS["east"]), LANE_WIDTH_M, "east"),
             Lane(np.array(LANE_POINTS["north"]), LANE_WIDTH_M, "north"),
             Lane(np.array([[54.0, -4.0], [54.0, -14.0]]), LANE_WIDTH_M, "approach"),
             Lane(np.vstack([turn, [[100.0, -22.0]]]), LANE_WIDTH_M, "turn_east"))
    return RoadMap(lanes=lanes, crosswalks=(), static_polygons=(),
                   routes={"robot_0": Route(LANE_POINTS["east"], "robot_0")},
                   speed_limit_mps=SPEED_LIMIT_MPS)


def _car(name: str, role: str, x: float, y: float, heading: float, speed: float) -> AgentSpec:
    sensor = SensorParams(50.0, math.radians(70.0), pos_noise_m=0.0, vel_noise_mps=0.0,
                          heading_noise_rad=0.0)
    return AgentSpec(name, "vehicle", role, np.array([x, y, heading, speed]), sensor=sensor)


class CrossingWorld:
    """The robot and other cars on the crossing map, stepped by the real World.

    Args:
        robot_xv: (x [m], speed [m/s]) of the robot on y = 0, heading east.
        cars: {name: (lane name, arc length along the lane [m], speed [m/s])}.
        building: include the building.
    """

    def __init__(self, robot_xv=(40.0, 0.0), cars=None, building: bool = True):
        cars = cars or {}
        specs = [_car("robot_0", "robot", robot_xv[0], 0.0, 0.0, robot_xv[1])]
        routes = {"robot_0": Route(LANE_POINTS["east"], "robot_0")}
        for name, (lane, s, speed) in cars.items():
            route = Route(LANE_POINTS[lane], name)
            xy, heading = route.point_at(s)
            specs.append(_car(name, "human", float(xy[0]), float(xy[1]), float(heading), speed))
            routes[name] = route
        self.road_map = crossing_map(building=building, routes=routes)
        params = ScenarioParams(n_rays=N_RAYS)
        self.world = World(ScenarioLayout(self.road_map, tuple(specs), params))
        self.layout = ObservationLayout(params.n_slots, params.n_rays)
        self.names = [s.name for s in specs]
        self._rng = np.random.default_rng(0)

    def robot_map(self) -> RoadMap:
        """The map the robot may know: the static map and its own route only."""
        return self.road_map.for_agent("robot_0")

    def observe(self) -> tuple[np.ndarray, list]:
        """The robot's observation vector and the names of the agents it sees."""
        w = self.world
        fov, meas = w.perceive(self._rng)
        obs = self.layout.encode(w.bodies(), meas, fov.depth_m)
        return obs[0], [self.names[j] for j in np.flatnonzero(fov.visible[0])]

    def step(self, accel_mps2: dict | None = None) -> None:
        """One step; every car holds its speed and heading unless given an acceleration."""
        action = np.zeros((self.world.n, 2))
        for name, a in (accel_mps2 or {}).items():
            action[self.names.index(name), 0] = a
        self.world.step(action)

"""The true world: struct-of-arrays state, dynamics, geometry mirrors, contacts and costs.

The world never calls a planner. It is built from a ScenarioLayout at every reset, taking over
the previous world's geometry mirror when the footprints and static polygons are the same (the
fcl solids and pymunk shapes are built once per env, so memory stays flat over resets). The fcl
mirror cannot be pickled, so an env pickles its constructor arguments, not its world.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.perception.fov import FieldOfView, FovResult
from marl_social.perception.sensors import Measurements, measure
from marl_social.perception.signal_view import visible_heads
from marl_social.scenarios.base import ScenarioLayout
from marl_social.sim.bodies import Bodies
from marl_social.sim.costs import (
    N_FEATURES,
    AgentFootprints,
    AgentMotion,
    pairwise_step_features,
)
from marl_social.sim.dynamics import (
    DT_S,
    bicycle_step,
    pedestrian_step,
    saturate_pedestrian_action,
    saturate_vehicle_action,
)
from marl_social.sim.footprint import circle_layout, place_along
from marl_social.sim.geometry import GeometryMirror
from marl_social.sim.road_map import RouteSet

ROUTE_END_MARGIN_M = 0.5  # an agent within this of its route's end has arrived [m]


@dataclass(frozen=True)
class StepEvents:
    """What happened in one world step.

    Attributes:
        collided: (n,) bool, agent touches another agent or a static polygon.
        contacts: list of (label_a, label_b); labels >= n are static polygons (label - n).
        arrived: (n,) bool, agent reached its route's end.
        applied_action: (n, 2) actions after saturation.
    """

    collided: np.ndarray
    contacts: list
    arrived: np.ndarray
    applied_action: np.ndarray


class World:
    """True state of every agent plus the static map.

    Attributes (n agents, in layout order):
        state: (n, 4) [x m, y m, heading rad, speed m/s].
        accel_mps2, prev_accel_mps2: (n,) effective longitudinal acceleration this / last step,
            dv / dt after the speed limits [m/s^2] (pedestrians: |change of velocity| / dt).
        active: (n,) bool, still in the episode.
        time_s: simulated time [s].
        signals: the signal controller's clock (None: no signals); `signal_states()` is what
            the heads show now.
    """

    def __init__(self, layout: ScenarioLayout, reuse: World | None = None):
        """Build the world of a layout.

        Args:
            layout: the episode's map and agents.
            reuse: the previous episode's world, whose geometry mirror is taken over when it
                holds the same agent footprints and static polygons (the world is then
                unusable); None builds a new mirror.
        """
        self.layout = layout
        self.road_map = layout.road_map
        specs = layout.agents
        self.specs = specs
        self.names = [s.name for s in specs]
        self.n = len(specs)
        self.state = np.array([s.initial_state for s in specs], dtype=np.float64).reshape(-1, 4)
        self.is_pedestrian = np.array([s.kind == "pedestrian" for s in specs], dtype=bool)
        diameter = np.array([2.0 * s.pedestrian.radius_m for s in specs])
        self.length_m = np.where(self.is_pedestrian, diameter, [s.vehicle.length_m for s in specs])
        self.width_m = np.where(self.is_pedestrian, diameter, [s.vehicle.width_m for s in specs])
        self.bounding_radius_m = np.array([s.bounding_radius_m for s in specs])
        veh = [s.vehicle for s in specs]
        self.wheelbase_m = np.array([v.wheelbase_m for v in veh])
        self.accel_max = np.array([v.accel_max_mps2 for v in veh])
        self.brake_max = np.array([v.brake_max_mps2 for v in veh])
        self.steer_max = np.array([v.steer_max_rad for v in veh])
        self.lat_accel_max = np.array([v.lat_accel_max_mps2 for v in veh])
        self.speed_max = np.where(
            self.is_pedestrian, [s.pedestrian.speed_max_mps for s in specs],
            [v.speed_max_mps for v in veh],
        )
        sensors = [s.sensor for s in specs]
        self.sensor_range_m = np.array([s.range_m for s in sensors])
        self.sensor_half_angle_rad = np.array([s.half_angle_rad for s in sensors])
        self.pos_noise_m = np.array([s.pos_noise_m for s in sensors])
        self.vel_noise_mps = np.array([s.vel_noise_mps for s in sensors])
        self.heading_noise_rad = np.array([s.heading_noise_rad for s in sensors])
        self.v_desired_mps = np.array([s.v_desired_mps for s in specs])
        self.theta = np.array([s.cost_weights.as_array() for s in specs]).reshape(-1, N_FEATURES)
        self.routes = RouteSet([self.road_map.routes[name] for name in self.names])
        self.route_length_m = self.routes.length_m
        self._arrive_at_m = self.route_length_m - ROUTE_END_MARGIN_M  # (n,) [m]

        self._circle_along, self._circle_r = circle_layout(self.length_m, self.width_m,
                                                           self.is_pedestrian)
        self.accel_mps2 = np.zeros(self.n)
        self.last_applied_action = np.zeros((self.n, 2))
        self.prev_accel_mps2 = np.zeros(self.n)
        self.active = np.ones(self.n, dtype=bool)
        self.time_s = 0.0
        self.signals = layout.signals
        self.signal_heads = self.road_map.signal_heads
        if self.signal_heads and self.signals is None:
            raise ValueError("world: the map has signal heads but the layout no signal controller")
        self._progress = None
        self._kinds_key = None
        self._kinds = None
        self._pairs_key = None
        self._pairs = None
        self._kinds_differ = self.is_pedestrian[None, :] != self.is_pedestrian[:, None]
        geometry = (self.is_pedestrian, self.length_m, self.width_m,
                    self.road_map.static_polygons)
        if reuse is not None and reuse.mirror.matches(*geometry):  # same solids: no rebuild
            self.mirror = reuse.mirror
            self.mirror.restore()
        else:
            self.mirror = GeometryMirror(*geometry)
        blind = [(i, poly) for i, s in enumerate(specs) for poly in s.sensor.blind_regions]
        self.fov = FieldOfView(self.mirror, self.road_map.static_polygons, layout.params.n_rays,
                               blind)
        self.mirror.sync(self.state[:, :2], self.state[:, 2], self.active)

    @property
    def velocity_mps(self) -> np.ndarray:
        """(n, 2) velocity vectors [m/s]."""
        return self.state[:, 3:4] * np.column_stack([np.cos(self.state[:, 2]),
                                                     np.sin(self.state[:, 2])])

    def step(self, action: np.ndarray) -> StepEvents:
        """Advance one step of DT_S.

        Args:
            action: (n, 2) finite raw actions (vehicles [a m/s^2, delta rad], pedestrians
                [vx, vy] m/s); rows of inactive agents are ignored. Out-of-range values saturate.
        """
        applied = np.zeros(action.shape, dtype=action.dtype)  # np.zeros_like, no wrapper
        veh, ped, veh_params, ped_speed_max = self._active_kinds()
        self.prev_accel_mps2 = self.accel_mps2.copy()
        if len(veh):
            before = self.state[veh]
            wheelbase, accel_max, brake_max, steer_max, lat_accel_max, speed_max = veh_params
            applied_veh = saturate_vehicle_action(action[veh], before[:, 3], wheelbase,
                                                  accel_max, brake_max, steer_max, lat_accel_max)
            after = bicycle_step(before, applied_veh, wheelbase, speed_max)
            self.state[veh] = after
            applied[veh] = applied_veh
            # effective acceleration: a stopped car "braking" does not decelerate
            self.accel_mps2[veh] = (after[:, 3] - before[:, 3]) / DT_S
        if len(ped):
            before = self.state[ped]
            applied_ped = saturate_pedestrian_action(action[ped], ped_speed_max)
            # |command - old velocity| / dt (what np.linalg.norm computes, without its wrapper)
            dvx = applied_ped[:, 0] - before[:, 3] * np.cos(before[:, 2])
            dvy = applied_ped[:, 1] - before[:, 3] * np.sin(before[:, 2])
            self.state[ped] = pedestrian_step(before, applied_ped)
            applied[ped] = applied_ped
            self.accel_mps2[ped] = np.sqrt(dvx * dvx + dvy * dvy) / DT_S
        self.last_applied_action = applied
        self.time_s += DT_S
        self.mirror.sync(self.state[:, :2], self.state[:, 2], self.active)

        contacts = self.mirror.contacts(self.state[:, :2], self.bounding_radius_m, self.active)
        collided = np.zeros(self.n, dtype=bool)
        for a, b in contacts:
            for label in (a, b):
                if label < self.n:
                    collided[label] = True
        self._progress = None
        s, _ = self.route_progress()
        arrived = self.active & (s >= self._arrive_at_m)
        return StepEvents(collided, contacts, arrived, applied)

    def _active_kinds(self) -> tuple:
        """Index arrays of the active vehicles and pedestrians and their limits, cached.

        Returns:
            vehicle indices (v,), pedestrian indices (p,), the vehicles' (wheelbase, accel_max,
            brake_max, steer_max, lat_accel_max, speed_max), each (v,), and the pedestrians'
            speed_max (p,).
        """
        key = self.active.tobytes()
        if key != self._kinds_key:
            veh = np.flatnonzero(self.active & ~self.is_pedestrian)
            ped = np.flatnonzero(self.active & self.is_pedestrian)
            params = tuple(a[veh] for a in (self.wheelbase_m, self.accel_max, self.brake_max,
                                            self.steer_max, self.lat_accel_max, self.speed_max))
            self._kinds_key, self._kinds = key, (veh, ped, params, self.speed_max[ped])
        return self._kinds

    def deactivate(self, mask: np.ndarray) -> None:
        """Remove agents from the world and from its geometry mirrors."""
        if (mask & self.active).any():
            self.active &= ~mask
            self.mirror.sync(self.state[:, :2], self.state[:, 2], self.active)

    def route_progress(self) -> tuple[np.ndarray, np.ndarray]:
        """Arc length along and signed lateral offset from each agent's route, (n,) each [m]."""
        if self._progress is None:  # cached until the next step moves the agents
            self._progress = self.routes.project(self.state[:, :2])
        return self._progress

    def bodies(self) -> Bodies:
        """Every agent's body and sensor now.

        The poses and speeds are views of the state table: read them, do not keep them past the
        next step.
        """
        return Bodies(self.state[:, :2], self.state[:, 2], self.state[:, 3], self.length_m,
                      self.width_m, self.is_pedestrian, self.bounding_radius_m, self.active,
                      self.sensor_range_m, self.sensor_half_angle_rad)

    def perceive(self, rng: np.random.Generator) -> tuple[FovResult, Measurements]:
        """Every agent's field of view and noisy measurements of what it sees."""
        fov = self.fov.compute(self.bodies())
        meas = measure(fov.visible, self.state[:, :2], self.state[:, 2], self.state[:, 3],
                       self.pos_noise_m, self.vel_noise_mps, self.heading_noise_rad, rng)
        return fov, meas

    def signal_states(self) -> np.ndarray:
        """(H,) int8: the state each signal head shows now (sim/signals.py; empty: none)."""
        if not self.signal_heads:
            return np.zeros(0, dtype=np.int8)
        return self.signals.head_states(self.time_s, self.signal_heads)

    def perceive_signals(self) -> tuple[np.ndarray, np.ndarray]:
        """Which heads every agent reads now, (n, H) bool, and their states (H,)."""
        visible = visible_heads(self.mirror, self.signal_heads, self.state[:, :2],
                                self.state[:, 2], self.sensor_range_m,
                                self.sensor_half_angle_rad, self.active)
        return visible, self.signal_states()

    def step_features(self) -> np.ndarray:
        """(n, N_FEATURES) each agent's cost features this step (sim/costs.py)."""
        _, lateral = self.route_progress()
        xy, heading = self.state[:, :2], self.state[:, 2]
        circles = place_along(xy, heading, self._circle_along)
        key = self.active.tobytes()
        if key != self._pairs_key:  # every active agent but itself is each agent's other
            others = self.active[None, :] & ~np.eye(self.n, dtype=bool)
            self._pairs_key, self._pairs = key, others
        others = self._pairs
        return pairwise_step_features(
            AgentMotion(lateral, self.state[:, 3], self.v_desired_mps, self.accel_mps2,
                        self.prev_accel_mps2),
            AgentFootprints(xy, self.bounding_radius_m, self.is_pedestrian, circles, self._circle_r),
            others, self.road_map.crosswalks, self._kinds_differ)

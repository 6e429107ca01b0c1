"""Pedestrians as noisily-optimal planners: walk along their crossing route at one of a few
speeds (0 = wait), Boltzmann over their own cost, seeing vehicles only through their own field
of view.

Cost (agents/costs.py, the same features as everyone): speed deviation from the pedestrian's
wish (its walking speed once it intends to cross, 0 before), acceleration, safety and the
crosswalk conflict with vehicles predicted at constant velocity from its own tracks. A pedestrian
has the right of way: it expects a vehicle to yield if that vehicle can still stop before the
crosswalk with a comfortable deceleration (`expected_yield_decel_mps2`), and then ignores it.
Gap acceptance emerges from the cost: a close, fast car that could not stop makes waiting
cheaper than walking into its path.
"""

from __future__ import annotations

import numpy as np
from marl_social.perception.tracking import Tracker, TrackSet

from marl_social.models.boltzmann import boltzmann
from marl_social.models.candidates import ScenePrediction
from marl_social.models.pedestrian import PedestrianModel, pedestrian_q_values
from marl_social.models.steering import walk_along
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import Crosswalk, RoadMap


def vehicles_expected_to_yield(tracks: TrackSet, crosswalk: Crosswalk, decel_mps2: float
                               ) -> np.ndarray:
    """(k,) bool: vehicle tracks heading towards the crosswalk that can still stop before it
    braking at decel_mps2 (v^2 / (2 decel) < distance to the crosswalk's near edge).
    """
    if len(tracks) == 0:
        return np.zeros(0, dtype=bool)
    rel = crosswalk.center - tracks.xy
    speed = np.linalg.norm(tracks.velocity, axis=1)
    closing = np.einsum("kd,kd->k", rel, tracks.velocity) / np.maximum(speed, 1e-6)
    # distance from the car's front to the crosswalk's near edge, along its motion
    gap = (np.linalg.norm(rel, axis=1) - 0.5 * crosswalk.width_m - 0.5 * tracks.length_m)
    stopping = speed ** 2 / (2.0 * decel_mps2)
    approaching = closing > 0.0
    return ~tracks.is_pedestrian & approaching & (stopping < gap)


class BoltzmannPedestrian:
    """A pedestrian policy (see module docstring). Planner parameters from its AgentSpec:
    "crossing" (intends to cross), "start_delay_s" (when that intent begins), "beta".
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap):
        self.name = spec.name
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.crosswalks = road_map.crosswalks
        self.crossing = bool(spec.planner.get("crossing", True))
        self.start_delay_s = float(spec.planner.get("start_delay_s", 0.0))
        self.model = PedestrianModel(theta=spec.cost_weights,
                                     beta=float(spec.planner.get("beta", 5.0)),
                                     v_walk_mps=max(spec.v_desired_mps, 0.1),
                                     radius_m=spec.pedestrian.radius_m)
        self.tracker = Tracker(spec.sensor.pos_noise_m, spec.sensor.vel_noise_mps)
        self._times = self.model.plan_times_s
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self.tracker.reset()
        self.time_s = 0.0
        self.prev_speed = 0.0
        self.last_probabilities = None

    def action_distribution(self, obs) -> np.ndarray:
        """(A,) probabilities over model.speeds_mps for this observation (updates the tracks)."""
        decoded = self.layout.decode(obs)
        tracks = self.tracker.update(decoded)
        wants_to_cross = self.crossing and self.time_s >= self.start_delay_s
        v_ref = self.model.v_walk_mps if wants_to_cross else 0.0
        s0, _, _ = self.route.project(decoded.ego[:2].astype(np.float64))
        scene = ScenePrediction.from_tracks(tracks, self._times)
        if self.crosswalks:
            yielding = vehicles_expected_to_yield(tracks, self.crosswalks[0],
                                                  self.model.expected_yield_decel_mps2)
            scene = ScenePrediction(scene.xy, scene.heading, scene.length_m, scene.width_m,
                                    scene.radius_m, scene.is_pedestrian,
                                    scene.mask & ~yielding[None])
        q = pedestrian_q_values(self.model, self.route, float(s0), v_ref, self.prev_speed, scene,
                                self.crosswalks)[0]
        self.last_q = q
        self.last_probabilities = boltzmann(q, self.model.beta)
        return self.last_probabilities

    def __call__(self, obs) -> np.ndarray:
        p = self.action_distribution(obs)
        self.time_s += DT_S
        speed = self.model.speeds_mps[int(self.rng.choice(len(p), p=p))]  # seeded sample
        self.prev_speed = speed
        x, y = (float(c) for c in self.layout.decode(obs).ego[:2])
        return walk_along(self.route, x, y, speed)

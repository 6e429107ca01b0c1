"""Human drivers as noisily-optimal planners (paper section III-B-1, eq. 7-8 and 11).

At every step a human driver computes, from its *own* tracks and the static map,

    Q*(x_hat, u) = min over continuations c of  sum_k theta^T phi(x_k, u_k)      (eq. 11)

(continuations that run into an object the human predicts are excluded: it never plans a
collision, whatever its weights);
for each first action u of a discrete set (held for `first_segment_s`, then continuation c
held to the end of the horizon; all candidates rolled out at once), and samples

    u ~ P(u) = softmax(-beta * Q*(x_hat, u))                                      (eq. 8)

with the episode's seeded generator; beta = inf is the argmin (perfectly rational), beta -> 0
uniform. Others are predicted at constant velocity from the human's tracks. The human chooses
its acceleration along its route (path-velocity decomposition); pure pursuit steers.

The decision model itself (`models/driver.py`, `models/boltzmann.py`) is shared: the robot's
model of a human calls `driver_q_values` with its own hypotheses and (theta_hat, beta_hat).
"""

from __future__ import annotations

import math

import numpy as np
from marl_social.perception.tracking import Tracker

from marl_social.models.boltzmann import boltzmann
from marl_social.models.candidates import ScenePrediction
from marl_social.models.driver import DriverModel, driver_choice_features, driver_q_values
from marl_social.models.steering import pure_pursuit
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap


class BoltzmannDriver:
    """A human driver policy: tracks what it sees, plans (eq. 11), samples (eq. 8).

    Built from its own AgentSpec (planner parameters: "beta", "theta" override the defaults),
    the shared observation layout and the static map — nothing else.
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap):
        self.name = spec.name
        self.layout = layout
        self.route = road_map.routes[spec.name]
        self.crosswalks = road_map.crosswalks
        self.model = DriverModel(
            theta=spec.cost_weights, beta=float(spec.planner.get("beta", 5.0)),
            v_desired_mps=min(spec.v_desired_mps, road_map.speed_limit_mps),
            vehicle=spec.vehicle,
        )
        self.tracker = Tracker(spec.sensor.pos_noise_m, spec.sensor.vel_noise_mps)
        self._times = self.model.plan_times_s
        self.record_decisions = False
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.rng = np.random.default_rng(seed)
        self.tracker.reset()
        self.prev_accel = 0.0
        self.last_probabilities = None
        self.last_q = None
        self.decisions = []  # with record_decisions: (features, allowed, chosen index) per step
        self._pending_features = None

    def action_distribution(self, obs) -> np.ndarray:
        """(A,) probabilities of the first actions for this observation (updates the tracks)."""
        decoded = self.layout.decode(obs)
        x, y = float(decoded.ego[0]), float(decoded.ego[1])
        v = float(decoded.ego[4])
        tracks = self.tracker.update(decoded)
        s0, _ = self.route.project_point(x, y)
        self._last_pose = (x, y, math.atan2(float(decoded.ego[3]), float(decoded.ego[2])), v, s0)
        scene = ScenePrediction.from_tracks(tracks, self._times)
        q = driver_q_values(self.model, self.route, s0, v, self.prev_accel, scene,
                            self.crosswalks)[0]
        self.last_q = q
        self.last_probabilities = boltzmann(q, self.model.beta)
        if self.record_decisions:  # computed apart: the decision itself is unchanged
            self._pending_features = driver_choice_features(
                self.model, self.route, s0, v, self.prev_accel, scene, self.crosswalks)
        return self.last_probabilities

    def choose(self, probabilities: np.ndarray) -> int:
        """Sample an action index from the distribution with the policy's seeded generator
        (inverse-CDF sampling: one uniform draw).
        """
        cdf = np.cumsum(probabilities)
        k = int(np.searchsorted(cdf, self.rng.random() * cdf[-1], side="right"))
        return min(k, len(probabilities) - 1)

    def __call__(self, obs) -> np.ndarray:
        p = self.action_distribution(obs)
        chosen = self.choose(p)
        if self._pending_features is not None:
            self.decisions.append((*self._pending_features, chosen))
            self._pending_features = None
        accel = self.model.first_actions_mps2[chosen]
        self.prev_accel = accel
        x, y, psi, v, s_arc = self._last_pose
        steer = pure_pursuit(self.route, x, y, psi, v, s_arc, self.model.vehicle.wheelbase_m)
        return np.array([accel, steer], dtype=np.float32)

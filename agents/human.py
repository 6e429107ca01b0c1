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
from marl_social.agents.base import BoltzmannPolicy
from marl_social.agents.params import DriverParams, parse_planner_params

from marl_social.models.candidates import ScenePrediction
from marl_social.models.driver import DriverModel, driver_choice_features, driver_q_values
from marl_social.models.steering import pure_pursuit
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.observation import Measurements, ObservationLayout
from marl_social.sim.road_map import RoadMap


class BoltzmannDriver(BoltzmannPolicy):
    """A human driver policy: tracks what it sees, plans (eq. 11), samples (eq. 8).

    Built from its own AgentSpec (its cost weights; planner parameter "beta", see
    agents/params.DriverParams), the shared observation layout and the static map — nothing
    else.

    Args:
        spec: the driver's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        params: its planner parameters (default: parsed from spec.planner).
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 params: DriverParams | None = None):
        params = params or parse_planner_params(DriverParams, spec)
        model = DriverModel(
            theta=spec.cost_weights, beta=params.beta,
            v_desired_mps=min(spec.v_desired_mps, road_map.speed_limit_mps),
            vehicle=spec.vehicle,
        )
        super().__init__(spec, layout, road_map, model)
        self.record_decisions = False
        self.reset()

    def reset_state(self) -> None:
        """Forget the previous acceleration and the recorded decisions."""
        self.prev_accel = 0.0
        self.decisions = []  # with record_decisions: (features, allowed, chosen index) per step
        self._pending_features = None

    def q_values(self, decoded: Measurements, scene: ScenePrediction) -> np.ndarray:
        """(A,) Q* of each first acceleration (eq. 11) along the driver's route."""
        x, y = float(decoded.ego[0]), float(decoded.ego[1])
        v = float(decoded.ego[4])
        s0, _ = self.route.project_point(x, y)
        self._last_pose = (x, y, math.atan2(float(decoded.ego[3]), float(decoded.ego[2])), v, s0)
        q = driver_q_values(self.model, self.route, s0, v, self.prev_accel, scene,
                            self.crosswalks)[0]
        if self.record_decisions:  # computed apart: the decision itself is unchanged
            self._pending_features = driver_choice_features(
                self.model, self.route, s0, v, self.prev_accel, scene, self.crosswalks)
        return q

    def choose(self, probabilities: np.ndarray) -> int:
        """Sample an action index from (A,) `probabilities` with the seeded generator.

        Inverse-CDF sampling: one uniform draw per call.
        """
        cdf = np.cumsum(probabilities)
        k = int(np.searchsorted(cdf, self.rng.random() * cdf[-1], side="right"))
        return min(k, len(probabilities) - 1)

    def act(self, chosen: int, obs: np.ndarray) -> np.ndarray:
        """The (2,) [acceleration m/s^2, steering rad] of first action `chosen`."""
        if self._pending_features is not None:
            self.decisions.append((*self._pending_features, chosen))
            self._pending_features = None
        accel = self.model.first_actions_mps2[chosen]
        self.prev_accel = accel
        x, y, psi, v, s_arc = self._last_pose
        steer = pure_pursuit(self.route, x, y, psi, v, s_arc, self.model.vehicle.wheelbase_m)
        return np.array([accel, steer], dtype=np.float32)

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

`driver_q_values` is the same computation for arbitrary hypotheses about the scene: the robot's
model of a human (issue: social perception) calls it with its own hypotheses and (theta_hat,
beta_hat).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from marl_social.agents.candidates import (  # noqa: F401  (re-exported for planners' users)
    CandidateSet,
    ScenePrediction,
    collision_free_totals,
    evaluate_candidates,
    rollout_speeds,
)
from marl_social.agents.costs import CostWeights
from marl_social.agents.steering import pure_pursuit
from marl_social.perception.tracking import Tracker

from marl_social.agent_spec import AgentSpec, VehicleParams
from marl_social.observation import ObservationLayout
from marl_social.road_map import Crosswalk, RoadMap, Route


@dataclass(frozen=True)
class DriverModel:
    """What defines a driver's decision (its own, or the robot's estimate of it).

    Attributes:
        theta: cost weights.
        beta: rationality (>= 0; inf = always the best action).
        v_desired_mps: speed it wants [m/s] (its v_ref).
        first_actions_mps2: (A,) candidate first accelerations [m/s^2].
        continuations_mps2: (C,) accelerations held after the first segment [m/s^2].
        first_segment_s: how long the first action is held in the rollout [s].
        horizon_s: planning horizon N [s].
        plan_dt_s: time step of the planner's rollout [s] (coarser than the simulator's;
            per-step costs are scaled by plan_dt / DT_S so Q is in simulator-step units).
        vehicle: its physical parameters.
    """

    theta: CostWeights = field(default_factory=CostWeights)
    beta: float = 5.0
    v_desired_mps: float = 11.5
    first_actions_mps2: tuple = (-8.0, -6.0, -4.0, -3.0, -2.0, -1.0, 0.0, 1.0, 2.0)
    continuations_mps2: tuple = (-4.0, -2.0, -1.0, 0.0, 1.0)
    first_segment_s: float = 0.5
    horizon_s: float = 3.0
    plan_dt_s: float = 0.25
    vehicle: VehicleParams = field(default_factory=VehicleParams)

    def __post_init__(self):
        if not (self.beta >= 0):  # also rejects NaN
            raise ValueError(f"DriverModel.beta must be >= 0 (inf allowed), got {self.beta}")
        if not self.horizon_s > self.first_segment_s >= self.plan_dt_s > 0:
            raise ValueError("DriverModel: need horizon_s > first_segment_s >= plan_dt_s > 0")

    @property
    def candidates(self) -> CandidateSet:
        return CandidateSet(self.first_actions_mps2, self.continuations_mps2,
                            self.first_segment_s, self.horizon_s, self.plan_dt_s)

    @property
    def plan_times_s(self) -> np.ndarray:
        """(T,) times of the rollout's states after each planner step [s]."""
        return self.candidates.plan_times_s


def driver_q_values(model: DriverModel, route: Route, s0: float, v0: float, prev_accel: float,
                    scene: ScenePrediction, crosswalks: tuple[Crosswalk, ...]) -> np.ndarray:
    """Q*(x_hat, u) for each first action u and each scene hypothesis (eq. 11).

    Args:
        route: the driver's route; s0 [m], v0 [m/s]: its arc length and speed;
        prev_accel: its last acceleration [m/s^2] (for the jerk term);
        scene: predicted others, L hypotheses, at model.plan_times_s.
    Returns:
        (L, A) optimal cost-to-go of each first action; continuations that run into a
        predicted object are excluded (candidates.collision_free_totals).
    """
    ev = evaluate_candidates(model.candidates, model.theta.as_array(), model.v_desired_mps,
                             model.vehicle, route, s0, v0, prev_accel, scene, crosswalks,
                             geometry=True)
    return collision_free_totals(ev).min(axis=-1)


def driver_choice_features(model: DriverModel, route: Route, s0: float, v0: float,
                           prev_accel: float, scene: ScenePrediction,
                           crosswalks: tuple[Crosswalk, ...]) -> tuple[np.ndarray, np.ndarray]:
    """What a driver's decision depends on, linear in theta (for discrete-choice IRL,
    agents/choice_irl.py): Q*(u) = min over allowed c of theta . features[u, c].

    Returns:
        features (A, C, N_FEATURES): per-feature totals of each candidate [simulator-step units];
        allowed (A, C) bool: the continuations collision_free_totals keeps.
        Both for the first scene hypothesis.
    """
    ev = evaluate_candidates(model.candidates, model.theta.as_array(), model.v_desired_mps,
                             model.vehicle, route, s0, v0, prev_accel, scene, crosswalks,
                             geometry=True, features=True)
    return ev.feature_totals[0].copy(), np.isfinite(collision_free_totals(ev)[0])


def boltzmann(q_values: np.ndarray, beta: float) -> np.ndarray:
    """P(u) = softmax(-beta * Q) along the last axis; beta = inf puts all mass on the argmin
    (ties split evenly), beta = 0 is uniform."""
    q = np.asarray(q_values, dtype=np.float64)
    if math.isinf(beta):
        best = q == q.min(axis=-1, keepdims=True)
        return best / best.sum(axis=-1, keepdims=True)
    z = -beta * (q - q.min(axis=-1, keepdims=True))
    p = np.exp(z)
    return p / p.sum(axis=-1, keepdims=True)


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
        (inverse-CDF sampling: one uniform draw)."""
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

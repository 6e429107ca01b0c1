"""The driver's decision model (paper eq. 11): Q*(x_hat, u) of each first acceleration u.

It is shared by the human drivers (who act on it) and the robot (which infers from it).

Q*(x_hat, u) = min over continuations c of  sum_k theta^T phi(x_k, u_k); continuations that
run into an object the driver predicts are excluded (it never plans a collision).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from marl_social.models.candidates import (
    CandidateSet,
    ScenePrediction,
    collision_free_totals,
    evaluate_candidates,
)
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import CostWeights
from marl_social.sim.road_map import Crosswalk, Route


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
        model: the driver's decision model (A first actions).
        route: the driver's route.
        s0: its arc length along the route [m].
        v0: its speed [m/s].
        prev_accel: its last acceleration [m/s^2] (for the jerk term).
        scene: predicted others, L hypotheses, at model.plan_times_s.
        crosswalks: the crosswalks of the map.

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
    """What a driver's decision depends on, linear in theta.

    For discrete-choice IRL (agents/irl/choice.py): Q*(u) = min over allowed c of
    theta . features[u, c]. The arguments are those of driver_q_values.

    Returns:
        features (A, C, N_FEATURES): per-feature totals of each candidate [simulator-step units];
        allowed (A, C) bool: the continuations collision_free_totals keeps.
        Both for the first scene hypothesis.
    """
    ev = evaluate_candidates(model.candidates, model.theta.as_array(), model.v_desired_mps,
                             model.vehicle, route, s0, v0, prev_accel, scene, crosswalks,
                             geometry=True, features=True)
    return ev.feature_totals[0].copy(), np.isfinite(collision_free_totals(ev)[0])

"""Probabilistic contingency MPC (paper section IV-A).

The structure is that of Zhan et al. 2016, "non-conservatively defensive" planning.

The robot chooses its acceleration along its route. Every candidate plan is a shared first
segment (first action u, held `first_segment_s`: what is executed, re-planned every step) followed
by one branch per live hypothesis l (continuation c_l). The expected cost over the beliefs
(eq. 14) is

    J(u) = sum_l b_l [ C_first(u; x_l) + min_{c feasible under l} C_branch(u, c; x_l) ]

where hypotheses with b_l < epsilon are dropped (the paper's tail threshold) and the remaining
b_l renormalized. A (u, c) is feasible under l if, over the horizon, its covering circles keep
`min_gap_m` from every object of hypothesis l and from the static polygons' bounding boxes, it
never shares a crosswalk with a pedestrian of hypothesis l (conflict below `max_conflict`) and it
respects the speed limit; u must have a
feasible branch under *every* live hypothesis (defensive), while the cost of each branch counts
only with its belief (not overly conservative). If no u is feasible, the robot brakes as hard as
it can (the safest action available). Acceleration and curvature limits are those of the
vehicle (actions saturate in the dynamics); lateral motion is path tracking (pure pursuit), so
curvature / lateral-acceleration limits are enforced by the steering saturation (G-G), not by
the MPC.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from marl_social.models.candidates import CandidateSet, ScenePrediction, evaluate_candidates
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import CostWeights
from marl_social.sim.road_map import Crosswalk, Route


@dataclass(frozen=True)
class MpcConfig:
    """The MPC's configuration.

    Attributes:
        theta: the robot's cost weights theta_R.
        candidates: first actions / continuations / segment / horizon.
        epsilon: tail threshold on beliefs.
        min_gap_m: safety margin to every object (covering circles) [m].
        max_conflict: largest allowed crosswalk conflict (own x pedestrian occupancy) [0..1].
    """

    theta: CostWeights = field(default_factory=CostWeights)
    candidates: CandidateSet = field(default_factory=lambda: CandidateSet(
        first_actions_mps2=(-8.0, -6.0, -4.0, -3.0, -2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0),
        continuations_mps2=(-8.0, -4.0, -2.0, 0.0, 1.0),
        first_segment_s=0.5, horizon_s=4.0, plan_dt_s=0.25))
    epsilon: float = 0.02
    min_gap_m: float = 0.5
    max_conflict: float = 0.05


@dataclass(frozen=True)
class MpcResult:
    """The result of one MPC solve.

    Attributes:
        accel_mps2: the chosen first action [m/s^2].
        expected_cost: (A,) J(u) (inf where infeasible).
        live: (L,) bool, the hypotheses used.
        weights: (L,) the renormalized beliefs.
        feasible: whether some first action is feasible (else: hardest braking).
    """

    accel_mps2: float
    expected_cost: np.ndarray
    live: np.ndarray
    weights: np.ndarray
    feasible: bool


def plan(config: MpcConfig, vehicle: VehicleParams, route: Route, s0: float, v0: float,
         prev_accel: float, v_ref_mps: float, speed_limit_mps: float, scene: ScenePrediction,
         beliefs: np.ndarray, crosswalks: tuple[Crosswalk, ...],
         static_boxes: np.ndarray | None = None) -> MpcResult:
    """One MPC solve.

    Args:
        config: the MPC configuration.
        vehicle: the robot's physical parameters.
        route: the robot's route.
        s0: the robot's arc length along its route [m].
        v0: its speed [m/s].
        prev_accel: its previous acceleration [m/s^2].
        v_ref_mps: reference speed (v_traffic) [m/s].
        speed_limit_mps: hard speed limit [m/s].
        scene: L hypotheses of the others (at config.candidates.plan_times_s).
        beliefs: (L,) probability of each hypothesis.
        crosswalks: the map's crosswalks.
        static_boxes: (S, 4) bounding boxes [xmin, ymin, xmax, ymax] of the static polygons [m].
    """
    beliefs = np.asarray(beliefs, dtype=np.float64)
    live = beliefs >= config.epsilon
    if not live.any():
        live = beliefs == beliefs.max()
    weights = np.where(live, beliefs, 0.0)
    weights = weights / weights.sum()
    cands = config.candidates
    ev = evaluate_candidates(cands, config.theta.as_array(), v_ref_mps, vehicle, route, s0, v0,
                             prev_accel, scene, crosswalks, geometry=True,
                             static_boxes=static_boxes)
    n_first = cands.n_first
    first_cost = ev.step_cost[..., :n_first].sum(axis=-1)[..., 0]  # (L, A): shared segment
    branch_cost = ev.step_cost[..., n_first:].sum(axis=-1)  # (L, A, C)
    feasible = ((ev.min_gap_m >= config.min_gap_m) & (ev.conflict <= config.max_conflict)
                & (ev.v.max(axis=-1) <= speed_limit_mps + 1e-6)[None]
                & (ev.static_gap_m >= config.min_gap_m)[None])  # (L, A, C)
    # the shared first segment is the same for every continuation: it must be feasible itself,
    # which the per-(u, c) check covers because every branch contains it
    best_branch = np.where(feasible, branch_cost, np.inf).min(axis=-1)  # (L, A)
    per_hyp = first_cost + best_branch  # (L, A), inf if u has no feasible branch under l
    blocked = (np.isinf(per_hyp) & live[:, None]).any(axis=0)  # some live l has no safe branch
    finite = np.where(live[:, None] & ~np.isinf(per_hyp), per_hyp, 0.0)
    expected = np.where(blocked, np.inf, (weights[:, None] * finite).sum(axis=0))
    if np.all(np.isinf(expected)):
        return MpcResult(float(min(cands.first_actions_mps2)), expected, live, weights, False)
    k = int(np.argmin(expected))
    return MpcResult(float(cands.first_actions_mps2[k]), expected, live, weights, True)

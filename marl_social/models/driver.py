"""The driver's decision model (paper eq. 11): Q*(x_hat, u) of each first acceleration u.

It is shared by the human drivers (who act on it) and the robot (which infers from it).

Q*(x_hat, u) = min over continuations c of  sum_k theta^T phi(x_k, u_k); continuations that
run into an object the driver predicts are excluded (it never plans a collision).

The road's rules enter through `RoadRules` (built by agents/human.py from the static map with
sim/route_rules.py): a stop line the driver has not yet stopped at is a constraint (plans
whose front passes it are excluded), the right of way is a cost (the conflict feature over
the zones it yields at: gap acceptance emerges from it), and it keeps to the curve speed in
bends (a constraint, like the stop line).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from marl_social.models import kernel_loading
from marl_social.models.candidates import (
    CandidateEvaluation,
    PlanningEgo,
    Surroundings,
    evaluate_candidates,
)
from marl_social.models.gap_evaluation import kernel_rule_totals
from marl_social.models.rollouts import CandidateSet, cached_or_computed
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import CostWeights
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CurveSpeed


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
        yield_margin_s: in a conflict zone it yields at, it wants to be out of the zone this
            long before a car with the right of way arrives (its accepted gap) [s].
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
    yield_margin_s: float = 1.5

    def __post_init__(self):
        if not (self.beta >= 0):  # also rejects NaN
            raise ValueError(f"DriverModel.beta must be >= 0 (inf allowed), got {self.beta}")
        if not self.horizon_s > self.first_segment_s >= self.plan_dt_s > 0:
            raise ValueError("DriverModel: need horizon_s > first_segment_s >= plan_dt_s > 0")
        if not self.yield_margin_s >= 0:
            raise ValueError(f"DriverModel.yield_margin_s must be >= 0, got {self.yield_margin_s}")

    @property
    def candidates(self) -> CandidateSet:
        return CandidateSet(self.first_actions_mps2, self.continuations_mps2,
                            self.first_segment_s, self.horizon_s, self.plan_dt_s)

    @property
    def plan_times_s(self) -> np.ndarray:
        """(T,) times of the rollout's states after each planner step [s]."""
        return self.candidates.plan_times_s


@dataclass(frozen=True)
class RoadRules:
    """What the static map imposes on one decision of a driver (sim/route_rules.py).

    Attributes:
        stop_s_m: arc length its front must not pass: the next stop line it has not yet come to
            rest at [m]; None: no such line ahead.
        yield_zones: the conflict zones it yields at, each (polygon (V, 2) [m], priority (L, M)
            bool: the scene objects with the right of way there).
        curve_speed: the speed it keeps to in bends (a constraint); None: straight route.
    """

    stop_s_m: float | None = None
    yield_zones: tuple = ()
    curve_speed: CurveSpeed | None = None


def _model_constants(model: DriverModel) -> tuple:
    """(model.candidates, model.theta.as_array() read-only), once per (hashable) model.

    Remembered by identity too (a frozen model keeps its constants): hashing a DriverModel
    (its fields, the weights' and the vehicle's) takes longer than the rest of this.
    """
    hit = _CONSTANTS_BY_MODEL.get(id(model))
    if hit is not None and hit[0] is model:
        return hit[1]
    constants = cached_or_computed(_cached_model_constants, model)
    if len(_CONSTANTS_BY_MODEL) >= _MAX_CONSTANTS_BY_MODEL:
        _CONSTANTS_BY_MODEL.clear()
    _CONSTANTS_BY_MODEL[id(model)] = (model, constants)
    return constants


# id(model) -> (model, its _model_constants); emptied when it reaches this many entries
_MAX_CONSTANTS_BY_MODEL = 256
_CONSTANTS_BY_MODEL: dict[int, tuple] = {}


@functools.lru_cache(maxsize=256)
def _cached_model_constants(model: DriverModel) -> tuple:
    theta = model.theta.as_array()
    theta.setflags(write=False)
    return model.candidates, theta


def _surroundings(model: DriverModel, scene: ScenePrediction,
                  crosswalks: tuple[Crosswalk, ...], rules: RoadRules | None) -> Surroundings:
    """What a driver's plans are costed against: the scene, and the road's rules if any."""
    if rules is None:
        return Surroundings(scene, crosswalks)
    return Surroundings(scene, crosswalks, rules.yield_zones, model.yield_margin_s,
                        rules.curve_speed)


def _evaluate_features(model: DriverModel, route: Route, s0: float, v0: float,
                       prev_accel: float, scene: ScenePrediction,
                       crosswalks: tuple[Crosswalk, ...],
                       rules: RoadRules | None) -> CandidateEvaluation:
    """The candidates' evaluation with their feature totals (evaluate_candidates')."""
    candidates, theta = _model_constants(model)
    return evaluate_candidates(
        PlanningEgo(candidates, theta, model.v_desired_mps, model.vehicle, route, s0, v0,
                    prev_accel), _surroundings(model, scene, crosswalks, rules),
        geometry=True, features=True, vehicle_gaps_only=True)


def rule_abiding_totals(ev: CandidateEvaluation, model: DriverModel, s0: float,
                        rules: RoadRules | None) -> np.ndarray:
    """(L, A, C) collision_free_totals, also +inf for plans that break a rule of the road.

    Plans whose front passes rules.stop_s_m are excluded (if none stops in time, those that
    overshoot least are kept: the hardest braking), then those that exceed the curve speed
    (if every one does, those that exceed it least are kept). If no plan both keeps these
    rules and avoids the predicted vehicles, the rules are dropped under that hypothesis
    (avoiding a collision comes first).

    In one compiled call (models/cost_kernels.rule_abiding_totals; its numpy reference:
    tests/reference/rule_totals.py, the same bits).

    Args:
        ev: the candidates' evaluation (with travel_m, and curve_excess_mps for a bendy route).
        model: the driver's decision model (its vehicle length).
        s0: the driver's arc length along its route [m].
        rules: the road's rules (None: collision_free_totals).
    """
    cost = ev.step_cost
    if not (isinstance(cost, np.ndarray) and cost.dtype == np.float64
            and cost.flags.c_contiguous):
        # np.sum's own order over a layout the kernel does not walk, as one step to add to 0.0
        cost = np.ascontiguousarray(np.sum(cost, axis=-1, dtype=np.float64)[..., None])
    plans = cost.shape[:3]
    stop_s_m = None if rules is None else rules.stop_s_m
    excess = None if rules is None else ev.curve_excess_mps  # no rules: none applies
    travel = _NO_TRAVEL if stop_s_m is None else ev.travel_m
    _, cost_kernels = kernel_loading.load()
    return cost_kernels.rule_abiding_totals(
        cost, _float_array(ev.min_vehicle_gap_m, plans),
        _float_array(ev.vehicle_clearance_m, plans),
        travel if travel is _NO_TRAVEL else _float_array(travel, plans[1:] + travel.shape[-1:]),
        float(s0), 0.5 * model.vehicle.length_m,
        _NO_STOP if stop_s_m is None else _stop_line(float(stop_s_m)),
        _NO_EXCESS if excess is None else _float_array(excess, plans[1:]))


def _float_array(values, shape: tuple) -> np.ndarray:
    """Values broadcast to shape, C-contiguous float64 (the same array when it already is)."""
    if getattr(values, "shape", None) != shape:
        values = np.broadcast_to(values, shape)
    return np.ascontiguousarray(values, dtype=np.float64)


@functools.lru_cache(maxsize=256)
def _stop_line(stop_s_m: float) -> np.ndarray:
    """(1,) read-only: a stop line's arc length [m] as the kernel takes it (a map has few)."""
    stop = np.array([stop_s_m])
    stop.setflags(write=False)
    return stop


_NO_TRAVEL = np.zeros((0, 0, 0))  # no stop line: the kernel reads no travel
_NO_STOP = np.zeros(0)
_NO_EXCESS = np.zeros((0, 0))
for _constant in (_NO_TRAVEL, _NO_STOP, _NO_EXCESS):
    _constant.setflags(write=False)


def driver_q_values(model: DriverModel, route: Route, s0: float, v0: float, prev_accel: float,
                    scene: ScenePrediction, crosswalks: tuple[Crosswalk, ...],
                    rules: RoadRules | None = None) -> np.ndarray:
    """Q*(x_hat, u) for each first action u and each scene hypothesis (eq. 11).

    Args:
        model: the driver's decision model (A first actions).
        route: the driver's route.
        s0: its arc length along the route [m].
        v0: its speed [m/s].
        prev_accel: its last acceleration [m/s^2] (for the jerk term).
        scene: predicted others, L hypotheses, at model.plan_times_s.
        crosswalks: the crosswalks of the map.
        rules: stop line, right of way and curve speeds on its route (None: none).

    Returns:
        (L, A) optimal cost-to-go of each first action; continuations that run into a
        predicted object, or past a stop line not yet served, are excluded
        (rule_abiding_totals).
    """
    candidates, theta = _model_constants(model)
    ego = PlanningEgo(candidates, theta, model.v_desired_mps, model.vehicle, route, s0, v0,
                      prev_accel)
    totals = kernel_rule_totals(ego, _surroundings(model, scene, crosswalks, rules),
                                None if rules is None else rules.stop_s_m)
    return np.minimum.reduce(totals, axis=-1)  # totals.min(axis=-1) without its wrapper


def driver_choice_features(model: DriverModel, route: Route, s0: float, v0: float,
                           prev_accel: float, scene: ScenePrediction,
                           crosswalks: tuple[Crosswalk, ...],
                           rules: RoadRules | None = None) -> tuple[np.ndarray, np.ndarray]:
    """What a driver's decision depends on, linear in theta.

    For discrete-choice IRL (agents/irl/choice.py): Q*(u) = min over allowed c of
    theta . features[u, c]. The arguments are those of driver_q_values.

    Returns:
        features (A, C, N_FEATURES): per-feature totals of each candidate [simulator-step units];
        allowed (A, C) bool: the continuations rule_abiding_totals keeps.
        Both for the first scene hypothesis.
    """
    ev = _evaluate_features(model, route, s0, v0, prev_accel, scene, crosswalks, rules)
    return ev.feature_totals[0].copy(), np.isfinite(rule_abiding_totals(ev, model, s0, rules)[0])

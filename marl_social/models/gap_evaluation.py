"""The candidates' costs and vehicle gaps in a few compiled loops.

`vehicle_gap_evaluation` is `candidates.evaluate_candidates(..., geometry=True,
vehicle_gaps_only=True)` -- what a driver's Q* needs (models/driver.py) and what the robot's
model of a human evaluates (perception/belief) -- bit for bit (tests/models/test_gap_evaluation.py).
A decision's plans are a few hundred values, so in numpy the time goes to the number of calls,
not to the arithmetic; here the rollouts (with the curve speed), the route's poses, the
covering circles, their gaps to the scene's objects and the step costs are numba loops
(models/gap_kernels.py, cost_kernels.py, imported at the first call) that do the reference's arithmetic in its
order. What stays in numpy:

* np.exp of the safety feature (numpy's SIMD exp and libm's differ in the last bit): the
  kernels hand it the clipped, negated gaps in one array and sum its result;
* np.tanh of the ego's and the objects' crosswalk occupancies and of the ego's zone
  occupancies (the kernels compute its arguments and finish the occupancies), and the objects'
  claims on the zones (candidates.zone_claims) summed over them (`_conflict_rows`).

`vehicle_gap_evaluations` evaluates the same candidates from several initial speeds with the
scene's inputs (covering circles, zone claims, crosswalk rows) built once.

Crosswalks without a pair of the ego (a vehicle) and a present pedestrian add +0.0 and are
left out (every feature is >= +0, and x + 0.0 == x for x >= +0), as is the tracking feature
of a plan along its route (lateral offset 0).
"""

import math
from dataclasses import dataclass

import numpy as np

from marl_social.models import kernel_loading
from marl_social.models.candidates import (
    CandidateEvaluation,
    PlanningEgo,
    Surroundings,
    _vehicle_circles,
    checked_initial_state,
)
from marl_social.models.circle_gaps import _scene_layout, scene_circle_inputs
from marl_social.models.circle_gaps import crosswalk_rows as crosswalk_rows_of
from marl_social.models.rollouts import CandidateSet, _plan_constants
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import OCCUPANCY_SOFTNESS_M, _polygon_edges, object_sum
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Route
from marl_social.sim.route_rules import CURVE_PROFILE_STEP_M, CurveSpeed


def vehicle_gap_evaluation(ego: PlanningEgo, around: Surroundings) -> CandidateEvaluation:
    """evaluate_candidates(..., geometry=True, vehicle_gaps_only=True), the same bits.

    The arguments are those of models/candidates.evaluate_candidates (ego.theta (N_FEATURES,),
    around.scene L hypotheses of M objects at the candidates' plan_times_s); so is the result:
    step_cost (L, A, C, T), v, a_eff and travel_m (A, C, T), min_vehicle_gap_m and
    vehicle_clearance_m (L, A, C) [m], curve_excess_mps (A, C) [m/s] with a curve speed; the
    other fields None.

    The rollouts, the gaps and the step costs are compiled loops (models/gap_kernels.py,
    cost_kernels.py; they read the route's per-segment pose table, Route.segment_pose_table and
    vertex_s_m); np.exp and np.tanh stay in numpy. Any number of objects; the initial state
    is checked as evaluate_candidates checks it (candidates.checked_initial_state: a
    ValueError for a non-finite or out-of-range speed or arc length).
    """
    return _evaluation(_kernel_arrays(ego, around), ego.v_ref_mps, ego.prev_accel,
                       around.curve_speed)


def vehicle_gap_evaluations(ego: PlanningEgo, speeds_mps: np.ndarray,
                            around: Surroundings) -> list[CandidateEvaluation]:
    """`vehicle_gap_evaluation` from each of several initial speeds, the scene's work shared.

    speeds_mps: (S,) initial speeds [m/s], in place of ego.v0; the other arguments are
    vehicle_gap_evaluation's. Returns the S evaluations, each bit for bit
    vehicle_gap_evaluation's from its speed: the scene's covering circles, its objects' claims
    on the zones and the crosswalk rows are computed once, and only the rollouts, the gaps and
    the step costs once per speed (the perception/belief model of a human averaged over the
    robot's estimate of its speed).
    """
    shared = _kernel_scene(ego, around)
    return [_evaluation(_kernel_motion(shared, checked_initial_state(ego.s0, float(v))[1]),
                        ego.v_ref_mps, ego.prev_accel, around.curve_speed)
            for v in speeds_mps]


def _evaluation(arrays: tuple, v_ref_mps: float, prev_accel: float,
                curve_speed: CurveSpeed | None) -> CandidateEvaluation:
    """The CandidateEvaluation of `_kernel_arrays`' result (step_costs applied)."""
    cost_kernels, motion, excess, gaps, cost_arguments = arrays
    cost = cost_kernels.step_costs(motion, float(v_ref_mps), float(prev_accel), cost_arguments)
    v, ds, a_eff = motion  # (A, C, T) each
    clearance, vehicle_gap = gaps  # (L, A, C) each
    return CandidateEvaluation(cost, v, a_eff, None, None, None, vehicle_gap, None, ds,
                               clearance, None if curve_speed is None else excess)


def kernel_rule_totals(ego: PlanningEgo, around: Surroundings,
                       stop_s_m: float | None = None) -> np.ndarray:
    """models/driver.rule_abiding_totals of `vehicle_gap_evaluation`'s evaluation, in fewer calls.

    The step costs and the totals in one compiled call (cost_kernels.plan_totals: step_costs,
    then rule_abiding_totals, the same bits), without the CandidateEvaluation in between.
    The arguments are vehicle_gap_evaluation's and stop_s_m, the stop line's arc length
    (RoadRules.stop_s_m) [m] (None: no stop line); the curve speed counts as a rule, as
    driver.rule_abiding_totals counts it with rules. Returns the (L, A, C) totals, inf for
    the excluded plans.
    """
    cost_kernels, motion, excess, gaps, cost_arguments = _kernel_arrays(ego, around)
    return cost_kernels.plan_totals(
        motion, float(ego.v_ref_mps), float(ego.prev_accel), cost_arguments, gaps,
        (float(ego.s0), 0.5 * ego.vehicle.length_m, 0.0 if stop_s_m is None else float(stop_s_m),
         stop_s_m is not None, excess, around.curve_speed is not None))


def _kernel_arrays(ego: PlanningEgo, around: Surroundings) -> tuple:
    """gap_kernels.plan_evaluation's arrays, np.exp and np.tanh applied.

    Returns:
        (cost_kernels, motion (3, A, C, T), curve excess (A, C) or (0, C), gaps (2, L, A, C):
        clearance and vehicle gap [m], and step_costs' arguments after v_ref and prev_accel
        as a tuple).
    """
    _, v0 = checked_initial_state(ego.s0, ego.v0)
    return _kernel_motion(_kernel_scene(ego, around), v0)


@dataclass(frozen=True)
class _KernelScene:
    """What `_kernel_motion` takes that does not depend on the initial speed (_kernel_scene)."""

    kernels: object
    cost_kernels: object
    plan: "_PreparedPlan"
    s0: float
    curve_speed: CurveSpeed | None
    route: Route
    scene_inputs: tuple
    radius_m: np.ndarray
    present: np.ndarray
    is_pedestrian: np.ndarray
    clipped: bool
    weights: np.ndarray
    conflict_rows: tuple


def _kernel_scene(ego: PlanningEgo, around: Surroundings) -> _KernelScene:
    """The scene's kernel inputs, shared by every initial speed."""
    cands, scene = ego.cands, around.scene
    s0, _ = checked_initial_state(ego.s0, 0.0)
    kernels, cost_kernels = _KERNELS or _kernels()
    plan = _prepared_plan(cands, ego.vehicle)
    weights = _weights(ego.theta)  # speed, accel, jerk, safety, conflict
    w_conflict = weights[4]
    conflict_rows = _conflict_rows(
        scene, around.crosswalks if w_conflict != 0.0 else (),
        around.yield_zones if w_conflict != 0.0 else (), around.yield_margin_s, plan.dt_s)
    return _KernelScene(kernels, cost_kernels, plan, float(s0), around.curve_speed, ego.route,
                        scene_circle_inputs(scene),
                        np.ascontiguousarray(scene.radius_m, dtype=float),
                        np.ascontiguousarray(scene.mask), np.ascontiguousarray(scene.is_pedestrian),
                        bool(weights[3] != 0.0), weights, conflict_rows)


def _kernel_motion(shared: _KernelScene, v0: float) -> tuple:
    """`_kernel_arrays`' result from the shared scene inputs and one initial speed v0 [m/s]."""
    plan, curve_speed, route = shared.plan, shared.curve_speed, shared.route
    crosswalk_rows, zone_rows, zone_sizes, zone_sums = shared.conflict_rows
    scene_xy, cos_heading, sin_heading, scene_along, other_r = shared.scene_inputs
    motion, excess, exp_arg, occupancy, scene_occupancy, gaps = shared.kernels.plan_evaluation(
        plan.increments, plan.plan_shape[1], float(v0), shared.s0, float(plan.dt_s),
        plan.continuations, plan.n_first, curve_speed is not None,
        _NO_CURVE if curve_speed is None else curve_speed.v_max_mps, CURVE_PROFILE_STEP_M,
        route.vertex_s_m, route.segment_pose_table, plan.ego_along, plan.ego_circle_r, scene_xy,
        cos_heading, sin_heading, scene_along, other_r, shared.radius_m, shared.present,
        shared.is_pedestrian, shared.clipped, plan.ego_radius, crosswalk_rows, zone_rows,
        zone_sizes, OCCUPANCY_SOFTNESS_M)
    if shared.clipped:
        np.exp(exp_arg, out=exp_arg)
    if len(occupancy):
        np.tanh(occupancy, out=occupancy)
        np.tanh(scene_occupancy, out=scene_occupancy)
    return shared.cost_kernels, motion, excess, gaps, (
        shared.weights, exp_arg, shared.present, occupancy, scene_occupancy,
        shared.is_pedestrian, zone_sums, plan.cost_scale)


_NO_CURVE = np.zeros(1)
_NO_ZONES = (np.zeros((0, 1, 5)), np.zeros(0, dtype=np.int64))
for _constant in (_NO_CURVE, *_NO_ZONES):
    _constant.setflags(write=False)
_KERNELS: list = []  # [gap_kernels, cost_kernels] once loaded
_LAST_WEIGHTS: list = [None, None]  # [a read-only theta, its _weights]


def _weights(theta: np.ndarray) -> np.ndarray:
    """theta[1:6] as float64, remembered for the last read-only theta (a model's own)."""
    if _LAST_WEIGHTS[0] is theta:
        return _LAST_WEIGHTS[1]
    weights = theta[1:6].astype(np.float64)
    if isinstance(theta, np.ndarray) and not theta.flags.writeable and theta.base is None:
        weights.setflags(write=False)
        _LAST_WEIGHTS[:] = [theta, weights]
    return weights


def _kernels() -> tuple:
    """(gap_kernels, cost_kernels), imported at the first call (importing numba takes a while)."""
    _KERNELS[:] = kernel_loading.load()
    return tuple(_KERNELS)


@dataclass(frozen=True)
class _PreparedPlan:
    """What the kernels take of a CandidateSet and a vehicle, computed once per pair.

    Attributes:
        increments: (A C, T) the plans' speed increments (_PlanConstants.increments) [m/s].
        continuations: (C,) continuation accelerations [m/s^2].
        n_first: planner steps of the first action.
        dt_s: the planner step [s] (cands.plan_dt_s).
        cost_scale: dt_s / DT_S.
        plan_shape: (A, C, T).
        ego_along: (K,) the vehicle's covering circles' offsets [m]; ego_circle_r: their
            radius [m]; ego_radius: half its diagonal [m].
    """

    increments: np.ndarray
    continuations: np.ndarray
    n_first: int
    dt_s: float
    cost_scale: float
    plan_shape: tuple
    ego_along: np.ndarray
    ego_circle_r: float
    ego_radius: float


# id(cands) -> (cands, vehicle, _PreparedPlan) of the last pairs (the sets and vehicles are
# frozen: the same objects give the same plan); emptied when it reaches this many entries
_MAX_PREPARED = 64
_PREPARED: dict[int, tuple] = {}


def _prepared_plan(cands: CandidateSet, vehicle: VehicleParams) -> _PreparedPlan:
    """The _PreparedPlan of (cands, vehicle), remembered for the same two objects."""
    hit = _PREPARED.get(id(cands))
    if hit is not None and hit[0] is cands and hit[1] is vehicle:
        return hit[2]
    plan = _plan_constants(cands)
    n_t = plan.increments.shape[-1]
    along, ego_circle_r = _vehicle_circles(vehicle.length_m, vehicle.width_m)
    prepared = _PreparedPlan(
        plan.increments.reshape(-1, n_t), plan.continuations, cands.n_first,
        cands.plan_dt_s, cands.plan_dt_s / DT_S, plan.increments.shape, along,
        ego_circle_r, 0.5 * math.hypot(vehicle.length_m, vehicle.width_m))
    if len(_PREPARED) >= _MAX_PREPARED:
        _PREPARED.clear()
    _PREPARED[id(cands)] = (cands, vehicle, prepared)
    return prepared


# read-only (0, L, T) zeros by (L, T): the zone sums without zones
_NO_ZONE_SUMS: dict[tuple, np.ndarray] = {}


def _no_zone_sums(n_hyp: int, n_t: int) -> np.ndarray:
    """Read-only zeros (0, n_hyp, n_t)."""
    out = _NO_ZONE_SUMS.get((n_hyp, n_t))
    if out is None:
        out = np.zeros((0, n_hyp, n_t))
        out.setflags(write=False)
        if len(_NO_ZONE_SUMS) >= _MAX_PREPARED:
            _NO_ZONE_SUMS.clear()
        _NO_ZONE_SUMS[(n_hyp, n_t)] = out
    return out


def _conflict_rows(scene: ScenePrediction, crosswalks: tuple, yield_zones: tuple,
                   yield_margin_s: float, dt: float) -> tuple:
    """What the kernels need of the conflict feature's crosswalks and zones.

    The crosswalks count only with a pair of the ego (a vehicle) and a present pedestrian:
    without one each adds occupancy x 0.0, +0.0 (sim/costs._feature_terms).

    Returns:
        (W, 6) the crosswalks' centre x, y [m], cos and sin of the walk heading, half length
        and half width [m]; (Z, V, 5) the zones' edges (sim/costs._polygon_edges) and (Z,)
        their numbers; (Z, L, T) per zone the present objects' claims on it (zone_claims)
        summed over them as sim/costs sums them (object_sum of np.where over the objects' axis).
    """
    if crosswalks and not np.count_nonzero(scene.mask & scene.is_pedestrian):  # ego: a car
        crosswalks = ()
    crosswalk_rows = crosswalk_rows_of(crosswalks)
    if not yield_zones:
        return (crosswalk_rows,) + _NO_ZONES + (_no_zone_sums(*scene.heading.shape[::2]),)
    edges = [_polygon_edges(polygon) for polygon, _ in yield_zones]
    zone_rows = np.zeros((len(edges), max(len(e) for e in edges), 5))
    for row, zone_edges in zip(zone_rows, edges):
        row[:len(zone_edges)] = zone_edges
    mask = scene.mask[:, None, None, None, :]
    sums = [object_sum(np.where(mask, _zone_claims(scene, row[:len(zone_edges)], priority,
                                                   yield_margin_s, dt)
                                .swapaxes(1, 2)[:, None, None], 0.0))  # (L, 1, 1, T)
            for row, zone_edges, (_, priority) in zip(zone_rows, edges, yield_zones)]
    return (crosswalk_rows, zone_rows, np.array([len(e) for e in edges], dtype=np.int64),
            np.stack(sums).reshape(len(sums), len(scene.mask), -1))


def _zone_claims(scene: ScenePrediction, zone_edges: np.ndarray, priority: np.ndarray,
                 margin_s: float, dt_s: float) -> np.ndarray:
    """candidates.zone_claims, bit for bit, with its geometry in models/zone_kernels.py.

    Args:
        scene: the predicted objects (L hypotheses, M objects, T steps).
        zone_edges: (V, 5) the zone's edges, sim/costs._polygon_edges of its outline.
        priority: (L, M) bool, the objects with the right of way in the zone.
        margin_s: the time margin [s], >= 0.
        dt_s: the planner step [s].

    Returns:
        (L, M, T) the claims, 0..1.
    """
    claim = np.zeros(scene.heading.shape)  # 0 for the others: only claimants are computed
    rows, cols = np.nonzero(np.asarray(priority, dtype=bool) & scene.mask)
    if not len(rows):
        return claim
    heading = scene.heading[rows, cols]  # (P, T)
    # footprint.circle_layout of the claimants, remembered for their sizes (circle_gaps)
    along, radius = _scene_layout(scene.length_m[rows, cols], scene.width_m[rows, cols],
                                  scene.is_pedestrian[rows, cols])
    arguments = kernel_loading.load_all()[3].zone_claim_arguments(  # models/zone_kernels.py
        (np.ascontiguousarray(scene.xy[rows, cols]), np.cos(heading), np.sin(heading)),
        (along, radius), dt_s, round(margin_s / dt_s) + 1, zone_edges, OCCUPANCY_SOFTNESS_M)
    claim[rows, cols] = (0.5 * (1.0 + np.tanh(arguments))).max(axis=0)
    return claim

"""The candidates' costs and vehicle gaps in a few compiled loops (issue 17).

`vehicle_gap_evaluation` is `candidates.evaluate_candidates(..., geometry=True,
vehicle_gaps_only=True)` -- what a driver's Q* needs (models/driver.py) and what the robot's
model of a human evaluates (perception/belief) -- bit for bit (tests/models/test_gap_evaluation.py).
A decision's plans are a few hundred values, so in numpy the time goes to the number of calls,
not to the arithmetic; here the rollouts (with the curve speed), the route's poses, the
covering circles, their gaps to the scene's objects and the step costs are numba loops
(models/gap_kernels.py, imported at the first call) that do the reference's arithmetic in its
order. What stays in numpy:

* np.exp of the safety feature (numpy's SIMD exp and libm's differ in the last bit): the
  kernels hand it the clipped, negated gaps in one array and sum its result;
* the conflict feature (np.tanh of the crosswalk and zone occupancies, `_conflict`), summed
  in sim/costs' order; without crosswalks or zones, or without a pair of a vehicle and a
  pedestrian on a crosswalk, it is all +0.0 and not added (every feature is >= +0, and
  x + 0.0 == x for x >= +0), as the tracking feature of a plan along its route (lateral 0).
"""

import math

import numpy as np

from marl_social.models.candidates import (
    CandidateEvaluation,
    CandidateSet,
    ScenePrediction,
    _plan_constants,
    _vehicle_circles,
    evaluate_candidates,
    zone_claims,
)
from marl_social.models.circle_gaps import scene_circles, scene_crosswalk_occupancy
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import _crosswalk_conflict, crosswalk_occupancy, zone_occupancy
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CURVE_PROFILE_STEP_M, CurveSpeed


def vehicle_gap_evaluation(cands: CandidateSet, theta: np.ndarray, v_ref_mps: float,
                           vehicle: VehicleParams, route: Route, s0: float, v0: float,
                           prev_accel: float, scene: ScenePrediction,
                           crosswalks: tuple[Crosswalk, ...], yield_zones: tuple = (),
                           yield_margin_s: float = 0.0,
                           curve_speed: CurveSpeed | None = None) -> CandidateEvaluation:
    """evaluate_candidates(..., geometry=True, vehicle_gaps_only=True), the same bits.

    The arguments are those of models/candidates.evaluate_candidates (theta (N_FEATURES,),
    scene L hypotheses of M objects at cands.plan_times_s); so is the result: step_cost
    (L, A, C, T), v, a_eff and travel_m (A, C, T), min_vehicle_gap_m and vehicle_clearance_m
    (L, A, C) [m], curve_excess_mps (A, C) [m/s] with curve_speed; the other fields None.

    The rollouts, the gaps and the step costs are compiled loops (models/gap_kernels.py);
    np.exp of the safety feature and the conflict feature stay in numpy. An initial state the
    kernels do not take (a non-finite or -0.0 speed, a huge speed or arc length) takes
    evaluate_candidates itself.
    """
    if not (abs(v0) < _LARGEST_SPEED_MPS and abs(s0) < _LARGEST_ARC_LENGTH_M) or (
            v0 == 0.0 and math.copysign(1.0, v0) < 0.0):
        return evaluate_candidates(cands, theta, v_ref_mps, vehicle, route, s0, v0, prev_accel,
                                   scene, crosswalks, geometry=True, yield_zones=yield_zones,
                                   yield_margin_s=yield_margin_s, curve_speed=curve_speed,
                                   vehicle_gaps_only=True)
    kernels = _kernels()
    dt = cands.plan_dt_s
    plan = _plan_constants(cands)
    n_first_actions, n_cont, n_t = plan.increments.shape
    along, ego_circle_r = _vehicle_circles(vehicle.length_m, vehicle.width_m)
    v_max = _NO_CURVE if curve_speed is None else curve_speed.v_max_mps
    v, ds, a_eff, excess, xy, ego_x, ego_y = kernels.plan_poses(
        plan.increments.reshape(-1, n_t), n_cont, float(v0), float(s0), float(dt),
        plan.continuations, cands.n_first, curve_speed is not None, v_max, CURVE_PROFILE_STEP_M,
        route._cum_s, route._pose_table, along)
    ox, oy, other_r = scene_circles(scene)  # (J, L, M, T) x 2, (L, M)
    n_hyp = len(scene.mask)
    weights = theta[1:6].astype(np.float64)  # speed, accel, jerk, safety, conflict
    w_safety, w_conflict = weights[3], weights[4]
    present = np.ascontiguousarray(scene.mask)
    exp_arg, clearance, vehicle_gap = kernels.circle_gaps(
        ego_x, ego_y, ego_circle_r, np.ascontiguousarray(ox), np.ascontiguousarray(oy),
        np.ascontiguousarray(other_r),
        present & ~scene.is_pedestrian, w_safety != 0.0)
    if w_safety != 0.0:
        np.exp(exp_arg, out=exp_arg)
    plan_shape = (n_first_actions, n_cont, n_t)
    conflict = _NO_CONFLICT
    if w_conflict != 0.0:
        shape = (n_hyp,) + plan_shape
        conflict, zeros = _conflict(xy.reshape(plan_shape + (2,)), 0.5 * math.hypot(
            vehicle.length_m, vehicle.width_m), ego_x.reshape((-1,) + plan_shape),
            ego_y.reshape((-1,) + plan_shape), ego_circle_r, scene, crosswalks, yield_zones,
            yield_margin_s, dt)
        # adding +0.0 changes nothing (every term is >= +0)
        conflict = _NO_CONFLICT if zeros else np.ascontiguousarray(
            np.broadcast_to(conflict, shape)).reshape(n_hyp, -1, n_t)
    cost = kernels.step_costs(v, a_eff, float(v_ref_mps), float(prev_accel), weights, exp_arg,
                              present, conflict, dt / DT_S)
    hyp_shape = (n_hyp, n_first_actions, n_cont)
    return CandidateEvaluation(
        cost.reshape((n_hyp,) + plan_shape), v.reshape(plan_shape), a_eff.reshape(plan_shape),
        None, None, None, vehicle_gap.reshape(hyp_shape), None, ds.reshape(plan_shape),
        clearance.reshape(hyp_shape),
        None if curve_speed is None else excess.reshape(plan_shape[:2]))


_LARGEST_SPEED_MPS = 1e6  # the kernels' v0 and s0 bounds (the curve-speed grid index of any
_LARGEST_ARC_LENGTH_M = 1e12  # arc length along the plans then fits an int64 by far)
_NO_CURVE = np.zeros(1)
_NO_CONFLICT = np.zeros((0, 0, 0))
_KERNELS = []  # [models.gap_kernels] once imported


def _kernels():
    """models.gap_kernels, imported at the first call (importing numba takes a while)."""
    if not _KERNELS:
        from marl_social.models import gap_kernels
        _KERNELS.append(gap_kernels)
    return _KERNELS[0]


def _conflict(xy, ego_radius, ego_x, ego_y, ego_circle_r, scene, crosswalks, yield_zones,
              yield_margin_s, dt) -> tuple:
    """sim/costs' conflict feature of the candidates, and whether it is all zeros.

    Returns:
        (conflict (L, A, C, T), False); (zeros (L, A, C, T), True) for crosswalks without a
        pair of a vehicle and a pedestrian (they may broadcast the total to that shape);
        (0.0, True) without crosswalks and zones.
    """
    conflict, zeros = 0.0, True
    if crosswalks:
        pair_mask = (scene.mask & scene.is_pedestrian)[:, None, None, None, :]  # the ego: a car
        if not pair_mask.any():
            conflict = np.zeros((len(scene.mask),) + xy.shape[:-1])
        else:
            zeros = False
            for cw, occ_other in zip(crosswalks, scene_crosswalk_occupancy(scene, crosswalks)):
                conflict = conflict + _crosswalk_conflict(
                    crosswalk_occupancy(xy, ego_radius, cw), occ_other, pair_mask)
    if yield_zones:
        ego_circles = np.moveaxis(np.stack((ego_x, ego_y), axis=-1), 0, -2)  # (A, C, T, K, 2)
        ego_r = np.broadcast_to(ego_circle_r, ego_circles.shape[:-1])
        zeros = False
        for polygon, priority in yield_zones:
            claim = zone_claims(scene, polygon, priority, yield_margin_s, dt)  # (L, M, T)
            claim = claim.swapaxes(1, 2)[:, None, None]  # (L, 1, 1, T, M)
            occ_ego = zone_occupancy(ego_circles, ego_r, polygon)
            conflict = conflict + occ_ego * np.sum(
                np.where(scene.mask[:, None, None, None, :], claim, 0.0), axis=-1)
    return conflict, zeros

"""The candidates' costs and vehicle gaps in fewer array operations (issue 17).

`vehicle_gap_evaluation` is `candidates.evaluate_candidates(..., geometry=True,
vehicle_gaps_only=True)` -- what a driver's Q* needs (models/driver.py) and what the robot's
model of a human evaluates (perception/belief) -- bit for bit (tests/models/test_gap_evaluation.py),
in about half the numpy calls: a decision's plans are a few hundred values, so the time goes
to the number of calls, not to the arithmetic. It differs from evaluate_candidates only in
how the same values are produced:

* the route gives the cosine and sine of its heading from a per-segment table
  (`Route.pose_at`); on a straight route the circles' offsets along it are computed once;
* the speeds' running minimum (the v >= 0 limit) is the initial speed plus that of the plans'
  increments, computed once per candidate set (`_rollout_from_rest_or_moving`);
* the arc lengths s0 + ds and the curve speeds along them are computed once where the speed
  ceiling changes nothing (on a straight stretch of a bent route);
* the per-step cost theta . phi is summed in the same order (sim/costs.step_cost) without the
  terms that add exact zeros (every feature is >= +0, and x + 0.0 == x for x >= +0): the
  tracking feature of a plan along its route and the conflict feature without crosswalks or
  zones; the safety term skips the np.where of a scene whose objects are all present;
* the vehicle clearance skips the np.where when every object it looks at is a present vehicle.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.models.candidates import (
    CandidateEvaluation,
    CandidateSet,
    ScenePrediction,
    _governed,
    _plan_constants,
    _rollout,
    _vehicle_circles,
    zone_claims,
)
from marl_social.models.circle_gaps import (
    circle_pair_gap,
    scene_circles,
    scene_crosswalk_occupancy,
)
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import _crosswalk_conflict, crosswalk_occupancy, zone_occupancy
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import Crosswalk, Route
from marl_social.sim.route_rules import CurveSpeed


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
    """
    dt = cands.plan_dt_s
    plan = _plan_constants(cands)
    v, ds, a_eff = _rollout_from_rest_or_moving(v0, plan.increments, dt)
    s = s0 + ds
    curve_excess = None
    if curve_speed is not None:
        cap = curve_speed.at(s)  # (A, C, T) [m/s]
        ceiling = float(cap.min())
        if math.isfinite(ceiling) or not v0 > 0.0:
            v, ds, a_eff = _governed(v, ds, v0, plan.continuations, cands.n_first, dt, ceiling)
            s = s0 + ds
            cap = curve_speed.at(s)
        # else: _governed changes nothing (its a_eff is _rollout's for v0 > 0), nor the caps
        curve_excess = (v - cap).max(axis=-1)  # (A, C)
    xy, direction = route.pose_at(s)  # (A, C, T, 2) [m], cos and sin of the heading
    along, ego_circle_r = _vehicle_circles(vehicle.length_m, vehicle.width_m)
    # the ego's covering circles (K, A, C, T): x + along cos(h), y + along sin(h)
    if direction.ndim == 1:  # one heading: along cos(h) per circle, then x and y apart
        offset = along[:, None] * direction  # (K, 2)
        ego_x = xy[..., 0] + offset[:, 0, None, None, None]
        ego_y = xy[..., 1] + offset[:, 1, None, None, None]
    else:  # x and y at once (a trailing axis of 2 that is not broadcast is the fast one)
        centres = xy + along[:, None, None, None, None] * direction  # (K, A, C, T, 2)
        ego_x, ego_y = centres[..., 0], centres[..., 1]
    ox, oy, other_r = scene_circles(scene)  # (J, L, M, T) x 2, (L, M)
    raw_gap = circle_pair_gap(ego_x, ego_y, ego_circle_r, ox, oy, other_r)  # (L, A, C, T, M)
    n_hyp, n_obj = scene.mask.shape
    all_present = bool(scene.mask.all())
    cost = _step_cost(theta, v, v_ref_mps, a_eff, prev_accel, raw_gap, all_present, xy,
                      0.5 * math.hypot(vehicle.length_m, vehicle.width_m), ego_x, ego_y,
                      ego_circle_r, scene, crosswalks, yield_zones, yield_margin_s, dt)
    cost = cost * (dt / DT_S)
    if cost.shape != (n_hyp,) + v.shape:
        cost = np.broadcast_to(cost, (n_hyp,) + v.shape)
    # only the objects that are a present vehicle in some hypothesis can be finite
    vehicles = scene.mask & ~scene.is_pedestrian  # (L, M)
    cars = np.flatnonzero(vehicles.any(axis=0))
    if len(cars):
        if len(cars) < n_obj:
            raw_gap, vehicles = raw_gap[..., cars], vehicles[:, cars]
        if not vehicles.all():
            raw_gap = np.where(vehicles[:, None, None, None, :], raw_gap, np.inf)
        clearance = np.broadcast_to(raw_gap.min(axis=(-1, -2)), (n_hyp,) + v.shape[:2])
    else:
        clearance = np.full((n_hyp,) + v.shape[:2], np.inf)
    return CandidateEvaluation(cost, v, a_eff, None, None, None, np.maximum(clearance, 0.0),
                               None, ds, clearance, curve_excess)


def _rollout_from_rest_or_moving(v0: float, increments: np.ndarray, dt_s: float
                                 ) -> tuple[np.ndarray, ...]:
    """candidates._rollout(v0, increments, dt_s), the same bits, in fewer numpy calls.

    The running minimum of v0 + [0, increments] is v0 + the running minimum of [0, increments]
    (rounding is monotone), computed once per plan; v0 = 0 (either zero) takes _rollout.

    Args:
        v0: initial speed [m/s].
        increments: (..., T) cumsum(accel * dt_s) of the plans [m/s] (read-only, cached).
        dt_s: step [s].
    """
    if v0 == 0.0 or not math.isfinite(v0):
        return _rollout(v0, increments, dt_s)
    from_zero, running_min = _running_minimum(increments)
    s_full = v0 + from_zero  # (..., T + 1): v0, then v0 + increments
    v_full = s_full - np.minimum(0.0, v0 + running_min)
    v = v_full[..., 1:]
    ds = np.cumsum(0.5 * (v + v_full[..., :-1]) * dt_s, axis=-1)
    return v, ds, (v - v_full[..., :-1]) / dt_s


_RUNNING_MINIMA: dict[int, tuple] = {}  # id(increments) -> (increments, [0, inc], running min)


def _running_minimum(increments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[0, increments] (..., T + 1) and its running minimum along the last axis, once per array.

    Kept for read-only (cached plan) arrays only, by identity (the array is held, so its id
    stays its own).
    """
    hit = _RUNNING_MINIMA.get(id(increments))
    if hit is not None and hit[0] is increments:
        return hit[1], hit[2]
    from_zero = np.zeros(increments.shape[:-1] + (increments.shape[-1] + 1,))
    from_zero[..., 1:] = increments
    running_min = np.minimum.accumulate(from_zero, axis=-1)
    if not increments.flags.writeable:
        if len(_RUNNING_MINIMA) >= 64:
            _RUNNING_MINIMA.clear()
        for array in (from_zero, running_min):
            array.setflags(write=False)
        _RUNNING_MINIMA[id(increments)] = (increments, from_zero, running_min)
    return from_zero, running_min


def _step_cost(theta, v, v_ref_mps, a_eff, prev_accel, raw_gap, all_present, xy, ego_radius,
               ego_x, ego_y, ego_circle_r, scene, crosswalks, yield_zones, yield_margin_s, dt
               ) -> np.ndarray:
    """sim/costs.step_cost of the candidates (L or 1, A, C, T), summed in its order.

    The feature terms of sim/costs._feature_terms with the arguments evaluate_candidates
    passes (lateral offset 0, the ego a vehicle), each weighted and added in FEATURE_NAMES
    order; terms that are exact zeros are not added (see the module docstring).
    """
    w_speed, w_accel, w_jerk, w_safety, w_conflict = (float(w) for w in theta[1:])
    total = None

    def add(total, term):
        return term if total is None else total + term

    if w_speed != 0.0:
        term = v - v_ref_mps
        term *= term
        term *= w_speed
        total = add(total, term)
    if w_accel != 0.0:
        term = a_eff * a_eff
        term *= w_accel
        total = add(total, term)
    if w_jerk != 0.0:
        term = np.empty_like(a_eff)  # a_k - a_{k-1}, a_{-1} = prev_accel
        np.subtract(a_eff[..., 0], prev_accel, out=term[..., 0])
        np.subtract(a_eff[..., 1:], a_eff[..., :-1], out=term[..., 1:])
        term *= term
        term *= w_jerk
        total = add(total, term)
    if w_safety != 0.0:
        gap = np.maximum(raw_gap, 0.0)
        np.negative(gap, out=gap)
        np.exp(gap, out=gap)
        if not all_present:
            gap = np.where(scene.mask[:, None, None, None, :], gap, 0.0)
        term = np.sum(gap, axis=-1)
        term *= w_safety
        total = add(total, term)
    if w_conflict != 0.0:
        conflict, zeros = _conflict(xy, ego_radius, ego_x, ego_y, ego_circle_r, scene,
                                    crosswalks, yield_zones, yield_margin_s, dt)
        # adding +0.0 (or zeros that do not broadcast the total) changes nothing
        if not zeros or (total is None and not isinstance(conflict, float)) or (
                total is not None and np.shape(conflict) != total.shape):
            total = add(total, w_conflict * conflict)
    return np.float64(0.0) if total is None else total


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

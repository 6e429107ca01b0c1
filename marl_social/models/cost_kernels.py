"""Compiled (numba) step costs of the candidates and of the pedestrian's walks.

`step_costs` (models/gap_evaluation.vehicle_gap_evaluation), `rule_abiding_totals`
(models/driver.rule_abiding_totals of its result) and `walk_costs`
(models/pedestrian.pedestrian_q_values, summed over the horizon in np.sum's pairwise order,
sim/pairwise_sum.py) cost what models/gap_kernels.py laid out, with the same arithmetic as the
numpy reference in its order, bit for bit (tests/models/test_gap_evaluation.py,
test_walk_kernels.py, test_pedestrian_costs.py); np.exp and np.tanh stay in numpy, between
the two kernels (see gap_kernels.py). Imported at the first decision; `cache=True` as there (and,
as there, a compiled function calls only compiled functions of its own module: numba's cache
notices changes of that file only).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types

from marl_social.models.gap_kernels import _B1, _F8, _I8, _array
from marl_social.sim.pairwise_sum import contiguous_sum

# pairwise_sum.py stamp: e57bd2f618419a3d (tests/sim/test_pairwise_sum.py)

# gap_kernels' options, written out: a change of them here must change this file for the cache
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}
# step_costs' scene: weights (5,), safety_exp (L, P, T, M), present (L, M), occupancy_tanh
# (R, P, T), scene_tanh (W, L, T, M), is_pedestrian (L, M), zone_sums (Z, L, T), scale
_COSTING = types.Tuple((_array(1), _array(4), _array(2, _B1), _array(3), _array(4),
                        _array(2, _B1), _array(3), _F8))
# plan_totals' rules: s0 [m], half the length [m], the stop line [m], whether it applies, the
# curve excess (A, C) [m/s], whether it applies
_RULES = types.Tuple((_F8, _F8, _F8, _B1, _array(2), _B1))
# walk_costs' walk: v_ref [m/s], the speed before [m/s], the step [s], plan_dt / DT_S
_WALK = types.UniTuple(_F8, 4)
# walk_costs' conflict: occupancy_tanh (W, A, T), scene_tanh (W, L, T, M), pair (L, M)
_WALK_CONFLICT = types.Tuple((_array(3), _array(4), _array(2, _B1)))
@numba.njit(cache=True)
def _conflict(occupancy_tanh, scene_sums, plan, h, t):
    """The conflict feature of plan `plan` in hypothesis h at step t (before its weight).

    Per conflict row r the ego's occupancy 0.5 (1 + tanh) times the objects' summed claims
    scene_sums[r, h, t], added up row by row from 0.0 (the reference's order).
    """
    conflict = 0.0
    for r in range(len(occupancy_tanh)):
        occupancy = 0.5 * (1.0 + occupancy_tanh[r, plan, t])
        conflict = conflict + occupancy * scene_sums[r, h, t]
    return conflict


@numba.njit(cache=True)
def _present_sum(values, present, n_obj, scratch):
    """sim/costs.object_sum of values[m] over the present objects m < n_obj (absent: 0.0).

    np.sum's order along a contiguous axis: below 8 values one by one from -0.0, plus 0.0;
    from 8 on numpy's pairwise sum (sim/pairwise_sum.contiguous_sum) of the values copied
    into scratch (n_obj,), the absent ones 0.0 in their places.
    """
    if n_obj < 8:
        summed = -0.0
        for m in range(n_obj):
            summed += values[m] if present[m] else 0.0
        return 0.0 + summed
    for m in range(n_obj):
        scratch[m] = values[m] if present[m] else 0.0
    return contiguous_sum(scratch, 0, n_obj)


@numba.njit((_array(4), _array(2, _B1), _array(3)), cache=True)
def _scene_sums(scene_tanh, pair, zone_sums):
    """(W + Z, L, T) the objects' summed crosswalk occupancies, then the zones' given sums.

    Per crosswalk the sum over the paired objects of their occupancy 0.5 (1 + tanh), as
    sim/costs._crosswalk_conflict sums them (object_sum of np.where: `_present_sum`).

    Args:
        scene_tanh: (W, L, T, M) tanh of gap_kernels.scene_occupancy_arguments.
        pair: (L, M) the objects of the other kind (pedestrian / vehicle), present.
        zone_sums: (Z, L, T) the present objects' summed claims on each zone.
    """
    n_cw, n_hyp, n_t, n_obj = scene_tanh.shape
    sums = np.empty((n_cw + len(zone_sums), n_hyp, n_t))
    occupancy = np.empty(n_obj)
    scratch = np.empty(n_obj)
    for i in range(n_cw):
        for h in range(n_hyp):
            for t in range(n_t):
                for m in range(n_obj):
                    occupancy[m] = 0.5 * (1.0 + scene_tanh[i, h, t, m])
                sums[i, h, t] = _present_sum(occupancy, pair[h], n_obj, scratch)
    for z in range(len(zone_sums)):  # element by element (a slice copy compiles numba's
        for h in range(n_hyp):  # shape-error message: seconds of compiling)
            for t in range(n_t):
                sums[n_cw + z, h, t] = zone_sums[z, h, t]
    return sums


@numba.njit([(_array(1), _I8, _WALK, _array(1), _array(4), _array(2, _B1), _WALK_CONFLICT)],
            **_JIT)
def walk_costs(speeds, n_t, walk, weights, safety_exp, present, conflict):
    """pedestrian_q_values: the step costs of the walks summed over the horizon, times scale.

    Per step, as models/pedestrian.py adds them: w_speed (v - v_ref)^2, w_accel a^2 and
    w_jerk a^2 (a = (v - prev_speed) / dt on the first step, 0 after it), w_safety times the
    sum over the present objects of exp(-max(gap, 0)) (`_present_sum`), w_conflict
    times 0.0 + the occupancy 0.5 (1 + tanh) times the scene's sum, crosswalk by crosswalk;
    each only if its weight is not zero; then np.sum's pairwise sum over the steps.

    Args:
        speeds: (A,) candidate speeds [m/s].
        n_t: T, the number of steps.
        walk: (v_ref [m/s], the speed before the plans [m/s], the rollout step dt [s],
            scale = plan_dt / DT_S).
        weights: (5,) the weights of speed, accel, jerk, safety and conflict.
        safety_exp: (L, A, T, M) exp(-max(gap, 0)) (unused with a zero safety weight).
        present: (L, M) the objects present in each hypothesis.
        conflict: (occupancy_tanh (W, A, T): tanh of walk_geometry's arguments of the
            crosswalks with a pair of the pedestrian and a present vehicle (W = 0: no conflict
            to add), scene_tanh (W, L, T, M): tanh of the objects' crosswalk occupancy
            arguments, pair (L, M): the vehicles present).

    Returns:
        (L, A) the costs.
    """
    v_ref_mps, prev_speed, dt_s, scale = walk
    occupancy_tanh, scene_tanh, pair = conflict
    w_speed, w_accel, w_jerk, w_safety, w_conflict = (weights[0], weights[1], weights[2],
                                                      weights[3], weights[4])
    n_hyp, n_obj = present.shape
    add_conflict = len(occupancy_tanh) > 0 and w_conflict != 0.0
    scene_sums = _scene_sums(scene_tanh, pair, np.zeros((0, n_hyp, n_t)))
    steps = np.empty(n_t)
    scratch = np.empty(n_obj)
    cost = np.empty((n_hyp, len(speeds)))
    for h in range(n_hyp):
        for a in range(len(speeds)):
            for t in range(n_t):
                total = 0.0
                started = False
                if w_speed != 0.0:
                    term = speeds[a] - v_ref_mps
                    total = term * term * w_speed
                    started = True
                if w_accel != 0.0 or w_jerk != 0.0:
                    accel = (speeds[a] - prev_speed) / dt_s if t == 0 else 0.0
                    squared = accel * accel
                    if w_accel != 0.0:
                        total = total + w_accel * squared if started else w_accel * squared
                        started = True
                    if w_jerk != 0.0:
                        total = total + w_jerk * squared if started else w_jerk * squared
                        started = True
                if w_safety != 0.0:
                    term = _present_sum(safety_exp[h, a, t], present[h], n_obj,
                                        scratch) * w_safety
                    total = total + term if started else term
                    started = True
                if add_conflict:
                    term = w_conflict * _conflict(occupancy_tanh, scene_sums, a, h, t)
                    total = total + term if started else term
                steps[t] = total
            cost[h, a] = contiguous_sum(steps, 0, n_t) * scale
    return cost


@numba.njit([(_array(4), _F8, _F8, _COSTING)], **_JIT)
def step_costs(motion, v_ref_mps, prev_accel, costing):
    """sim/costs.step_cost of the candidates, times scale, as vehicle_gap_evaluation sums it.

    The terms w_speed (v - v_ref)^2, w_accel a^2, w_jerk (a_k - a_{k-1})^2, w_safety times the
    sum over the present objects of exp(-max(gap, 0)) (np.sum's order) and w_conflict times
    the conflict, each only if its weight is not zero, added in that order (the first three,
    the same in every hypothesis, once); the total of no term is 0.0. The conflict is
    0.0 + the ego's occupancy 0.5 (1 + tanh) times the scene's sum, crosswalk by crosswalk,
    then zone by zone (sim/costs._feature_terms).

    Args:
        motion: (3, A, C, T) the P = A x C plans' speeds [m/s], travel [m] and effective
            accelerations [m/s^2] (gap_kernels.plan_evaluation's).
        v_ref_mps: the reference speed [m/s].
        prev_accel: the acceleration before the plans [m/s^2].
        costing: (weights, safety_exp, present, occupancy_tanh, scene_tanh, is_pedestrian,
            zone_sums, scale), the scene's arrays and the scale:
            weights: (5,) the weights of speed, accel, jerk, safety and conflict.
            safety_exp: (L, P, T, M) exp(-max(gap, 0)) (unused with a zero safety
                weight).
            present: (L, M) the objects present in each hypothesis.
            occupancy_tanh: (R, P, T) tanh of `occupancy_arguments` of the crosswalks with a pair
                of a vehicle and a pedestrian and of the zones (R = 0: no conflict to add).
            scene_tanh: (W, L, T, M) tanh of the objects' crosswalk occupancy arguments
                (gap_kernels.scene_occupancy_arguments).
            is_pedestrian: (L, M) the pedestrians (those present pair with the ego).
            zone_sums: (Z, L, T) per zone the present objects' summed claims on it.
            scale: plan_dt / DT_S.

    Returns:
        (L, A, C, T) the step costs.
    """
    (weights, safety_exp, present, occupancy_tanh, scene_tanh, is_pedestrian, zone_sums,
     scale) = costing
    n_first_actions, n_cont, n_t = motion.shape[1], motion.shape[2], motion.shape[3]
    v = motion[0].reshape((n_first_actions * n_cont, n_t))
    a_eff = motion[2].reshape((n_first_actions * n_cont, n_t))
    pair = np.empty(present.shape, dtype=np.bool_)
    for h in range(present.shape[0]):
        for m in range(present.shape[1]):
            pair[h, m] = present[h, m] and is_pedestrian[h, m]
    w_speed, w_accel, w_jerk, w_safety, w_conflict = (weights[0], weights[1], weights[2],
                                                      weights[3], weights[4])
    n_hyp, n_obj = present.shape
    n_plans, n_t = v.shape
    own = np.zeros((n_plans, n_t))  # the scene-independent terms' total
    started = False
    if w_speed != 0.0:
        for p in range(n_plans):
            for t in range(n_t):
                term = v[p, t] - v_ref_mps
                own[p, t] = term * term * w_speed
        started = True
    if w_accel != 0.0:
        for p in range(n_plans):
            for t in range(n_t):
                term = a_eff[p, t] * a_eff[p, t] * w_accel
                own[p, t] = own[p, t] + term if started else term
        started = True
    if w_jerk != 0.0:
        for p in range(n_plans):
            for t in range(n_t):
                term = a_eff[p, t] - (a_eff[p, t - 1] if t else prev_accel)
                term = term * term * w_jerk
                own[p, t] = own[p, t] + term if started else term
        started = True
    add_conflict = len(occupancy_tanh) > 0 and w_conflict != 0.0
    scene_sums = _scene_sums(scene_tanh, pair, zone_sums)
    # term by term over the whole (L, P, T) array, each loop's innermost axis the steps: every
    # element sees the per-step order of the reference (own, then + safety, then + conflict,
    # then x scale), the branches decided once, not per element
    cost = np.empty((n_hyp, n_plans, n_t))
    for h in range(n_hyp):  # element by element (a slice copy compiles a shape-error message)
        for p in range(n_plans):
            for t in range(n_t):
                cost[h, p, t] = own[p, t]
    if w_safety != 0.0:  # sim/costs.object_sum over the present objects (values >= +0)
        summed = np.empty((n_plans, n_t))
        scratch = np.empty(n_obj)
        for h in range(n_hyp):
            if n_obj < 8:  # one by one, the objects outermost (the loops vectorize)
                summed[:] = -0.0
                for m in range(n_obj):  # an absent object adds +0.0: nothing once 0.0 + is
                    if present[h, m]:  # taken
                        for p in range(n_plans):
                            for t in range(n_t):
                                summed[p, t] += safety_exp[h, p, t, m]
                for p in range(n_plans):
                    for t in range(n_t):
                        summed[p, t] = 0.0 + summed[p, t]
            else:  # pairwise, step by step
                for p in range(n_plans):
                    for t in range(n_t):
                        summed[p, t] = _present_sum(safety_exp[h, p, t], present[h], n_obj,
                                                    scratch)
            for p in range(n_plans):
                for t in range(n_t):
                    term = summed[p, t] * w_safety
                    cost[h, p, t] = cost[h, p, t] + term if started else term
    if add_conflict:
        n_rows = len(occupancy_tanh)
        half = np.empty((n_rows, n_plans, n_t))  # the ego's occupancy 0.5 (1 + tanh)
        for r in range(n_rows):
            for p in range(n_plans):
                for t in range(n_t):
                    half[r, p, t] = 0.5 * (1.0 + occupancy_tanh[r, p, t])
        added = started or w_safety != 0.0
        conflict = np.empty(n_t)
        for h in range(n_hyp):
            for p in range(n_plans):
                conflict[:] = 0.0
                for r in range(n_rows):  # row by row from 0.0 (`_conflict`'s order)
                    for t in range(n_t):
                        conflict[t] = conflict[t] + half[r, p, t] * scene_sums[r, h, t]
                for t in range(n_t):
                    term = w_conflict * conflict[t]
                    cost[h, p, t] = cost[h, p, t] + term if added else term
    for h in range(n_hyp):
        for p in range(n_plans):
            for t in range(n_t):
                cost[h, p, t] = cost[h, p, t] * scale
    return cost.reshape((n_hyp, n_first_actions, n_cont, n_t))


# _nan_min / _nan_max: gap_kernels' twins, kept in this file on purpose: numba's cache of
# rule_abiding_totals is invalidated by edits of this file only, not of a file it calls into
@numba.njit(cache=True)
def _nan_min(a, b):
    """np.minimum(a, b) of two floats: the smaller, NaN if either is NaN (gap_kernels')."""
    return b if (b < a or np.isnan(b)) else a


@numba.njit(cache=True)
def _nan_max(a, b):
    """np.maximum(a, b) of two floats: the larger, NaN if either is NaN (gap_kernels')."""
    return b if (b > a or np.isnan(b)) else a


@numba.njit(cache=True)
def _rule_keepers(front_m, stop_s_m, has_stop, curve_excess, has_curve):
    """(A, C) the plans that keep the rules, as models/driver.rule_abiding_totals picks them.

    With a stop line those whose overshoot max(front - stop, 0) is the least (NaN: none);
    then, with a curve speed, of those the ones whose excess max(excess, 0) is the least
    (the others' excess counting as inf). np.min's and np.maximum's NaN propagation.
    """
    n_first, n_cont = front_m.shape
    ok = np.ones((n_first, n_cont), dtype=np.bool_)
    if has_stop:
        overshoot = np.empty((n_first, n_cont))
        least = np.inf
        for a in range(n_first):
            for c in range(n_cont):
                overshoot[a, c] = _nan_max(front_m[a, c] - stop_s_m, 0.0)
                least = overshoot[a, c] if a == 0 and c == 0 else _nan_min(least, overshoot[a, c])
        for a in range(n_first):
            for c in range(n_cont):
                ok[a, c] = overshoot[a, c] <= least
    if has_curve:
        excess = np.empty((n_first, n_cont))
        least = np.inf
        for a in range(n_first):
            for c in range(n_cont):
                excess[a, c] = _nan_max(curve_excess[a, c], 0.0) if ok[a, c] else np.inf
                least = excess[a, c] if a == 0 and c == 0 else _nan_min(least, excess[a, c])
        for a in range(n_first):
            for c in range(n_cont):
                ok[a, c] = ok[a, c] and excess[a, c] <= least
    return ok


@numba.njit([(_array(4), _array(3), _array(3), _array(3), _F8, _F8, _array(1), _array(2))],
            **_JIT)
def rule_abiding_totals(step_cost, vehicle_gap, clearance, travel_m, s0, half_length_m,
                        stop_s_m, curve_excess):
    """models/driver.rule_abiding_totals of a compiled evaluation (its totals, its rules).

    The totals are np.sum over the steps of a C-contiguous step_cost (0.0 + its pairwise
    sum, sim/pairwise_sum.contiguous_sum); candidates.collision_free_totals sets those of
    plans touching a vehicle (vehicle gap <= 0) to inf, or, in a hypothesis where every plan
    does, all but those of the largest clearance (np.max, NaN propagating: then all); then
    the plans that break a rule (`_rule_keepers`) are set to inf, in each hypothesis where a
    finite total is left.

    Args:
        step_cost: (L, A, C, T) the step costs.
        vehicle_gap: (L, A, C) the smallest vehicle gap of each plan [m].
        clearance: (L, A, C) its clearance to vehicles [m].
        travel_m: (A, C, >= 1) the plans' travel [m], its last step read (unused without a
            stop line).
        s0: the driver's arc length [m].
        half_length_m: half its length [m]: its front at the end of a plan is at
            s0 + travel + half_length_m [m].
        stop_s_m: (1,) the stop line's arc length [m]; (0,): no stop line applies.
        curve_excess: (A, C) the excess over the curve speed [m/s]; (0, 0): no curve speed
            applies.

    Returns:
        (L, A, C) the totals, inf for excluded plans.
    """
    has_stop = len(stop_s_m) > 0
    has_curve = curve_excess.size > 0
    n_hyp, n_first, n_cont, n_t = step_cost.shape
    totals = np.empty((n_hyp, n_first, n_cont))
    if n_first * n_cont == 0:
        return totals
    flat_cost = step_cost.reshape(n_hyp * n_first * n_cont, n_t)
    flat_totals = totals.reshape(n_hyp * n_first * n_cont)
    for i in range(len(flat_totals)):
        flat_totals[i] = contiguous_sum(flat_cost[i], 0, n_t)
    for h in range(n_hyp):
        hopeless = True
        for a in range(n_first):
            for c in range(n_cont):
                hopeless = hopeless and vehicle_gap[h, a, c] <= 0.0
        if not hopeless:
            for a in range(n_first):
                for c in range(n_cont):
                    if vehicle_gap[h, a, c] <= 0.0:
                        totals[h, a, c] = np.inf
            continue
        largest = clearance[h, 0, 0]
        for a in range(n_first):
            for c in range(n_cont):
                largest = _nan_max(largest, clearance[h, a, c])
        for a in range(n_first):
            for c in range(n_cont):
                if not clearance[h, a, c] >= largest:
                    totals[h, a, c] = np.inf
    if not (has_stop or has_curve):
        return totals
    front_m = np.empty((n_first, n_cont))
    if has_stop:
        for a in range(n_first):
            for c in range(n_cont):
                front_m[a, c] = s0 + travel_m[a, c, travel_m.shape[2] - 1] + half_length_m
    ok = _rule_keepers(front_m, stop_s_m[0] if has_stop else 0.0, has_stop, curve_excess,
                       has_curve)
    for h in range(n_hyp):
        kept_finite = False
        for a in range(n_first):
            for c in range(n_cont):
                if ok[a, c] and np.isfinite(totals[h, a, c]):
                    kept_finite = True
        if kept_finite:
            for a in range(n_first):
                for c in range(n_cont):
                    if not ok[a, c]:
                        totals[h, a, c] = np.inf
    return totals


@numba.njit([(_array(4), _F8, _F8, _COSTING, _array(4), _RULES)], **_JIT)
def plan_totals(motion, v_ref_mps, prev_accel, costing, gaps, rules):
    """`rule_abiding_totals` of `step_costs`, in one call (a human driver's decision).

    motion to costing are step_costs' arguments; gaps (2, L, A, C) the clearance and the
    vehicle gap of each plan [m] (gap_kernels.plan_evaluation's); rules (s0 [m], half the
    driver's length [m], the stop line's arc length [m], whether a stop line applies, the
    curve excess (A, C) [m/s], whether a curve speed applies); the travel is motion[1].
    Returns the (L, A, C) totals of rule_abiding_totals (inf for the excluded plans): the
    same bits as the two calls (tests/models/test_rule_totals.py).
    """
    s0, half_length_m, stop_s_m, has_stop, curve_excess, has_curve = rules
    cost = step_costs(motion, v_ref_mps, prev_accel, costing)
    stop = np.full(1 if has_stop else 0, stop_s_m)
    excess = np.empty(curve_excess.shape if has_curve else (0, 0))
    if has_curve:  # element by element (a slice copy compiles a shape-error message)
        for a in range(excess.shape[0]):
            for c in range(excess.shape[1]):
                excess[a, c] = curve_excess[a, c]
    return rule_abiding_totals(cost, gaps[1], gaps[0], motion[1], s0, half_length_m, stop,
                               excess)


@numba.njit([(_array(1), _F8)], **_JIT)
def boltzmann_exponents(q, beta):
    """-beta (q - min q) of a row of finite Q values (models/boltzmann.boltzmann's exp argument).

    Args:
        q: (A,) Q values.
        beta: the rationality, finite.

    Returns:
        (A,) the exponents, the same values as numpy's (min q is exact; a -0.0 / +0.0 tie can
        only flip the sign of a zero exponent, and exp(-0.0) == exp(+0.0)); (0,) when a Q or
        an exponent is not finite (numpy then, with its warnings).
    """
    n = len(q)
    least = np.inf
    for i in range(n):
        if not np.isfinite(q[i]):
            return np.empty(0)
        least = min(least, q[i])
    z = np.empty(n)
    for i in range(n):
        z[i] = -beta * (q[i] - least)
        if not np.isfinite(z[i]):
            return np.empty(0)
    return z

"""Compiled (numba) loops of the pedestrian's decision (models/pedestrian.pedestrian_q_values).

The same arithmetic as the numpy reference, in its order, bit for bit
(tests/models/test_pedestrian_costs.py): the walk along the crossing route at each candidate
speed, the gaps of the pedestrian's disc to the scene's covering circles
(gap_kernels.circle_gaps), the arguments of np.tanh of its crosswalk occupancies
(gap_kernels.occupancy_arguments), then the step costs summed over the horizon in np.sum's
pairwise order. np.exp and np.tanh stay in numpy (see models/gap_kernels.py), between the
two kernels. Imported at the first decision; `cache=True` as there.
"""

from __future__ import annotations

import numba
import numpy as np

from marl_social.models.gap_kernels import (
    _B1,
    _F8,
    _I8,
    _JIT,
    _array,
    _nan_min,
    _segment,
    circle_gaps,
    occupancy_arguments,
    scene_circles,
)


@numba.njit(cache=True)
def _pairwise_block(values, start, n):
    """The pairwise_sum of numpy of values[start:start + n] for n <= 128 (no further split).

    Fewer than 8 values: added one by one to -0.0; else eight running sums, combined
    ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)), then the rest one by one.
    """
    if n < 8:
        total = -0.0
        for i in range(start, start + n):
            total += values[i]
        return total
    r0, r1, r2, r3 = values[start], values[start + 1], values[start + 2], values[start + 3]
    r4, r5, r6, r7 = values[start + 4], values[start + 5], values[start + 6], values[start + 7]
    i = 8
    while i < n - (n % 8):
        b = start + i
        r0 += values[b]
        r1 += values[b + 1]
        r2 += values[b + 2]
        r3 += values[b + 3]
        r4 += values[b + 4]
        r5 += values[b + 5]
        r6 += values[b + 6]
        r7 += values[b + 7]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        total += values[start + i]
        i += 1
    return total


@numba.njit(cache=True)
def _pairwise_sum(values, start, n):
    """The pairwise_sum of numpy of values[start:start + n] (its add reduction's inner loop).

    Up to 128 values `_pairwise_block`; more: the sum of the two halves' sums, the first half
    n // 2 rounded down to a multiple of 8 -- numpy's recursion, walked with an explicit
    stack (numba's on-disk cache does not take recursive functions). np.sum along a
    contiguous axis is 0.0 + this (tests/models/test_gap_kernels.py checks it).
    """
    if n <= 128:
        return _pairwise_block(values, start, n)
    # post-order walk of the split tree: (start, n, halves pushed) per pending node
    node_start = np.empty(128, dtype=np.int64)
    node_n = np.empty(128, dtype=np.int64)
    node_split = np.zeros(128, dtype=np.bool_)
    sums = np.empty(128)
    depth, n_sums = 1, 0
    node_start[0], node_n[0] = start, n
    while depth:
        depth -= 1
        first, count = node_start[depth], node_n[depth]
        if count <= 128:
            sums[n_sums] = _pairwise_block(values, first, count)
            n_sums += 1
        elif node_split[depth]:
            n_sums -= 1
            sums[n_sums - 1] = sums[n_sums - 1] + sums[n_sums]
        else:
            half = count // 2
            half -= half % 8
            node_split[depth] = True  # this node again, to add its halves' sums
            node_start[depth + 1], node_n[depth + 1] = first + half, count - half
            node_split[depth + 1] = False
            node_start[depth + 2], node_n[depth + 2] = first, half
            node_split[depth + 2] = False
            depth += 3
    return sums[0]


@numba.njit([(_array(2), _F8, _F8, _array(1), _array(2), _F8, _array(4), _array(3), _array(3),
              _array(3), _array(2), _B1, _F8, _array(2), _F8)], **_JIT)
def walk_geometry(speed_times, s0, route_length_m, cum_s, pose_table, ego_r, scene_xy,
                  cos_heading, sin_heading, scene_along, other_r, clipped, own_radius_m,
                  crosswalks, softness_m):
    """The walks' positions, their gaps to the scene's objects and crosswalk tanh arguments.

    s = min(s0 + speed x time, route length) (np.minimum), its Route.pose_at position; then
    gap_kernels.circle_gaps of the disc there (one circle) to gap_kernels.scene_circles, and
    gap_kernels.occupancy_arguments of its crosswalks (no zones).

    Args:
        speed_times: (A, T) candidate speed x plan time [m].
        s0: arc length now [m].
        route_length_m: the crossing route's length [m].
        cum_s: (S + 1,) the route's cumulative segment lengths [m].
        pose_table: (S, 6) Route.pose_at's per-segment table.
        ego_r: the radius of the pedestrian's covering circle [m].
        scene_xy: (L, M, T, 2) the objects' predicted positions [m].
        cos_heading: (L, M, T) np.cos of their headings.
        sin_heading: (L, M, T) np.sin of their headings.
        scene_along: (L, M, C) their covering circles' offsets (footprint.circle_layout) [m].
        other_r: (L, M) their circles' radii [m].
        clipped: return -max(gap, 0) (the safety feature's exp argument) rather than the gaps.
        own_radius_m: the pedestrian's radius, for the crosswalk occupancy [m].
        crosswalks: (W, 6) as gap_kernels.occupancy_arguments takes them.
        softness_m: sim/costs.OCCUPANCY_SOFTNESS_M [m].

    Returns:
        the gaps or -max(gap, 0) (L, A, T, M) [m]; the tanh arguments (W, A, T).
    """
    n_speeds, n_t = speed_times.shape
    n_seg = len(pose_table)
    xy = np.empty((n_speeds, n_t, 2))
    ego_x = np.empty((1, n_speeds, n_t))
    ego_y = np.empty((1, n_speeds, n_t))
    for a in range(n_speeds):
        for t in range(n_t):
            s = _nan_min(s0 + speed_times[a, t], route_length_m)
            k = _segment(s, cum_s, n_seg)
            local = s - cum_s[k]
            x = pose_table[k, 0] + local * pose_table[k, 2]
            y = pose_table[k, 1] + local * pose_table[k, 3]
            xy[a, t, 0] = ego_x[0, a, t] = x
            xy[a, t, 1] = ego_y[0, a, t] = y
    n_hyp = other_r.shape[0]
    other_x, other_y = scene_circles(scene_xy, cos_heading, sin_heading, scene_along)
    gap, _, _ = circle_gaps(ego_x, ego_y, ego_r, other_x, other_y, other_r,
                            np.zeros((n_hyp, other_r.shape[1]), dtype=np.bool_), clipped)
    soft = occupancy_arguments(xy, ego_x, ego_y, ego_r, own_radius_m, crosswalks,
                               np.zeros((0, 1, 5)), np.zeros(0, dtype=np.int64), softness_m)
    return gap, soft


@numba.njit([(_array(1), _I8, _F8, _F8, _F8, _array(1), _array(4), _array(2, _B1), _array(3),
              _array(3), _F8)], **_JIT)
def walk_costs(speeds, n_t, v_ref_mps, prev_speed, dt_s, weights, safety_exp, present,
               occupancy_tanh, scene_sums, scale):
    """pedestrian_q_values: the step costs of the walks summed over the horizon, times scale.

    Per step, as models/pedestrian.py adds them: w_speed (v - v_ref)^2, w_accel a^2 and
    w_jerk a^2 (a = (v - prev_speed) / dt on the first step, 0 after it), w_safety times the
    sum over the present objects of exp(-max(gap, 0)) (np.sum's order: one by one, fewer
    than circle_gaps.MAX_KERNEL_OBJECTS), w_conflict
    times 0.0 + the occupancy 0.5 (1 + tanh) times the scene's sum, crosswalk by crosswalk;
    each only if its weight is not zero; then np.sum's pairwise sum over the steps.

    Args:
        speeds: (A,) candidate speeds [m/s].
        n_t: T, the number of steps.
        v_ref_mps: the reference speed [m/s].
        prev_speed: the speed before the plans [m/s].
        dt_s: the rollout step [s].
        weights: (5,) the weights of speed, accel, jerk, safety and conflict.
        safety_exp: (L, A, T, M) exp(-max(gap, 0)), M < circle_gaps.MAX_KERNEL_OBJECTS
            (unused with a zero safety weight).
        present: (L, M) the objects present in each hypothesis.
        occupancy_tanh: (W, A, T) tanh of walk_geometry's arguments of the crosswalks with a
            pair of the pedestrian and a present vehicle (W = 0: no conflict to add).
        scene_sums: (W, L, T) per crosswalk the vehicles' summed crosswalk occupancy.
        scale: plan_dt / DT_S.

    Returns:
        (L, A) the costs.
    """
    w_speed, w_accel, w_jerk, w_safety, w_conflict = (weights[0], weights[1], weights[2],
                                                      weights[3], weights[4])
    n_hyp, n_obj = present.shape
    add_conflict = len(occupancy_tanh) > 0 and w_conflict != 0.0
    steps = np.empty(n_t)
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
                if w_safety != 0.0:  # np.sum of fewer than 8 values >= +0
                    summed = -0.0
                    for m in range(n_obj):
                        summed += safety_exp[h, a, t, m] if present[h, m] else 0.0
                    term = (0.0 + summed) * w_safety
                    total = total + term if started else term
                    started = True
                if add_conflict:
                    conflict = 0.0
                    for r in range(len(occupancy_tanh)):
                        occupancy = 0.5 * (1.0 + occupancy_tanh[r, a, t])
                        conflict = conflict + occupancy * scene_sums[r, h, t]
                    term = w_conflict * conflict
                    total = total + term if started else term
                steps[t] = total
            cost[h, a] = (0.0 + _pairwise_sum(steps, 0, n_t)) * scale
    return cost

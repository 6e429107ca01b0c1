"""Compiled (numba) loops for the candidates' rollouts, poses and vehicle gaps.

`models/gap_evaluation.vehicle_gap_evaluation` (a driver's Q*, the robot's model of a human)
and `models/pedestrian.pedestrian_q_values` (their costs: models/cost_kernels.py) evaluate a few hundred plan steps per decision;
in numpy that is some 150 calls of a few microseconds each. These kernels do the same
arithmetic in a few fused loops, bit for bit (tests/models/test_gap_kernels.py,
tests/models/test_gap_evaluation.py):

* every value is computed by the same IEEE operations (+, -, *, /, sqrt) in the same order
  as the numpy reference (models/candidates.py); numba's defaults do not contract a * b + c
  into a fused multiply-add and this module never asks for fastmath;
* minima and maxima propagate NaN as np.minimum / np.maximum do (their order cannot matter
  otherwise: no signed zero reaches them, see the functions' docstrings);
* sums follow np.sum's order along a contiguous axis: numpy's pairwise summation
  (sim/pairwise_sum.py), which below 8 values is the one-by-one sum; the sums over the
  objects are sim/costs.object_sum's, that order whatever the reference's memory layout;
  cumulative sums are np.cumsum's sequential ones;
* the transcendental functions (np.exp of the safety feature, np.tanh of the crosswalk
  occupancy) stay in numpy: numpy's SIMD exp differs from libm's in the last bit. The kernels
  hand numpy the array to exponentiate and take the result back.

The module is imported at the first evaluation (importing numba takes a few tenths of a
second); `cache=True` keeps the machine code next to it (__pycache__), so only the first
process after a change compiles. numba's cache notices changes of a function's own file only,
so a compiled function here calls only compiled functions of this module (the pedestrian's
`walk_geometry` is here for that reason; cost_kernels.py calls nothing of it). The objects'
conflict-zone claims, a job of their own, are models/zone_kernels.py. Every kernel
has one signature: read-only C-contiguous arrays (writable ones convert to them), so one
compilation serves every call.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean


def _array(ndim: int, dtype=_F8):
    """The numba type of a read-only C-contiguous array (a writable one converts to it)."""
    return types.Array(dtype, ndim, "C", readonly=True)


_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(cache=True)
def _nan_min(a, b):
    """np.minimum(a, b) of two floats: the smaller, NaN if either is NaN."""
    return b if (b < a or math.isnan(b)) else a


@numba.njit(cache=True)
def _nan_max(a, b):
    """np.maximum(a, b) of two floats: the larger, NaN if either is NaN."""
    return b if (b > a or math.isnan(b)) else a


@numba.njit(cache=True)
def _curve_cap(s, v_max, step_m):
    """route_rules.CurveSpeed.at of one arc length s [m] (|s / step_m| far below 2**63)."""
    k = np.int64(np.rint(s / step_m))
    if k < 0:
        k = 0
    elif k > len(v_max) - 1:
        k = len(v_max) - 1
    return v_max[k]


@numba.njit(cache=True)
def _segment(s, cum_s, n_seg, hint=0):
    """Route.pose_at's segment of arc length s: searchsorted(cum_s, s, 'right') - 1, clamped.

    cum_s is sorted, so that index lo is the one with cum_s[lo - 1] <= s < cum_s[lo] (the ends
    count as -inf and +inf): `hint` + 1, the segment after it, is tried first (a plan's arc
    lengths grow step by step), then bisection.
    """
    if n_seg == 1:
        return 0
    n = len(cum_s)
    lo = hint + 1
    if 0 < lo < n and cum_s[lo - 1] <= s and not cum_s[lo] <= s:
        return min(hint, n_seg - 1)
    if lo + 1 < n and cum_s[lo] <= s and not cum_s[lo + 1] <= s:
        return min(lo, n_seg - 1)
    lo, hi = 0, n  # the first index whose cum_s exceeds s
    while lo < hi:
        mid = (lo + hi) // 2
        if cum_s[mid] <= s:
            lo = mid + 1
        else:
            hi = mid
    k = lo - 1
    return 0 if k < 0 else (min(k, n_seg - 1))


@numba.njit(**_JIT)
def plan_poses(increments, n_cont, v0, s0, dt_s, continuations, n_first, has_curve, v_max,
               curve_step_m, cum_s, pose_table, along):
    """The candidates' rollouts and the ego's covering circles along the route.

    What models/candidates.evaluate_candidates computes before the scene: _rollout (the v >= 0
    limit), with a curve speed _governed and the excess over the curve speed, Route.pose_at
    of s0 + ds and the covering circles x + along cos(h), y + along sin(h). For a finite v0
    that is not -0.0 (then no signed zero reaches a minimum) and |s0|, |v0| small enough that
    the curve-speed grid index fits an int64.

    Args:
        increments: (P, T) cumsum(accel * dt_s) of the P = A x C plans [m/s], plan p having
            continuation p % n_cont.
        n_cont: C, the number of continuations.
        v0: initial speed [m/s].
        s0: initial arc length [m].
        dt_s: rollout step [s].
        continuations: (C,) continuation accelerations [m/s^2].
        n_first: steps of the first segment (>= 1).
        has_curve: whether a curve speed is given (v_max, curve_step_m: its grid).
        v_max: (G,) CurveSpeed.v_max_mps [m/s] (unused without a curve speed).
        curve_step_m: its grid step [m].
        cum_s: (S + 1,) the route's cumulative segment lengths [m].
        pose_table: (S, 6) per segment: start x, y [m], unit direction, cos and sin of the
            heading.
        along: (K,) offsets of the ego's covering circles along its heading [m].

    Returns:
        v, ds, a_eff (P, T) [m/s, m, m/s^2]; curve_excess (P,) [m/s] (empty without a curve
        speed); xy (P, T, 2) [m]; ego_x, ego_y (K, P, T) [m].
    """
    n_plans, n_t = increments.shape
    v = np.empty((n_plans, n_t))
    ds = np.empty((n_plans, n_t))
    a_eff = np.empty((n_plans, n_t))
    v_start = v0 - _nan_min(0.0, v0)  # v_full[..., 0] of _rollout
    for p in range(n_plans):
        running_min = v0
        previous = v_start
        distance = 0.0
        for t in range(n_t):
            s_full = v0 + increments[p, t]
            running_min = _nan_min(running_min, s_full)
            speed = s_full - _nan_min(0.0, running_min)
            step = 0.5 * (speed + previous) * dt_s
            distance = step if t == 0 else distance + step
            v[p, t] = speed
            ds[p, t] = distance
            a_eff[p, t] = (speed - previous) / dt_s
            previous = speed
    excess = np.empty(n_plans if has_curve else 0)
    if has_curve:
        ceiling = np.inf
        for p in range(n_plans):
            for t in range(n_t):
                ceiling = _nan_min(ceiling, _curve_cap(s0 + ds[p, t], v_max, curve_step_m))
        if math.isfinite(ceiling) or not v0 > 0.0:  # rollouts._governed
            for p in range(n_plans):
                rising = continuations[p % n_cont] > 0.0 and math.isfinite(ceiling)
                bound = _nan_max(v[p, n_first - 1], ceiling)
                previous = v0
                distance = 0.0
                for t in range(n_t):
                    speed = v[p, t]
                    if rising and t >= n_first:
                        speed = _nan_min(speed, bound)
                    if math.isfinite(ceiling):
                        step = 0.5 * (speed + previous) * dt_s
                        distance = step if t == 0 else distance + step
                        ds[p, t] = distance
                    v[p, t] = speed
                    a_eff[p, t] = (speed - previous) / dt_s
                    previous = speed
        for p in range(n_plans):
            largest = -np.inf
            for t in range(n_t):
                cap = _curve_cap(s0 + ds[p, t], v_max, curve_step_m)
                largest = _nan_max(largest, v[p, t] - cap) if t else v[p, t] - cap
            excess[p] = largest
    n_seg, n_circles = len(pose_table), len(along)
    xy = np.empty((n_plans, n_t, 2))
    ego_x = np.empty((n_circles, n_plans, n_t))
    ego_y = np.empty((n_circles, n_plans, n_t))
    segment = np.empty((n_plans, n_t), dtype=np.int64)  # each step's route segment
    k = 0
    for p in range(n_plans):
        for t in range(n_t):
            s = s0 + ds[p, t]
            if n_seg > 1:  # (one segment: 0)
                k = _segment(s, cum_s, n_seg, k)
            local = s - cum_s[k]
            xy[p, t, 0] = pose_table[k, 0] + local * pose_table[k, 2]
            xy[p, t, 1] = pose_table[k, 1] + local * pose_table[k, 3]
            segment[p, t] = k
    # the circles one by one over the contiguous (plan, step) axes: the same values
    for c in range(n_circles):
        offset = along[c]
        for p in range(n_plans):
            for t in range(n_t):
                k = segment[p, t]
                ego_x[c, p, t] = xy[p, t, 0] + offset * pose_table[k, 4]
                ego_y[c, p, t] = xy[p, t, 1] + offset * pose_table[k, 5]
    return v, ds, a_eff, excess, xy, ego_x, ego_y


@numba.njit(**_JIT)
def scene_circles(scene_xy, cos_heading, sin_heading, along):
    """circle_gaps.scene_circles: the objects' covering circles, x + along cos(h), y + ...

    Args:
        scene_xy: (L, M, T, 2) the objects' predicted positions [m].
        cos_heading: (L, M, T) np.cos of their headings.
        sin_heading: (L, M, T) np.sin of their headings.
        along: (L, M, C) footprint.circle_layout's offsets along the heading [m].

    Returns:
        x and y (J, L, M, T) of the circles' centres [m]; J = 1 when every offset is 0 (only
        discs: the circles coincide), else C.
    """
    n_hyp, n_obj, n_t = cos_heading.shape
    n_circles = 1
    for value in along.ravel():
        if value != 0.0:
            n_circles = along.shape[2]
    other_x = np.empty((n_circles, n_hyp, n_obj, n_t))
    other_y = np.empty((n_circles, n_hyp, n_obj, n_t))
    for j in range(n_circles):
        for h in range(n_hyp):
            for m in range(n_obj):
                offset = along[h, m, j]
                for t in range(n_t):
                    other_x[j, h, m, t] = scene_xy[h, m, t, 0] + offset * cos_heading[h, m, t]
                    other_y[j, h, m, t] = scene_xy[h, m, t, 1] + offset * sin_heading[h, m, t]
    return other_x, other_y


@numba.njit(**_JIT)
def circle_gaps(ego_x, ego_y, ego_r, other_x, other_y, other_r, vehicles, clipped):
    """circle_gaps.circle_pair_gap of every plan step and object, and the vehicle clearance.

    Per (hypothesis, object, plan step): the smallest squared centre distance dx^2 + dy^2
    over the circle pairs (NaN if any is NaN), its square root minus the ego's radius minus
    the object's. An object whose circles coincide (a disc) is compared through its first
    one, an object that equals hypothesis 0's copies its gaps: the same values.

    Args:
        ego_x: (K, P, T) x of the ego's covering circles along its P plans [m].
        ego_y: (K, P, T) their y [m].
        ego_r: their radius [m].
        other_x: (J, L, M, T) x of the objects' covering circles [m].
        other_y: (J, L, M, T) their y [m].
        other_r: (L, M) their radii [m].
        vehicles: (L, M) the objects that are a present vehicle.
        clipped: return -max(gap, 0), the argument of the safety feature's exp, rather
            than the gaps.

    Returns:
        the gaps (L, P, T, M) [m], or -max(gap, 0) with `clipped`; the clearance (L, P): the
        smallest gap to a present vehicle over the plan (inf without one) [m]; and its
        max(., 0), the vehicle gap [m].
    """
    n_circles, n_plans, n_t = ego_x.shape
    n_obj_circles, n_hyp, n_obj = other_x.shape[0], other_x.shape[1], other_x.shape[2]
    gap = np.empty((n_hyp, n_plans, n_t, n_obj))
    nearest = np.empty((n_plans, n_t))
    for h in range(n_hyp):
        for m in range(n_obj):
            shared = h > 0 and other_r[h, m] == other_r[0, m]
            disc = True
            for j in range(n_obj_circles):
                for t in range(n_t):
                    if shared and (other_x[j, h, m, t] != other_x[j, 0, m, t]
                                   or other_y[j, h, m, t] != other_y[j, 0, m, t]):
                        shared = False
                    if j and (other_x[j, h, m, t] != other_x[0, h, m, t]
                              or other_y[j, h, m, t] != other_y[0, h, m, t]):
                        disc = False
            if shared:  # element by element: a slice copy compiles numba's shape-error message
                for p in range(n_plans):
                    for t in range(n_t):
                        gap[h, p, t, m] = gap[0, p, t, m]
                continue
            nearest[:] = np.inf
            for k in range(n_circles):
                for j in range(1 if disc else n_obj_circles):
                    obj_x, obj_y = other_x[j, h, m], other_y[j, h, m]  # (T,)
                    for p in range(n_plans):
                        for t in range(n_t):
                            dx = ego_x[k, p, t] - obj_x[t]
                            dy = ego_y[k, p, t] - obj_y[t]
                            nearest[p, t] = _nan_min(nearest[p, t], dx * dx + dy * dy)
            radius = other_r[h, m]
            for p in range(n_plans):
                for t in range(n_t):
                    gap[h, p, t, m] = math.sqrt(nearest[p, t]) - ego_r - radius
    clearance = np.full((n_hyp, n_plans), np.inf)
    for h in range(n_hyp):
        for m in range(n_obj):
            if vehicles[h, m]:
                for p in range(n_plans):
                    smallest = clearance[h, p]
                    for t in range(n_t):
                        smallest = _nan_min(smallest, gap[h, p, t, m])
                    clearance[h, p] = smallest
    vehicle_gap = np.empty((n_hyp, n_plans))
    for h in range(n_hyp):
        for p in range(n_plans):
            vehicle_gap[h, p] = _nan_max(clearance[h, p], 0.0)
    if clipped:
        for h in range(n_hyp):
            for p in range(n_plans):
                for t in range(n_t):
                    for m in range(n_obj):
                        gap[h, p, t, m] = -_nan_max(gap[h, p, t, m], 0.0)
    return gap, clearance, vehicle_gap


# one signature, read-only arrays: its two callers pass writable and read-only zone tables
@numba.njit((_array(3), types.Tuple((_array(3), _array(3), _F8)), _F8, _array(2),
             types.Tuple((_array(3), _array(1, _I8))), _F8), **_JIT)
def occupancy_arguments(xy, ego_circles, ego_radius, crosswalks, zone_table, softness_m):
    """The arguments of np.tanh of the ego's crosswalk and zone occupancies (sim/costs.py).

    crosswalk_occupancy(xy, ego_radius, cw) is 0.5 (1 + tanh(0.5 depth / softness)), depth =
    min(half length - |u|, half width - |w| + ego_radius), u = rx c + ry s, w = ry c - rx s;
    zone_occupancy of the covering circles the same of the largest over the circles of the
    smallest signed distance inside the zone's edges plus the circles' radius. A signed zero
    in a depth cannot change the occupancy (1.0 + tanh(-0.0) == 1.0 + tanh(+0.0)).

    Args:
        xy: (P, T, 2) the ego's positions along its plans [m].
        ego_circles: its covering circles (ego_x (K, P, T) their x [m], ego_y (K, P, T) their
            y [m], ego_r their radius [m]).
        ego_radius: the ego's bounding radius [m].
        crosswalks: (W, 6) per crosswalk: centre x, y [m], cos and sin of the walk heading,
            half length, half width [m].
        zone_table: (zones (Z, V, 5) per zone edge: start x, y [m], edge vector x, y [m], its
            length [m]; zone_sizes (Z,) the number of edges of each zone).
        softness_m: sim/costs.OCCUPANCY_SOFTNESS_M [m].

    Returns:
        (W + Z, P, T) 0.5 depth / softness, the crosswalks' rows first.
    """
    ego_x, ego_y, ego_r = ego_circles
    zones, zone_sizes = zone_table
    n_circles, n_plans, n_t = ego_x.shape
    n_cw = len(crosswalks)
    out = np.empty((n_cw + len(zones), n_plans, n_t))
    for i in range(n_cw):
        cx, cy, c, s, half_length, half_width = crosswalks[i]
        for p in range(n_plans):
            for t in range(n_t):
                rx = xy[p, t, 0] - cx
                ry = xy[p, t, 1] - cy
                u = half_length - abs(rx * c + ry * s)
                w = half_width - abs(ry * c - rx * s) + ego_radius
                out[i, p, t] = 0.5 * _nan_min(u, w) / softness_m
    for z in range(len(zones)):
        edges = zones[z]
        for p in range(n_plans):
            for t in range(n_t):
                depth = 0.0
                for k in range(n_circles):
                    x, y = ego_x[k, p, t], ego_y[k, p, t]
                    inside = 0.0
                    for e in range(zone_sizes[z]):
                        px, py, ex, ey, length = edges[e]
                        d = (ex * (y - py) - ey * (x - px)) / length
                        inside = _nan_min(inside, d) if e else d
                    depth = _nan_max(depth, inside + ego_r) if k else inside + ego_r
                out[n_cw + z, p, t] = 0.5 * depth / softness_m
    return out


@numba.njit(**_JIT)
def scene_occupancy_arguments(scene_xy, scene_radius, crosswalks, softness_m):
    """The arguments of np.tanh of the objects' crosswalk occupancies (see occupancy_arguments).

    Args:
        scene_xy: (L, M, T, 2) the objects' predicted positions [m].
        scene_radius: (L, M) their bounding radii [m].
        crosswalks: (W, 6) as occupancy_arguments takes them.
        softness_m: sim/costs.OCCUPANCY_SOFTNESS_M [m].

    Returns:
        (W, L, T, M) 0.5 depth / softness.
    """
    n_hyp, n_obj, n_t = scene_xy.shape[0], scene_xy.shape[1], scene_xy.shape[2]
    out = np.empty((len(crosswalks), n_hyp, n_t, n_obj))
    for i in range(len(crosswalks)):
        cx, cy, c, s, half_length, half_width = crosswalks[i]
        for h in range(n_hyp):
            for m in range(n_obj):
                for t in range(n_t):
                    rx = scene_xy[h, m, t, 0] - cx
                    ry = scene_xy[h, m, t, 1] - cy
                    u = half_length - abs(rx * c + ry * s)
                    w = half_width - abs(ry * c - rx * s) + scene_radius[h, m]
                    out[i, h, t, m] = 0.5 * _nan_min(u, w) / softness_m
    return out


@numba.njit([(_array(2), _I8, _F8, _F8, _F8, _array(1), _I8, _B1, _array(1), _F8, _array(1),
              _array(2), _array(1), _F8, _array(4), _array(3), _array(3), _array(3), _array(2),
              _array(2), _array(2, _B1), _array(2, _B1), _B1, _F8, _array(2), _array(3),
              _array(1, _I8), _F8)], **_JIT)
def plan_evaluation(increments, n_cont, v0, s0, dt_s, continuations, n_first, has_curve, v_max,
                    curve_step_m, cum_s, pose_table, along, ego_r, scene_xy, cos_heading,
                    sin_heading, scene_along, other_r, scene_radius, present, is_pedestrian,
                    clipped, ego_radius, crosswalks, zones, zone_sizes, softness_m):
    """`plan_poses`, then `circle_gaps` and `occupancy_arguments` of its plans, in one call.

    The arguments are theirs (see them); ego_x and ego_y come from plan_poses, other_x and
    other_y from `scene_circles` (scene_xy, cos_heading, sin_heading, scene_along: its
    arguments), circle_gaps' vehicles are present & ~is_pedestrian ((L, M) bool each); and
    `scene_occupancy_arguments` of the crosswalks (scene_radius (L, M): the objects' bounding
    radii [m]).

    Returns (A = P / n_cont first actions; few arrays, as each returned array costs a
    microsecond or so to hand to Python):
        (3, A, C, T) v, ds and a_eff of plan_poses; its curve_excess (A, C) ((0, C) without a
        curve speed); the gaps or -max(gap, 0) (L, P, T, M), and (2, L, A, C) the clearance
        and the vehicle gap of circle_gaps; the tanh arguments (W + Z, P, T) of
        occupancy_arguments and (W, L, T, M) of scene_occupancy_arguments.
    """
    v, ds, a_eff, excess, xy, ego_x, ego_y = plan_poses(
        increments, n_cont, v0, s0, dt_s, continuations, n_first, has_curve, v_max,
        curve_step_m, cum_s, pose_table, along)
    other_x, other_y = scene_circles(scene_xy, cos_heading, sin_heading, scene_along)
    vehicles = np.empty(present.shape, dtype=np.bool_)
    for h in range(present.shape[0]):
        for m in range(present.shape[1]):
            vehicles[h, m] = present[h, m] and not is_pedestrian[h, m]
    gap, clearance, vehicle_gap = circle_gaps(ego_x, ego_y, ego_r, other_x, other_y, other_r,
                                              vehicles, clipped)
    soft = occupancy_arguments(xy, (ego_x, ego_y, ego_r), ego_radius, crosswalks,
                               (zones, zone_sizes), softness_m)
    scene_soft = scene_occupancy_arguments(scene_xy, scene_radius, crosswalks, softness_m)
    n_plans, n_t = v.shape
    n_first_actions = n_plans // n_cont
    # element by element: a slice copy compiles numba's shape-error message (seconds)
    motion = np.empty((3, n_plans, n_t))
    for p in range(n_plans):
        for t in range(n_t):
            motion[0, p, t], motion[1, p, t], motion[2, p, t] = v[p, t], ds[p, t], a_eff[p, t]
    gaps = np.empty((2,) + clearance.shape)
    for h in range(clearance.shape[0]):
        for p in range(clearance.shape[1]):
            gaps[0, h, p], gaps[1, h, p] = clearance[h, p], vehicle_gap[h, p]
    return (motion.reshape((3, n_first_actions, n_cont, n_t)), excess.reshape(
        (n_first_actions if has_curve else 0, n_cont)), gap, soft, scene_soft,
        gaps.reshape((2, clearance.shape[0], n_first_actions, n_cont)))


@numba.njit([(_array(2), _F8, _F8, _array(1), _array(2), _F8, _array(4), _array(3), _array(3),
              _array(3), _array(2), _array(2), _B1, _F8, _array(2), _F8)], **_JIT)
def walk_geometry(speed_times, s0, route_length_m, cum_s, pose_table, ego_r, scene_xy,
                  cos_heading, sin_heading, scene_along, other_r, scene_radius, clipped,
                  own_radius_m, crosswalks, softness_m):
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
        scene_radius: (L, M) their bounding radii [m].
        clipped: return -max(gap, 0) (the safety feature's exp argument) rather than the gaps.
        own_radius_m: the pedestrian's radius, for the crosswalk occupancy [m].
        crosswalks: (W, 6) as gap_kernels.occupancy_arguments takes them.
        softness_m: sim/costs.OCCUPANCY_SOFTNESS_M [m].

    Returns:
        the gaps or -max(gap, 0) (L, A, T, M) [m]; the tanh arguments (W, A, T) of its
        crosswalk occupancies and (W, L, T, M) of the objects'.
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
    soft = occupancy_arguments(xy, (ego_x, ego_y, ego_r), own_radius_m, crosswalks,
                               (np.zeros((0, 1, 5)), np.zeros(0, dtype=np.int64)), softness_m)
    return gap, soft, scene_occupancy_arguments(scene_xy, scene_radius, crosswalks, softness_m)

"""The robot's corridor test and the MPC's progress and speed bounds, compiled by numba.

agents/robot/corridor.py and mpc.py call these through `corridor.corridor_kernels()`, loaded at
the first use in a process (cache=True: compiled once, in this folder's __pycache__;
agents/compile_kernels.py compiles them ahead with one MPC plan). Each kernel is the numpy it
replaced, operation for operation (tests/agents/test_corridor_kernels.py keeps that numpy and
checks them bit for bit): which predictions to project (`distinct_predictions`; their
footprints' extents are sim/route_kernels.project_footprints), when they occupy the corridor
(`corridor_occupancy`), the braking reach, the reachable progress and the infeasibility test,
the curvature speed bound and a branch's give-way bound. Sums are np.cumsum's sequential ones;
np.minimum / np.maximum are `_np_minimum` / `_np_maximum` (a NaN stays, a tie gives the second
operand, as numpy's do); no reduction is reordered. No fast-math (no contraction into fused
multiply-adds), no threads.
"""

from __future__ import annotations

import math

import numba


@numba.njit(cache=True)
def distinct_predictions(predictions, mask, out):
    """Which (hypothesis, object) predictions agents/robot/corridor.py projects, in one pass.

    Object m is shared when some object is present in more than one hypothesis and m is
    predicted alike (==, so NaN never is) in every hypothesis, the first included: position,
    heading, length, width and kind. A shared object present anywhere is projected once, as
    the first hypothesis' (l = 0); any other as present (mask). The projected pairs are
    numbered in row-major (hypothesis, object) order, np.nonzero's.

    Args:
        predictions: (xy (L, M, N, 2) predicted positions [m], heading (L, M, N) predicted
            headings [rad], length_m (L, M) and width_m (L, M) [m], is_pedestrian (L, M) bool).
        mask: (L, M) bool, present in that hypothesis.
        out: the arrays written: (shared (M,) bool, predicted alike in every hypothesis (all
            False when no object is present in more than one); pair (L, M) int64, the number
            of the projected pair that stands for object m of hypothesis l where present (a
            shared object: its l = 0 pair), else -1; source (2, L M) int64, the hypothesis and
            the object of pair p in column p).

    Returns:
        P, the number of projected pairs.
    """
    xy, heading, length_m, width_m, is_pedestrian = predictions
    shared, pair, source = out
    n_hyp, n_obj = mask.shape
    several = False
    if n_hyp > 1:
        for m in range(n_obj):
            count = 0
            for l in range(n_hyp):
                count += mask[l, m]
            several = several or count > 1
    for m in range(n_obj):
        alike = several
        for l in range(n_hyp):
            if not alike:
                break
            alike = (length_m[l, m] == length_m[0, m] and width_m[l, m] == width_m[0, m]
                     and is_pedestrian[l, m] == is_pedestrian[0, m])
            for n in range(heading.shape[2]):
                if not (alike and heading[l, m, n] == heading[0, m, n]
                        and xy[l, m, n, 0] == xy[0, m, n, 0]
                        and xy[l, m, n, 1] == xy[0, m, n, 1]):
                    alike = False
                    break
        shared[m] = alike
    count = 0
    for l in range(n_hyp):
        for m in range(n_obj):
            pair[l, m] = -1
            present = mask[l, m]
            if shared[m] and l == 0:
                for k in range(n_hyp):
                    present = present or mask[k, m]
            elif shared[m]:
                present = False
            if present:
                pair[l, m] = count
                source[0, count], source[1, count] = l, m
                count += 1
    for l in range(1, n_hyp):
        for m in range(n_obj):
            if shared[m] and mask[l, m]:
                pair[l, m] = pair[0, m]
    return count


@numba.njit(cache=True)
def corridor_occupancy(extent, is_pedestrian, source, corridor, mask, pair, out):
    """When each projected footprint occupies the robot's corridor (agents/robot/corridor.py).

    Footprint p is in the corridor at step n when its lateral extent overlaps
    [-half, half] (half_pedestrian_m for a pedestrian, else half_other_m) or, for a pedestrian
    with `widen`, overlaps [-closing_half_m, closing_half_m] while closing in
    (|mean lateral offset| shrinking by more than 1 mm from the previous step; the first step
    as the second, or, with one step, c - (c + 1) < -1e-3), and its extent along the route is
    within (0, route_length_m). It is relevant when occupied at some step and its rear at the
    first step is at or beyond rear_from_m. The comparisons of the numpy formulation
    (tests/agents/test_corridor_kernels.py), no arithmetic but those differences.

    Args:
        extent: (5, P, N) project_footprints' out [m].
        is_pedestrian: (L, M) bool.
        source: (2, >= P) int64, the hypothesis and the object of each projected pair.
        corridor: (half_pedestrian_m half the corridor's width for a pedestrian [m],
            half_other_m for anything else [m], widen whether a pedestrian closing in is in it
            within closing_half_m, closing_half_m half the corridor's width for a pedestrian
            closing in [m], route_length_m the route's length [m], rear_from_m the smallest
            rear arc length at the first step of a relevant one [m]).
        mask: (L, M) bool, object m present in hypothesis l.
        pair: (L, M) distinct_predictions' pair numbers.
        out: the arrays written: (occupied (P, N) bool, in the corridor at step n; span (P, 3)
            int64, first and last occupied step of a relevant footprint (else -1, -1) and
            whether it is a pedestrian's (1, else 0); listed (L, M) int64, per hypothesis, the
            pair numbers of its relevant objects in object order, then -1; n_listed (L,)
            int64, how many each hypothesis has).

    Returns:
        the number of relevant footprints.
    """
    half_pedestrian_m, half_other_m, widen, closing_half_m, route_length_m, rear_from_m = corridor
    occupied, span, listed, n_listed = out
    n_pair, n_step = occupied.shape
    n_relevant = 0
    for p in range(n_pair):
        ped = is_pedestrian[source[0, p], source[1, p]]
        half = half_pedestrian_m if ped else half_other_m
        first, last = -1, -1
        for n in range(n_step):
            lat_min, lat_max = extent[2, p, n], extent[3, p, n]
            inside = lat_min <= half and lat_max >= -half
            if ped and widen and not inside:
                if n_step == 1:
                    closing = extent[4, p, 0] - (extent[4, p, 0] + 1.0) < -1e-3
                else:
                    k = max(n, 1)
                    closing = extent[4, p, k] - extent[4, p, k - 1] < -1e-3
                inside = closing and lat_min <= closing_half_m and lat_max >= -closing_half_m
            inside = inside and extent[1, p, n] > 0.0 and extent[0, p, n] < route_length_m
            occupied[p, n] = inside
            if inside:
                if first < 0:
                    first = n
                last = n
        if first >= 0 and extent[0, p, 0] >= rear_from_m:
            span[p, 0], span[p, 1] = first, last
            n_relevant += 1
        else:
            span[p, 0], span[p, 1] = -1, -1
        span[p, 2] = 1 if ped else 0
    listed[:] = -1
    for l in range(mask.shape[0]):
        k = 0
        for m in range(mask.shape[1]):
            if mask[l, m] and span[pair[l, m], 0] >= 0:
                listed[l, k] = pair[l, m]
                k += 1
        n_listed[l] = k
    return n_relevant


# _np_minimum / _np_maximum: qp_kernels.py's twins, kept in this file on purpose: numba's cache
# of a kernel notices edits of its own file only
@numba.njit(cache=True)
def _np_minimum(a, b):
    """np.minimum(a, b) of two floats: a NaN stays, a tie gives b (numpy's, +-0 included)."""
    if math.isnan(a):
        return a
    return a if a < b else b  # noqa: FURB136 - the tie order is the point


@numba.njit(cache=True)
def _np_maximum(a, b):
    """np.maximum(a, b) of two floats: a NaN stays, a tie gives b (numpy's, +-0 included)."""
    if math.isnan(a):
        return a
    return a if a > b else b  # noqa: FURB136 - the tie order is the point


@numba.njit(cache=True)
def braking_reach(v0, decel, dt_s, headway_s, room_m, out):
    """agents/robot/mpc.py's _braking_reach: the numpy arithmetic's bits, in one pass.

    v_k = max(v0 - decel_k, 0) (np.maximum: NaN stays), the progress sum over j <= k of
    ((v_{j-1} + v_j) 0.5) dt (v_{-1} = v0; np.cumsum's sequential sum, its first term as
    it is), out_k = (progress_k + headway_k v_k) + room.

    Args:
        v0: the robot's speed [m/s].
        decel: (N,) the speed lost by the end of each plan step [m/s].
        dt_s: the plan step [s].
        headway_s: (N,) the time headway of each step [s].
        room_m: added to each [m].
        out: (N,) out [m].
    """
    v_prev, progress = v0, 0.0
    for k in range(decel.shape[0]):
        v = _np_maximum(v0 - decel[k], 0.0)
        step = 0.5 * (v_prev + v) * dt_s
        progress = step if k == 0 else progress + step
        out[k] = progress + headway_s[k] * v + room_m
        v_prev = v


@numba.njit(cache=True)
def progress_infeasible(s_low, s_up, reachable_m, margin_m):
    """corridor.provably_infeasible's test, its numpy comparisons' answer, in one pass.

    need = np.maximum.accumulate(s_low) along each row (a NaN stays), and the answer is
    whether need > np.minimum(s_up, reachable_m) + margin_m anywhere (NaN: no).

    Args:
        s_low: (L, N) lower bounds on progress [m].
        s_up: (L, N) upper bounds on progress plus headway times speed [m].
        reachable_m: (N,) the reachable progress [m].
        margin_m: the violation that still does not count [m].
    """
    for l in range(s_low.shape[0]):
        need = s_low[l, 0]
        for k in range(s_low.shape[1]):
            if k > 0:
                need = _np_maximum(need, s_low[l, k])
            if need > _np_minimum(s_up[l, k], reachable_m[k]) + margin_m:
                return True
    return False


@numba.njit(cache=True)
def reachable_progress(v0, prev_accel, accel_max_mps2, jerk_max_mps3, first_dt_s, dt_s,
                       v_max_mps, out):
    """corridor.reachable_progress: the numpy arithmetic's bits, in one pass.

    a_k = min(accel_max, prev + jerk (first_dt + dt k)), climb_k the sequential sum of a_j dt
    (np.cumsum), speed_k = max(climb_k + min(v0, min over j <= k of (v_max_j - climb_j)), 0)
    (np.minimum / np.maximum: NaN stays), out_k the sequential sum of (0.5 dt) (v_{j-1} + v_j)
    (v_{-1} = v0).

    Args:
        v0: the robot's speed [m/s].
        prev_accel: its previous acceleration command [m/s^2].
        accel_max_mps2: its largest acceleration [m/s^2].
        jerk_max_mps3: the jerk bound [m/s^3].
        first_dt_s: the time the first acceleration may change in [s].
        dt_s: plan step [s].
        v_max_mps: (N,) the speed bound of each plan step [m/s].
        out: (N,) out: the upper bound on the progress at the end of each step [m].
    """
    half_dt = 0.5 * dt_s
    climb, bound, v_prev, progress = 0.0, 0.0, v0, 0.0
    for k in range(v_max_mps.shape[0]):
        accel = _np_minimum(accel_max_mps2, prev_accel + jerk_max_mps3 * (first_dt_s + dt_s * k))
        climb = accel * dt_s if k == 0 else climb + accel * dt_s
        room = v_max_mps[k] - climb
        bound = room if k == 0 else _np_minimum(bound, room)
        speed = _np_maximum(climb + _np_minimum(v0, bound), 0.0)
        step = half_dt * (v_prev + speed)
        progress = step if k == 0 else progress + step
        out[k] = progress
        v_prev = speed


@numba.njit(cache=True, error_model="numpy")
def curvature_speed_bound(vertex_s, vertex_kappa, s_lo, s_hi, window_m, lat_accel_max_mps2,
                          v_cap_mps, out):
    """agents/robot/corridor.curvature_speed_bound, capped at v_cap: numpy's bits, one pass.

    Per step k: kappa_k = the largest curvature of the vertices within [s_lo_k - window,
    s_hi_k + window] (0 where there is none; np.max: a NaN stays), the bound
    sqrt(a_lat / (kappa_k + 0.0)) (division by zero: inf, numpy's error model; -0.0 counts as
    +0.0), out_k =
    np.minimum(bound, v_cap) (_np_minimum).

    Args:
        vertex_s: (V,) arc lengths of the route's vertices [m].
        vertex_kappa: (V,) their curvatures [1/m], V >= 1.
        s_lo: (N,) smallest arc length each plan step may reach [m].
        s_hi: (N,) largest [m].
        window_m: vertices this far outside [s_lo, s_hi] count too [m].
        lat_accel_max_mps2: the lateral acceleration allowed [m/s^2].
        v_cap_mps: the speed cap [m/s].
        out: (N,) out: the speed bound of each step [m/s].

    Returns:
        whether the curvature bound is finite at some step (a curve bounds the speed).
    """
    curved = False
    for k in range(s_lo.shape[0]):
        lo = s_lo[k] - window_m
        hi = s_hi[k] + window_m
        kappa = 0.0
        for v in range(vertex_s.shape[0]):
            near = vertex_s[v] >= lo and vertex_s[v] <= hi
            value = vertex_kappa[v] if near else 0.0
            kappa = value if v == 0 else _np_maximum(kappa, value)
        # + 0.0: a zero curvature of either sign is straight (which of +-0 a max returns
        # depends on numpy's reduction order; route_curvature's |kappa| is never -0.0)
        bound = math.sqrt(lat_accel_max_mps2 / (kappa + 0.0))
        curved = curved or math.isfinite(bound)
        out[k] = _np_minimum(bound, v_cap_mps)
    return curved


@numba.njit(cache=True)
def give_way_bound(s_up, wall_m, reach_m, tolerance_m, moving, out):
    """agents/robot/mpc.py's _branch_bounds after mode_bounds: numpy's bits, in one pass.

    up = np.minimum(s_up, wall); moving: np.maximum(up, np.minimum(reach, up + tolerance)),
    at rest: np.maximum(up, reach); then np.maximum(up, 0) (_np_minimum / _np_maximum).

    Args:
        s_up: (N,) upper bounds on progress plus headway times speed [m].
        wall_m: the static limit (a box, a stop line) relative to the robot [m].
        reach_m: (N,) _braking_reach [m].
        tolerance_m: how far a bound gives way to the braking reach when moving [m].
        moving: whether the robot is moving (above its rest speed).
        out: (N,) out [m] (may be s_up).
    """
    for k in range(s_up.shape[0]):
        up = _np_minimum(s_up[k], wall_m)
        if moving:
            up = _np_maximum(up, _np_minimum(reach_m[k], up + tolerance_m))
        else:
            up = _np_maximum(up, reach_m[k])
        out[k] = _np_maximum(up, 0.0)

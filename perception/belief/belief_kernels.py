"""Compiled (numba) pieces of the belief update: numpy's arithmetic, in its order, in few calls.

The robot's belief works on a few dozen numbers per step (L ~ 13 hypotheses, V = 4 traffic
speeds, A ~ 11 actions), so in numpy its time goes to the number of calls, not to the
arithmetic. These kernels do the additions, products, maxima and comparisons between the
transcendental functions, which stay in numpy (np.exp, np.log, np.arctan2, np.hypot and
np.logaddexp use numpy's own vectorized implementations, whose last bit libm's need not
share), and between the matrix products (BLAS). Every kernel reproduces its numpy reference
bit for bit (tests/perception/test_belief_kernels.py):

* a sum along a contiguous axis is numpy's pairwise sum from 0.0 (`_pairwise_sum`: fewer
  than 8 values one by one, else eight running sums; up to 128 values, which is all the
  belief sums along a contiguous axis);
* a sum over a non-contiguous axis, and np.cumsum, add one by one in index order;
* np.max propagates NaN; np.maximum(x, c) is x unless c > x or c is NaN.

One signature each, `cache=True`, no fastmath, error_model "numpy" (a division by zero gives
inf or NaN as in numpy); a compiled function calls only compiled functions of this file
(numba's cache notices changes of this file only), an index 0 as np.int64(0) (numba would
compile the helper once more for a literal 0). Imported at the first update
(`compiled.kernels`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

from marl_social.sim.pairwise_sum import contiguous_sum

# pairwise_sum.py stamp: e57bd2f618419a3d (tests/sim/test_pairwise_sum.py)

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


def _array(ndim: int, dtype=_F8):
    """The numba type of a read-only C-contiguous array (a writable one converts to it)."""
    return types.Array(dtype, ndim, "C", readonly=True)


def _writable(ndim: int, dtype=_F8):
    """The numba type of a writable C-contiguous array (a kernel that writes into it)."""
    return types.Array(dtype, ndim, "C")


@numba.njit(cache=True)
def _nan_max(values, start, n):
    """np.max of values[start:start + n] (n >= 1): NaN if one is NaN."""
    top = values[start]
    for i in range(start, start + n):
        v = values[i]
        if math.isnan(v):
            return v
        top = max(top, v)
    return top


@numba.njit(cache=True)
def _sanitized(values, start, n, out, out_start):
    """bayes.sanitize_log_likelihood of values[start:start + n] into out[out_start:...]."""
    top = _nan_max(values, start, n)
    good = math.isfinite(top)
    for i in range(n):
        out[out_start + i] = values[start + i] - top if good else 0.0


@numba.njit(cache=True)
def _wrapped(angle):
    """(angle + pi) % (2 pi) - pi with np.remainder's arithmetic: fmod, then 2 pi's sign [rad]."""
    m = np.fmod(angle + np.pi, 2.0 * np.pi)
    if m != 0.0:
        if m < 0.0:
            m += 2.0 * np.pi
    else:
        m = 0.0
    return m - np.pi


@numba.njit(cache=True)
def _normalize(pdf):
    """bayes.normalize in place: pdf / np.cumsum(pdf)[-1] (a sum one by one from pdf[0])."""
    total = pdf[0]
    for i in range(1, len(pdf)):
        total += pdf[i]
    for i in range(len(pdf)):
        pdf[i] = pdf[i] / total


@numba.njit((_array(2), _F8), **_JIT)
def boltzmann_exponents(q, beta):
    """-beta (q - q.min(axis=-1)) of Q-values q (R, A), or an empty array if one is not finite.

    action_model.action_log_likelihood's exponent (its check of q first).
    """
    n_rows, n_act = q.shape
    for r in range(n_rows):
        for a in range(n_act):
            if not math.isfinite(q[r, a]):
                return np.empty((0, n_act))
    z = np.empty((n_rows, n_act))
    neg_beta = -beta
    for r in range(n_rows):
        low = q[r, 0]
        for a in range(n_act):
            low = min(low, q[r, a])
        for a in range(n_act):
            z[r, a] = neg_beta * (q[r, a] - low)
    return z


@numba.njit((_array(2),), **_JIT)
def row_sums(values):
    """values.sum(axis=-1) of values (R, A), any A (numpy's pairwise order)."""
    n_rows, n_act = values.shape
    flat = values.ravel()
    out = np.empty(n_rows)
    for r in range(n_rows):
        out[r] = contiguous_sum(flat, r * n_act, n_act)
    return out


@numba.njit((_array(2), _array(1), _array(1)), **_JIT)
def shifted_log_model_terms(z, log_norm, log_kernel):
    """The shifted terms of logsumexp(log_p + log_kernel) and its shift per row.

    With log_p = z - log_norm[r] (the Boltzmann log-probabilities of the R rows (R, A)) and
    log_kernel (A,) the observation's log density under each action: x = log_p + log_kernel,
    top = x.max(axis=-1) (0 where not finite); returns x - top (R, A) and top (R,).
    """
    n_rows, n_act = z.shape
    x = np.empty((n_rows, n_act))
    top = np.empty(n_rows)
    for r in range(n_rows):
        for a in range(n_act):
            x[r, a] = (z[r, a] - log_norm[r]) + log_kernel[a]
        t = _nan_max(x[r], np.int64(0), n_act)
        if not math.isfinite(t):
            t = 0.0
        top[r] = t
        for a in range(n_act):
            x[r, a] = x[r, a] - t
    return x, top


@numba.njit((_array(2), _array(1)), **_JIT)
def node_average_terms(log_lik, log_weights):
    """The shifted terms of logsumexp(log_lik + log_weights[:, None], axis=0) and its shift.

    action_model.speed_averaged_log_likelihood's average over the speed nodes, its check
    first: an empty (0, N) result if a log-likelihood is not finite. x = log_lik (S, N) +
    log_weights (S,), top = x.max(axis=0) (0 where not finite); returns x - top (S, N) and
    top (N,).
    """
    n_nodes, n = log_lik.shape
    for s in range(n_nodes):
        for i in range(n):
            if not math.isfinite(log_lik[s, i]):
                return np.empty((0, n)), np.empty(0)
    x = np.empty((n_nodes, n))
    top = np.empty(n)
    for i in range(n):
        t = log_lik[0, i] + log_weights[0]
        for s in range(n_nodes):
            x[s, i] = log_lik[s, i] + log_weights[s]
            if math.isnan(x[s, i]) or x[s, i] > t:
                t = x[s, i]
        if not math.isfinite(t):
            t = 0.0
        top[i] = t
        for s in range(n_nodes):
            x[s, i] = x[s, i] - t
    return x, top


@numba.njit((_array(2),), **_JIT)
def column_sums(values):
    """values.sum(axis=0) of values (S, N): row by row in index order, as numpy adds them."""
    n_rows, n = values.shape
    out = np.empty(n)
    for i in range(n):
        out[i] = values[0, i]
    for r in range(1, n_rows):
        for i in range(n):
            out[i] = out[i] + values[r, i]
    return out


@numba.njit((_array(1), _F8), **_JIT)
def bounded(log_lik, max_ratio):
    """action_model.bounded_log_likelihood of a flat (N,) array (a copy)."""
    n = len(log_lik)
    out = log_lik.copy()
    for i in range(n):
        if not math.isfinite(log_lik[i]):
            return out
    floor = _nan_max(log_lik, np.int64(0), n) - max_ratio
    for i in range(n):
        if not out[i] >= floor:
            out[i] = floor
    return out


@numba.njit((_writable(1), _array(1), _array(3), _I8), **_JIT)
def joint_log_likelihood(predicted, own, social, n_v):
    """The exponents of the joint update and of its debugging summaries, in one buffer.

    joint_bayes_step's summed and sanitized log-likelihood (N = L V,) of the own sensors'
    (L,) and the H humans' (H, L, V) sources (each sanitized, added own first), then the
    humans' raw sum (N,) sanitized (HiddenAgentBelief.last_likelihoods' "social"), then the
    own sensors' sanitized (L,): a (2 N + L,) buffer for one np.exp. Clips `predicted` (N,)
    at 0 in place (np.maximum(predicted, 0.0)).
    """
    n_l = len(own)
    n = n_l * n_v
    n_h = social.shape[0]
    for i in range(n):  # np.maximum(predicted, 0.0): NaN stays
        predicted[i] = max(predicted[i], 0.0)
    out = np.empty(2 * n + n_l)
    _sanitized(own, np.int64(0), n_l, out, 2 * n)
    total = np.empty(n)
    for i in range(n):
        total[i] = out[2 * n + i // n_v]
    flat = social.ravel()
    rows = np.empty(n)
    raw = np.zeros(n)
    for h in range(n_h):
        _sanitized(flat, h * n, n, rows, np.int64(0))
        for i in range(n):
            total[i] += rows[i]
            raw[i] += flat[h * n + i]
    _sanitized(total, np.int64(0), n, out, np.int64(0))
    _sanitized(raw, np.int64(0), n, out, n)
    return out


@numba.njit((_array(1), _array(1), _F8, _I8), **_JIT)
def joint_posterior(predicted, exp_total, floor, n_v):
    """The joint posterior (L, V) and its floored marginals, or an empty joint if not finite.

    joint_bayes_step after np.exp: predicted * exp(total) normalized; if every entry is finite,
    floored and normalized again; then `floored_marginals`: the sums over v (numpy's pairwise
    order along the contiguous axis) and over l (one by one), floored and normalized. An empty
    joint (0, V) means a non-finite posterior (the caller falls back as bayes_step does).
    """
    n = len(predicted)
    n_l = n // n_v
    posterior = np.empty(n)
    for i in range(n):
        posterior[i] = predicted[i] * exp_total[i]
    _normalize(posterior)
    for i in range(n):
        if not math.isfinite(posterior[i]):
            return np.empty((0, n_v)), np.empty(0), np.empty(0)
    for i in range(n):
        if not posterior[i] >= floor:
            posterior[i] = floor
    _normalize(posterior)
    by_l = np.empty(n_l)
    for i in range(n_l):
        by_l[i] = max(contiguous_sum(posterior, i * n_v, n_v), floor)
    by_v = np.zeros(n_v)
    for i in range(n_l):
        for j in range(n_v):
            by_v[j] += posterior[i * n_v + j]
    for j in range(n_v):
        by_v[j] = max(by_v[j], floor)
    _normalize(by_l)
    _normalize(by_v)
    return posterior.reshape(n_l, n_v), by_l, by_v


@numba.njit((_array(2), _array(2), _F8, _array(1), _array(1), types.UniTuple(_F8, 4)), **_JIT)
def visible_counts(dist, bearing, heading, angles, depth, cone):
    """(P,) how many of each region's K points (P, K) the depth rays show free.

    own_sensors.OwnSensors.visible_fraction after np.hypot and np.arctan2: the bearing
    (arctan2 - heading) wrapped with np.remainder's arithmetic, the two neighbouring rays
    (np.searchsorted, side "left"), and the point seen if inside the cone and range and the
    shorter ray reaches it less `radius`.

    Args:
        dist: (P, K) distances [m].
        bearing: (P, K) np.arctan2 of the relative positions [rad].
        heading: the robot's heading [rad] (subtracted from bearing).
        angles: (R,) ray directions, ascending [rad].
        depth: (R,) depth along each ray [m].
        cone: (rng, half, tolerance, radius): the sensor's range [m] and half-angle [rad]
            (half >= pi: the rays wrap around), the cone edge's tolerance [rad], and the
            radius [m] a point is free with if the ray reaches its distance less it.
    """
    rng, half, tolerance, radius = cone
    full_circle = half >= np.pi
    n_p, n_k = dist.shape
    n_rays = len(angles)
    counts = np.zeros(n_p, dtype=np.int64)
    for p in range(n_p):
        for k in range(n_k):
            b = _wrapped(bearing[p, k] - heading)
            lo, hi = 0, n_rays  # np.searchsorted(angles, b): the first angles[i] >= b
            while lo < hi:
                mid = (lo + hi) // 2
                if angles[mid] < b:
                    lo = mid + 1
                else:
                    hi = mid
            i1 = lo
            d = dist[p, k]
            if full_circle:
                i1 = i1 % n_rays
                i0 = (i1 - 1) % n_rays
                inside = d <= rng
            else:
                i1 = min(i1, n_rays - 1)
                i0 = max(i1 - 1, 0)
                inside = (abs(b) <= half + tolerance) and (d <= rng)
            reach = min(depth[i0], depth[i1])
            if inside and reach >= d - radius:
                counts[p] += 1
    return counts


@numba.njit((_F8, _F8, _array(2), _array(1, _I8)), **_JIT)
def lane_projections(x, y, segments, first_segment):
    """Route.project_point(x, y) of one point on each of N lanes: (N,) arc lengths, laterals.

    Per lane its segments' foot points, clamped to the segments, and the first closest one,
    with project_point's arithmetic (the distance x - (start + t dir)); for a finite point
    (np.argmin's first minimum is then the loop's first strict one).

    Args:
        x: the point's x [m].
        y: its y [m].
        segments: (S, 6) every lane's segments in lane order: start x, y [m], unit direction
            x, y, length [m], arc length at the start [m].
        first_segment: (N + 1,) lane i's segments are first_segment[i]:first_segment[i + 1].
    """
    n_lanes = len(first_segment) - 1
    s_out = np.empty(n_lanes)
    lateral_out = np.empty(n_lanes)
    for lane in range(n_lanes):
        best_d2, best_s, best_lateral = np.inf, 0.0, 0.0
        for k in range(first_segment[lane], first_segment[lane + 1]):
            sx, sy, dx, dy = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
            length, s0 = segments[k, 4], segments[k, 5]
            rx, ry = x - sx, y - sy
            t = min(max(rx * dx + ry * dy, 0.0), length)
            ex, ey = x - (sx + t * dx), y - (sy + t * dy)
            d2 = ex * ex + ey * ey
            if d2 < best_d2:
                best_d2, best_s, best_lateral = d2, s0 + t, dx * ry - dy * rx
        s_out[lane] = best_s
        lateral_out[lane] = best_lateral
    return s_out, lateral_out


@numba.njit(cache=True)
def _speed_q_values_into(base, speeds, v_ref, weight, rows, out, node):
    """`speed_q_values` of one speed's evaluation, written into out[node] (L, V, A)."""
    n_kept, n_act, n_cont = base.shape
    n_t = speeds.shape[2]
    n_v = len(v_ref)
    flat = speeds.ravel()
    squares = np.empty(n_t)
    speed = np.empty((n_v, n_act, n_cont))
    for j in range(n_v):
        for a in range(n_act):
            for c in range(n_cont):
                start = (a * n_cont + c) * n_t
                for t in range(n_t):
                    d = flat[start + t] - v_ref[j]
                    squares[t] = d * d
                speed[j, a, c] = weight * contiguous_sum(squares, np.int64(0), n_t)
    kept = np.empty((n_kept, n_v, n_act))
    for k in range(n_kept):
        for j in range(n_v):
            for a in range(n_act):
                low = base[k, a, 0] + speed[j, a, 0]
                for c in range(n_cont):
                    total = base[k, a, c] + speed[j, a, c]
                    if math.isnan(total):
                        low = total
                        break
                    low = min(low, total)
                kept[k, j, a] = low
    for i in range(len(rows)):  # element by element: no broadcast whose shapes numba must check
        k = rows[i]
        for j in range(n_v):
            for a in range(n_act):
                out[node, i, j, a] = kept[k, j, a]


@numba.njit((_array(3), _array(3), _array(1), _F8, _array(1, _I8)), **_JIT)
def speed_q_values(base, speeds, v_ref, weight, rows):
    """Q* (L, V, A) of every traffic speed: the cheapest continuation with the speed feature.

    social.SocialLikelihood._q_values after the candidates' evaluation: the speed feature
    weight * sum_t (v[a, c, t] - v_ref)^2 (numpy's pairwise sum over the T steps, T <= 128)
    added to base[k, a, c], the minimum over the continuations c (NaN if one is NaN), for
    hypothesis l the kept scene rows[l].

    Args:
        base: (K, A, C) the kept scenes' totals without the speed feature.
        speeds: (A, C, T) the plans' speeds [m/s].
        v_ref: (V,) the traffic speeds [m/s].
        weight: the speed feature's weight per planner step.
        rows: (L,) each hypothesis' row of base.
    """
    out = np.empty((1, len(rows), len(v_ref), base.shape[1]))
    _speed_q_values_into(base, speeds, v_ref, weight, rows, out, np.int64(0))
    return out[0]


_NODES = types.UniTuple(_array(3), 3)


@numba.njit((_NODES, _NODES, _array(1), _F8, _array(1, _I8)), **_JIT)
def node_speed_q_values(bases, speeds, v_ref, weight, rows):
    """`speed_q_values` of three evaluations (the speed nodes of a human's speed): (3, L, V, A).

    Args:
        bases: three (K, A, C) totals without the speed feature, one per node.
        speeds: the three evaluations' (A, C, T) plan speeds [m/s].
        v_ref: (V,) the traffic speeds [m/s].
        weight: the speed feature's weight per planner step.
        rows: (L,) each hypothesis' row of the bases.
    """
    out = np.empty((3, len(rows), len(v_ref), bases[0].shape[1]))
    _speed_q_values_into(bases[0], speeds[0], v_ref, weight, rows, out, np.int64(0))
    _speed_q_values_into(bases[1], speeds[1], v_ref, weight, rows, out, np.int64(1))
    _speed_q_values_into(bases[2], speeds[2], v_ref, weight, rows, out, np.int64(2))
    return out


@numba.njit((_array(1), _array(1), _F8, _array(1, _B1), _array(1, _I8), _I8, _F8, _F8), **_JIT)
def view_mask(dist, bearing, heading, candidates, ids, exclude_id, range_m, half_fov_rad):
    """(N,) bool: the candidates inside a view, other than the object exclude_id.

    human_scene.HumanScenes' view test after np.hypot and np.arctan2: dist <= range_m and
    |wrap(bearing - heading)| <= half_fov_rad (the wrap with np.remainder's arithmetic).

    Args:
        dist: (N,) distances from the viewer [m].
        bearing: (N,) np.arctan2 of the relative positions [rad].
        heading: the viewer's heading [rad].
        candidates: (N,) bool, the objects that may be kept.
        ids: (n <= N,) the object ids of the first n rows (the others have none).
        exclude_id: the id left out (the viewer's own).
        range_m: the view's range [m].
        half_fov_rad: its half-angle [rad].
    """
    n = len(dist)
    keep = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        if not candidates[i] or (i < len(ids) and ids[i] == exclude_id):
            continue
        keep[i] = dist[i] <= range_m and abs(_wrapped(bearing[i] - heading)) <= half_fov_rad
    return keep


@numba.njit((_array(1), _array(1, _B1), _array(1, _B1), _F8, _F8, _F8, _F8), **_JIT)
def own_likelihoods(visible, present, detected, p_detect, p_false_alarm, p_no_false_alarm,
                    probability_min):
    """(L,) own_sensors.OwnSensors.log_likelihood's likelihoods, before np.log.

    miss = min(max(1 - p_detect * visible, probability_min), 1) for the present hypotheses
    (1 for "none"); with a detection p_detect for the matching hypotheses and p_false_alarm
    miss for the others, else p_no_false_alarm miss.
    """
    n = len(visible)
    any_detected = False
    for i in range(n):
        any_detected = any_detected or detected[i]
    out = np.empty(n)
    for i in range(n):
        miss = min(max(1.0 - p_detect * visible[i], probability_min), 1.0) if present[i] else 1.0
        if not any_detected:
            out[i] = p_no_false_alarm * miss
        else:
            out[i] = p_detect if detected[i] else p_false_alarm * miss
    return out


@numba.njit((_array(2), _array(2)), **_JIT)
def route_projections(xy, segments):
    """Route.project of points (n, 2) [m]: arc length (n,) [m], lateral (n,) [m], segment (n,).

    Route._project's arithmetic: each segment's foot point clamped to it, x - (start + t dir)
    squared, the first closest segment (np.argmin; the only one for a single segment); for
    finite points (the closest of a NaN distance is not np.argmin's).

    Args:
        xy: (n, 2) the points [m].
        segments: (S, 6) the route's segments: start x, y [m], unit direction x, y, length [m],
            arc length at the start [m].
    """
    n = len(xy)
    s_out = np.empty(n)
    lateral_out = np.empty(n)
    k_out = np.zeros(n, dtype=np.int64)
    for i in range(n):
        x, y = xy[i, 0], xy[i, 1]
        best_d2 = np.inf
        for k in range(len(segments)):
            sx, sy, dx, dy = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
            rx, ry = x - sx, y - sy
            t = min(max(rx * dx + ry * dy, 0.0), segments[k, 4])
            ex, ey = x - (sx + t * dx), y - (sy + t * dy)
            d2 = ex * ex + ey * ey
            if k == 0 or d2 < best_d2:
                best_d2 = d2
                s_out[i] = segments[k, 5] + t
                lateral_out[i] = dx * ry - dy * rx
                k_out[i] = k
    return s_out, lateral_out, k_out


@numba.njit((_array(1), _array(1), _array(1), _array(1), _array(2), _F8, _B1), **_JIT)
def path_matches(along, lateral, v_along, v_floor, bounds, v_min, vehicle):
    """(H,) bool: own_sensors._PathGroup.matches after its coordinates, the same comparisons.

    Seen agent j (of n) is in hypothesis k's bin if |lateral_j| <= b0_k, b1_k <= along_j <= b2_k
    and, for a vehicle, v_along_j >= v_floor_j, b3_k <= v_along_j < b4_k; for a pedestrian,
    b3_k <= along_j <= b4_k and v_along_j > -v_min, or v_along_j >= v_min.

    Args:
        along: (n,) coordinate along the path [m].
        lateral: (n,) coordinate across it [m].
        v_along: (n,) speed along the path [m/s].
        v_floor: (n,) its floor [m/s] (vehicles only).
        bounds: (5, H) each hypothesis' bounds [m] or [m/s] (`_PathGroup.bounds`).
        v_min: the pedestrians' walking speed threshold [m/s].
        vehicle: the path's kind.
    """
    n_h, n = bounds.shape[1], len(along)
    out = np.zeros(n_h, dtype=np.bool_)
    for k in range(n_h):
        for j in range(n):
            a, v = along[j], v_along[j]
            if not (abs(lateral[j]) <= bounds[0, k] and a >= bounds[1, k] and a <= bounds[2, k]):
                continue
            if vehicle:
                hit = v >= v_floor[j] and v >= bounds[3, k] and v < bounds[4, k]
            else:
                hit = (a >= bounds[3, k] and a <= bounds[4, k] and v > -v_min) or v >= v_min
            if hit:
                out[k] = True
                break
    return out

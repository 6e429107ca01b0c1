"""Compiled (numba) geometry of the belief: what the robot's and a human's views hold.

The robot's own view of every hypothesis (`visible_counts`, `own_likelihoods`), a human's
assumed view (`view_mask`), and points projected on the map's lanes and a hidden agent's
paths (`lane_projections`, `route_projections`, `path_matches`). The same rules as
belief_kernels.py: numpy's arithmetic in its order (np.arctan2 and np.hypot stay in numpy),
one signature each, `cache=True`, a compiled function calls only compiled functions of this
file; every kernel reproduces its numpy reference bit for bit
(tests/perception/test_belief_kernels.py). Imported at the first update (`compiled.view`).
"""

from __future__ import annotations

import numba
import numpy as np
from numba import types

_F8 = types.float64
_I8 = types.int64
_B1 = types.boolean
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


def _array(ndim: int, dtype=_F8):
    """The numba type of a read-only C-contiguous array (a writable one converts to it)."""
    return types.Array(dtype, ndim, "C", readonly=True)


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

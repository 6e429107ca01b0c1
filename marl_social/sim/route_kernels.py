"""Route.project's arithmetic on a route of several segments, and the lane test, compiled by numba.

sim/road_map.py imports this module at the first projection on such a route (numba is not
imported with `import marl_social`). Per point, the same operations in the same order as the
numpy formulation it replaces (tests/sim/test_route_kernels.py keeps it, and checks the two
agree bit for bit): for each segment j the foot point's parameter t = rel_x dx + rel_y dy
(rel = the point minus the segment's start) clamped to [0, length_j], the squared distance
ex^2 + ey^2 with ex = x - (sx + t dx); the first segment of the smallest (numpy's argmin: the
first NaN if there is one) gives the arc length cum_s[k] + t and the signed lateral offset
dx_k rel_y - dy_k rel_x. `on_lanes` tests objects against lanes with it (sim/route_rules.py,
tests/sim/test_route_kernels.py). No fast-math (no contraction into fused multiply-adds), no threads:
each value gets numpy's bits. Compiled once, cached in __pycache__ (cache=True).

`project_footprints` projects the corners of predicted footprints on a route and takes their
extents (the robot's corridor test, agents/robot/corridor.py; its numpy formulation is kept in
tests/sim/test_route_kernels.py). The corridor's other kernels and the MPC's bounds are robot
planning, in agents/robot/corridor_kernels.py.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def _project_one(xi, yi, segments, first, end):
    """The projection of one point on segments[:, first:end] (module docstring).

    Returns:
        its arc length [m], its signed lateral offset [m] and the segment's column in segments.
    """
    start_x, start_y, dir_x, dir_y = segments[0], segments[1], segments[2], segments[3]
    seg_len, cum_s = segments[4], segments[5]
    best, best_d2, best_t, best_rx, best_ry = first, 0.0, 0.0, 0.0, 0.0
    for j in range(first, end):
        rx = xi - start_x[j]
        ry = yi - start_y[j]
        t = rx * dir_x[j] + ry * dir_y[j]
        if t < 0.0:  # noqa: PLR1730 - np.maximum(t, 0.0): NaN stays (max() would drop it)
            t = 0.0
        if t > seg_len[j]:  # noqa: PLR1730 - np.minimum(t, length), NaN stays
            t = seg_len[j]
        ex = xi - (start_x[j] + t * dir_x[j])
        ey = yi - (start_y[j] + t * dir_y[j])
        d2 = ex * ex + ey * ey
        nan = math.isnan(d2)
        if j == first or d2 < best_d2 or nan:
            best, best_d2, best_t, best_rx, best_ry = j, d2, t, rx, ry
            if nan:  # argmin stops at the first NaN
                break
    return (cum_s[best] + best_t, dir_x[best] * best_ry - dir_y[best] * best_rx, best)


@numba.njit(cache=True)
def project_points(x, y, segments, out, k_out):
    """Project points on a polyline of S >= 1 segments.

    Args:
        x: (P,) the points' x [m].
        y: (P,) their y [m].
        segments: (6, S) per segment: start x, start y [m], unit direction x, y, length [m],
            arc length at its start [m].
        out: (2, P) out: arc length of the closest point [m], and the signed lateral offset,
            positive to the left of travel [m].
        k_out: (P,) out: the closest point's segment.
    """
    for i in range(x.shape[0]):
        out[0, i], out[1, i], k_out[i] = _project_one(x[i], y[i], segments, 0,
                                                       segments.shape[1])


@numba.njit(cache=True)
def on_lanes(x, y, heading, segments, lanes, tolerance_rad, out):
    """route_rules.on_lanes' test of each object on each lane, the numpy arithmetic's bits.

    On lane l (the segment columns lanes[0, l - 1] (0 for l = 0) to lanes[0, l] of
    segments): its arc length s strictly within (0, lanes[1, l]), |lateral| <= lanes[2, l]
    and |(heading - segment heading + pi) mod 2 pi - pi| <= tolerance_rad (np.remainder's
    floored modulo, as Python's %).

    Args:
        x: (M,) the objects' centre x [m].
        y: (M,) their centre y [m].
        heading: (M,) their headings [rad].
        segments: (7, S) the lanes' centreline segments, lane after lane: project_points'
            six rows, then the segments' headings [rad].
        lanes: (3, N) per lane the end column of its segments (a whole number), its
            centreline's length [m] and half its width plus the lateral margin [m].
        tolerance_rad: the heading tolerance [rad].
        out: (M,) bool, out: on any of the lanes.
    """
    seg_heading = segments[6]
    for i in range(x.shape[0]):
        found = False
        first = 0
        for lane in range(lanes.shape[1]):
            end = int(lanes[0, lane])
            s, lateral, k = _project_one(x[i], y[i], segments, first, end)
            first = end
            dpsi = abs((heading[i] - seg_heading[k] + np.pi) % (2 * np.pi) - np.pi)
            if (s > 0.0 and s < lanes[1, lane] and abs(lateral) <= lanes[2, lane]
                    and dpsi <= tolerance_rad):
                found = True
        out[i] = found


@numba.njit(cache=True)
def project_footprints(xy, cos_h, sin_h, length_m, width_m, source, segments, out):
    """The extent along and across a route of rectangles, in one pass (agents/robot/corridor.py).

    Rectangle (p, n) is object m of hypothesis l (l, m = source[:, p]) at step n: centre
    xy[l, m, n], heading with cosine cos_h[p, n] and sine sin_h[p, n] (numpy's, given), half
    length 0.5 length_m[l, m] and half width 0.5 width_m[l, m]. Its corners, in the order and
    with the arithmetic of corridor._corners' numpy (front left, front right, rear right,
    rear left: centre + (l c - w s, l s + w c), ...), are projected like `project_points`.

    Args:
        xy: (L, M, N, 2) centres [m].
        cos_h: (P, N) cosines of the projected pairs' headings.
        sin_h: (P, N) their sines.
        length_m: (L, M) lengths [m].
        width_m: (L, M) widths [m].
        source: (2, >= P) int64, the hypothesis and the object of each projected pair.
        segments: (6, S) the route's segments (project_points').
        out: (5, P, N) out: the corners' smallest and largest arc length [m], smallest and
            largest lateral offset [m], and |mean lateral offset| (((l0 + l1) + l2) + l3) / 4
            [m].
    """
    n_seg = segments.shape[1]
    for p in range(cos_h.shape[0]):
        hyp, obj = source[0, p], source[1, p]
        hl = 0.5 * length_m[hyp, obj]
        hw = 0.5 * width_m[hyp, obj]
        for n in range(cos_h.shape[1]):
            c = cos_h[p, n]
            s = sin_h[p, n]
            lc, ls, wc, ws = hl * c, hl * s, hw * c, hw * s
            xc, yc = xy[hyp, obj, n, 0], xy[hyp, obj, n, 1]
            s0, l0, _ = _project_one(xc + (lc - ws), yc + (ls + wc), segments, 0, n_seg)
            s1, l1, _ = _project_one(xc + (lc + ws), yc + (ls - wc), segments, 0, n_seg)
            s2, l2, _ = _project_one(xc + (ws - lc), yc + (-ls - wc), segments, 0, n_seg)
            s3, l3, _ = _project_one(xc + (-lc - ws), yc + (wc - ls), segments, 0, n_seg)
            out[0, p, n] = min(min(min(s0, s1), s2), s3)
            out[1, p, n] = max(max(max(s0, s1), s2), s3)
            out[2, p, n] = min(min(min(l0, l1), l2), l3)
            out[3, p, n] = max(max(max(l0, l1), l2), l3)
            out[4, p, n] = abs((((l0 + l1) + l2) + l3) / 4.0)


@numba.njit(cache=True)
def _nan_max(a, b):
    """np.maximum(a, b) of two floats: NaN if either is NaN, b on a tie (-0.0 vs 0.0 gives b).

    Each kernel file keeps its own twin (numba's cache notices edits in a kernel's own file).
    """
    return a if (a > b or math.isnan(a)) else b


@numba.njit(cache=True)
def _nan_min(a, b):
    """np.minimum(a, b) of two floats: NaN if either is NaN, b on a tie."""
    return a if (a < b or math.isnan(a)) else b


@numba.njit(cache=True)
def project_on_own_routes(xy, seg_start, seg_dir, seg_len, cum_s, valid, all_valid):
    """RouteSet.project: each agent's arc length and lateral offset on its own route.

    Per agent i and segment j, the numpy formulation's values (tests/sim/test_route_kernels.py):
    rel = xy_i - start_ij, its dot product with the direction as np.einsum sums it,
    (0.0 + rel_x dir_x) + rel_y dir_y, t = np.minimum(np.maximum(dot, 0.0), length_ij), the
    squared distance (x - (start_x + t dir_x))^2 + (y - (start_y + t dir_y))^2 (inf for a
    padding segment when not all_valid); the first segment k of the smallest (numpy's argmin:
    the first NaN) gives s = cum_s_ik + t_ik and lateral = dir_x rel_y - dir_y rel_x.

    Args:
        xy: (n, 2) agent positions [m].
        seg_start: (n, S, 2) segment starts [m].
        seg_dir: (n, S, 2) unit directions.
        seg_len: (n, S) segment lengths [m].
        cum_s: (n, S) arc length at each segment's start [m].
        valid: (n, S) bool, real segments (the others pad shorter routes).
        all_valid: whether every segment is real.

    Returns:
        s (n,) [m] and lateral (n,) [m].
    """
    n, n_seg = seg_len.shape
    s_out = np.empty(n)
    lateral = np.empty(n)
    for i in range(n):
        x, y = xy[i, 0], xy[i, 1]
        best, best_d2, best_t, best_rx, best_ry = 0, 0.0, 0.0, 0.0, 0.0
        for j in range(n_seg):
            rx = x - seg_start[i, j, 0]
            ry = y - seg_start[i, j, 1]
            dx, dy = seg_dir[i, j, 0], seg_dir[i, j, 1]
            t = _nan_min(_nan_max((0.0 + rx * dx) + ry * dy, 0.0), seg_len[i, j])
            ex = x - (seg_start[i, j, 0] + t * dx)
            ey = y - (seg_start[i, j, 1] + t * dy)
            d2 = ex * ex + ey * ey
            if not all_valid and not valid[i, j]:
                d2 = np.inf
            nan = math.isnan(d2)
            if j == 0 or d2 < best_d2 or nan:
                best, best_d2, best_t, best_rx, best_ry = j, d2, t, rx, ry
                if nan:  # argmin stops at the first NaN
                    break
        s_out[i] = cum_s[i, best] + best_t
        lateral[i] = seg_dir[i, best, 0] * best_ry - seg_dir[i, best, 1] * best_rx
    return s_out, lateral

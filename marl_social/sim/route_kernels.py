"""Route.project's arithmetic on a route of several segments, compiled by numba.

sim/road_map.py imports this module at the first projection on such a route (numba is not
imported with `import marl_social`). Per point, the same operations in the same order as the
numpy formulation it replaces (tests/sim/test_route_kernels.py keeps it, and checks the two
agree bit for bit): for each segment j the foot point's parameter t = rel_x dx + rel_y dy
(rel = the point minus the segment's start) clamped to [0, length_j], the squared distance
ex^2 + ey^2 with ex = x - (sx + t dx); the first segment of the smallest (numpy's argmin: the
first NaN if there is one) gives the arc length cum_s[k] + t and the signed lateral offset
dx_k rel_y - dy_k rel_x. No fast-math (no contraction into fused multiply-adds), no threads:
each value gets numpy's bits. Compiled once, cached in __pycache__ (cache=True).
"""

from __future__ import annotations

import math

import numba


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
    start_x, start_y, dir_x, dir_y = segments[0], segments[1], segments[2], segments[3]
    seg_len, cum_s = segments[4], segments[5]
    n_seg = segments.shape[1]
    for i in range(x.shape[0]):
        xi, yi = x[i], y[i]
        best, best_d2, best_t, best_rx, best_ry = 0, 0.0, 0.0, 0.0, 0.0
        for j in range(n_seg):
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
            if j == 0 or d2 < best_d2 or nan:
                best, best_d2, best_t, best_rx, best_ry = j, d2, t, rx, ry
                if nan:  # argmin stops at the first NaN
                    break
        out[0, i] = cum_s[best] + best_t
        out[1, i] = dir_x[best] * best_ry - dir_y[best] * best_rx
        k_out[i] = best

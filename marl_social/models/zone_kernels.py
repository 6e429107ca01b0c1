"""The conflict-zone claims of predicted objects, compiled by numba.

`models/gap_evaluation._zone_claims` (candidates.zone_claims, bit for bit: tests/models/
test_gap_evaluation.py) asks, per claimant with the right of way, how deep its covering
circles reach into a conflict zone at each step and the next few (the time margin). The same
IEEE operations in the same order as the numpy reference; the minima and maxima propagate NaN
as np.minimum / np.maximum do; np.tanh stays in numpy. A separate job from the ego's plan
evaluation (models/gap_kernels.py): its kernels call only the two helpers below, twins of
gap_kernels' kept in this file on purpose (numba's cache of a kernel notices edits of its own
file only). Loaded with the planners' kernels (models/kernel_loading.py), `cache=True`.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

_F8 = types.float64
_I8 = types.int64
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


def _array(ndim: int):
    """A read-only C-contiguous float64 array type of ndim dimensions."""
    return types.Array(_F8, ndim, "C", readonly=True)


@numba.njit(cache=True)
def _nan_min(a, b):
    """np.minimum(a, b) of two floats: the smaller, NaN if either is NaN (gap_kernels')."""
    return b if (b < a or math.isnan(b)) else a


@numba.njit(cache=True)
def _nan_max(a, b):
    """np.maximum(a, b) of two floats: the larger, NaN if either is NaN (gap_kernels')."""
    return b if (b > a or math.isnan(b)) else a


_PREDICTED = types.Tuple((_array(3), _array(2), _array(2)))  # xy, cos and sin of the heading
_CIRCLES = types.UniTuple(_array(2), 2)  # along, radius


@numba.njit((_PREDICTED, _CIRCLES, _F8, _I8, _array(2), _F8), **_JIT)
def zone_claim_arguments(predicted, circles, dt_s, n_offsets, edges, softness_m):
    """The arguments of np.tanh of candidates.zone_claims' occupancies, per time offset.

    As zone_claims computes them: each object's velocity is np.gradient's of its positions
    (zero for one step), its position offset j dt_s ahead at that velocity (j < n_offsets),
    its covering circles placed along its heading, and the zone's occupancy argument 0.5 depth /
    softness with depth the largest over the circles of the smallest signed distance inside
    the zone's edges plus the circle's radius (occupancy_arguments' zone rows).

    Args:
        predicted: the P claimants' (xy (P, T, 2) predicted positions [m], cos_heading (P, T)
            and sin_heading (P, T) np.cos and np.sin of their predicted headings).
        circles: their covering circles (along (P, C) footprint.circle_layout's offsets along
            the heading [m], radius (P, C) the circles' radii [m]).
        dt_s: the planner step [s].
        n_offsets: J, the offsets 0, dt_s, ..., (J - 1) dt_s.
        edges: (V, 5) the zone's edges (sim/costs._polygon_edges): start x, y, vector x, y,
            length [m].
        softness_m: sim/costs.OCCUPANCY_SOFTNESS_M [m].

    Returns:
        (J, P, T) 0.5 depth / softness.
    """
    xy, cos_heading, sin_heading = predicted
    along, radius = circles
    n_plans, n_t = cos_heading.shape
    out = np.empty((n_offsets, n_plans, n_t))
    for p in range(n_plans):
        for t in range(n_t):
            vx = vy = 0.0
            if n_t > 1:
                if t == 0:
                    vx = (xy[p, 1, 0] - xy[p, 0, 0]) / dt_s
                    vy = (xy[p, 1, 1] - xy[p, 0, 1]) / dt_s
                elif t == n_t - 1:
                    vx = (xy[p, t, 0] - xy[p, t - 1, 0]) / dt_s
                    vy = (xy[p, t, 1] - xy[p, t - 1, 1]) / dt_s
                else:
                    vx = (xy[p, t + 1, 0] - xy[p, t - 1, 0]) / (2.0 * dt_s)
                    vy = (xy[p, t + 1, 1] - xy[p, t - 1, 1]) / (2.0 * dt_s)
            for j in range(n_offsets):
                offset = j * dt_s
                ahead_x = xy[p, t, 0] + offset * vx
                ahead_y = xy[p, t, 1] + offset * vy
                depth = 0.0
                for k in range(along.shape[1]):
                    x = ahead_x + along[p, k] * cos_heading[p, t]
                    y = ahead_y + along[p, k] * sin_heading[p, t]
                    inside = 0.0
                    for e in range(len(edges)):
                        px, py, ex, ey, length = edges[e]
                        d = (ex * (y - py) - ey * (x - px)) / length
                        inside = _nan_min(inside, d) if e else d
                    depth = _nan_max(depth, inside + radius[p, k]) if k else inside + radius[p, k]
                out[j, p, t] = 0.5 * depth / softness_m
    return out

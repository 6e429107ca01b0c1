"""The contact test's broad phase, compiled by numba.

sim/geometry.py loads this module at the first contact test of a process (numba is not imported
with `import marl_social`). `bounds_may_touch` decides, comparison by comparison, what the numpy
formulation it replaces decides (kept in tests/sim/test_geometry_kernels.py, which checks the
two agree). No fast-math, no threads. Compiled once, cached in __pycache__ (cache=True).
"""

from __future__ import annotations

import math

import numba
from numba import types

_F8 = types.float64
_B1 = types.boolean


def _array(ndim: int, dtype=_F8, layout: str = "C"):
    """The numba type of a read-only array (a writable one converts to it)."""
    return types.Array(dtype, ndim, layout, readonly=True)


@numba.njit(cache=True)
def _nan_max(a, b):
    """np.maximum(a, b) of two floats: the larger, NaN if either is NaN."""
    return a if (a > b or math.isnan(a)) else b


@numba.njit([_B1(_array(2, layout="A"), _array(2), _array(2, _B1), _array(2), _array(2),
                 _array(1))], cache=True, nogil=True, error_model="numpy")
def bounds_may_touch(xy, reach2, pairs, static_min, static_max, radius2):
    """Whether two agents' bounding circles, or one and a static box, overlap.

    Args:
        xy: (n, 2) agent centres [m].
        reach2: (n, n) squared sums of the agents' bounding radii [m^2].
        pairs: (n, n) bool, the pairs that count (both active, not the same agent).
        static_min: (S, 2) the static boxes' lower corners [m].
        static_max: (S, 2) their upper corners [m].
        radius2: (n,) squared bounding radii, -1 for an inactive agent [m^2].

    Returns:
        some pair with dx^2 + dy^2 <= reach2 (dx = x_i - x_j), or some agent with the box gap
        max(max(min - xy, xy - max), 0) squared and summed <= radius2.
    """
    n = xy.shape[0]
    for i in range(n):
        for j in range(n):
            if pairs[i, j]:
                dx = xy[i, 0] - xy[j, 0]
                dy = xy[i, 1] - xy[j, 1]
                if dx * dx + dy * dy <= reach2[i, j]:
                    return True
    for i in range(n):
        for k in range(static_min.shape[0]):
            gx = _nan_max(_nan_max(static_min[k, 0] - xy[i, 0], xy[i, 0] - static_max[k, 0]), 0.0)
            gy = _nan_max(_nan_max(static_min[k, 1] - xy[i, 1], xy[i, 1] - static_max[k, 1]), 0.0)
            if gx * gx + gy * gy <= radius2[i]:
                return True
    return False

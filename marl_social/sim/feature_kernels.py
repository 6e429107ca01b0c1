"""The env's per-step cost features of every agent against every other, compiled by numba.

sim/costs.py loads this module at the first `pairwise_step_features` of a process (numba is not
imported with `import marl_social`). Each kernel gives, value by value, what the numpy
formulation in tests/reference/pairwise_features.py gives (tests/sim/test_feature_kernels.py
checks the two agree bit for bit, any number of agents): np.min over the circle pairs, numpy's
maximum tie rule, np.sum's pairwise summation of a row (sim/pairwise_sum.py); np.exp and
np.tanh stay numpy's. No fast-math, no threads. Compiled once, cached in __pycache__
(cache=True).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

from marl_social.sim.pairwise_sum import contiguous_sum

# pairwise_sum.py stamp: e57bd2f618419a3d (tests/sim/test_pairwise_sum.py)

_F8 = types.float64
_B1 = types.boolean
_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


def _array(ndim: int, dtype=_F8):
    """The numba type of a read-only array of any layout (a writable one converts to it)."""
    return types.Array(dtype, ndim, "A", readonly=True)


@numba.njit(cache=True)
def _row_sum(values, mask, i, row):
    """np.sum(np.where(mask[i], values[i], 0.0)) of row i, any length (row: a scratch buffer)."""
    n = values.shape[1]
    for j in range(n):
        row[j] = values[i, j] if mask[i, j] else 0.0
    return contiguous_sum(row, 0, n)


@numba.njit([_F8[:, ::1](_array(3), _array(1))], **_JIT)
def circle_gap_matrix(circles, radius):
    """Gaps between every two agents' covering circles, (n, n) [m].

    max((sqrt(min over circle pairs of dx dx + dy dy) - radius_i) - radius_j, 0.0): np.min
    (NaN if any is NaN), then np.maximum (0.0 on a tie).

    Args:
        circles: (n, C, 2) covering-circle centres [m].
        radius: (n,) each agent's circle radius [m].
    """
    n, n_c = circles.shape[0], circles.shape[1]
    gap = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            nearest = np.inf
            for a in range(n_c):
                for b in range(n_c):
                    dx = circles[i, a, 0] - circles[j, b, 0]
                    dy = circles[i, a, 1] - circles[j, b, 1]
                    d2 = dx * dx + dy * dy
                    if d2 < nearest or math.isnan(d2):
                        nearest = d2
                    if math.isnan(nearest):
                        break
                if math.isnan(nearest):
                    break
            g = (np.sqrt(nearest) - radius[i]) - radius[j]
            gap[i, j] = g if (g > 0.0 or math.isnan(g)) else 0.0
    return gap


@numba.njit([_F8[:, ::1](_array(1), _array(1), _array(1), _array(1), _array(1), _array(2),
                         _array(2, _B1))], **_JIT)
def feature_rows(lateral_m, speed_mps, v_ref_mps, accel_mps2, prev_accel_mps2, safety_exp,
                 other_mask):
    """(n, 6) features but the conflict (column 5 left 0.0).

    lateral^2, (v - v_ref)^2, a^2, (a - a_prev)^2 and the row sums of
    np.where(other_mask, safety_exp, 0.0).

    Args:
        lateral_m: (n,) lateral offsets [m].
        speed_mps: (n,) speeds [m/s].
        v_ref_mps: (n,) reference speeds [m/s].
        accel_mps2: (n,) accelerations [m/s^2].
        prev_accel_mps2: (n,) last step's accelerations [m/s^2].
        safety_exp: (n, n) np.exp(-gap).
        other_mask: (n, n) bool, the others of each agent.
    """
    n = len(lateral_m)
    out = np.zeros((n, 6))
    row = np.empty(safety_exp.shape[1])
    for i in range(n):
        out[i, 0] = lateral_m[i] * lateral_m[i]
        dv = speed_mps[i] - v_ref_mps[i]
        out[i, 1] = dv * dv
        out[i, 2] = accel_mps2[i] * accel_mps2[i]
        da = accel_mps2[i] - prev_accel_mps2[i]
        out[i, 3] = da * da
        out[i, 4] = _row_sum(safety_exp, other_mask, i, row)
    return out


@numba.njit([_F8[::1](_array(1), _array(2, _B1))], **_JIT)
def occupancy_sums(occupancy, pair_mask):
    """(n,) row sums of np.where(pair_mask, occupancy[None, :], 0.0) (np.sum, pairwise).

    Args:
        occupancy: (n,) each agent's occupancy of one crosswalk.
        pair_mask: (n, n) bool, the pairs of the two kinds that count.
    """
    n = len(occupancy)
    values = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            values[i, j] = occupancy[j]
    out = np.empty(n)
    row = np.empty(n)
    for i in range(n):
        out[i] = _row_sum(values, pair_mask, i, row)
    return out

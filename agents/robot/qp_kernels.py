"""The contingency QP's per-step array work around its solver, as compiled loops.

Each MPC solve fills the sparse QP's row bounds (ContingencyQp._bounds, agents/robot/qp.py),
turns them into DAQP's inputs and DAQP's answer back into the sparse QP's accelerations and
slacks (CondensedLayout.solve, agents/robot/condensed_qp.py). In numpy that is ~45 small array
calls per solve (fancy assignments, selections, concatenations, clips), which took several
times DAQP's own time for the common one-branch QP. Here they are three numba loops. The
matrix products (the weighted cost blocks, T'q, T z) stay in numpy: BLAS may sum in another
order than a loop. What is here only assigns, selects, compares, multiplies and subtracts, in
numpy's order, so it gives numpy's bits (tests/agents/test_qp_kernels.py compares it with the
numpy formulation).

Compiled by numba at the first use (cache=True, in this folder's __pycache__; explicit
signatures, so one compilation serves contiguous and broadcast inputs alike);
agents/compile_kernels.py's "tree" part compiles it ahead.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import types

DAQP_INF = 1e30  # DAQP's infinity
NO_BOUND = 1e19  # a bound of the sparse QP beyond this is none (qp.py's infinity is 1e20)

# explicit signatures: inputs as read-only arrays of any layout (a writable or broadcast array
# converts), outputs as new arrays
_IN_F1, _IN_F2 = (types.Array(types.float64, n, "A", readonly=True) for n in (1, 2))
_IN_I1, _IN_I2 = (types.Array(types.int64, n, "A", readonly=True) for n in (1, 2))
_IN_B1 = types.Array(types.boolean, 1, "A", readonly=True)
_F1, _F2, _F8 = types.float64[::1], types.float64[:, ::1], types.float64
_BOUND_ROWS = types.Tuple((_IN_F1, _IN_F1, _IN_I1, _IN_I1, _IN_I2, _IN_I2, _IN_I2, _IN_I1,
                           _IN_I1, _IN_I1))
_SPARSE_BOUNDS = types.Tuple((_F1, _F1, types.boolean))(
    _BOUND_ROWS, _F8, _F8, types.UniTuple(_F8, 2), types.UniTuple(_IN_F2, 3),
    types.UniTuple(_F8, 5))
_CONDENSED_ROWS = types.Tuple((_IN_F2, _IN_F1, _IN_I2, _IN_I1, _IN_I1, _IN_I1, _IN_I1))
_DAQP_INPUTS = types.Tuple((_F2, _F1, _F2, _F1, _F1))(
    _IN_F2, _IN_F1, _F8, _IN_F1, _IN_F1, _CONDENSED_ROWS, _IN_B1)
_FULL_SOLUTION = _F1(_IN_F1, _IN_B1, _IN_F1, _IN_I1)


# _np_minimum / _np_maximum: corridor_kernels.py's twins, kept in this file on purpose: numba's
# cache of a kernel notices edits of its own file only
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


@numba.njit(_SPARSE_BOUNDS, cache=True)
def sparse_bounds(bound_rows, v0, prev_accel, steps, plan_bounds, limits):
    """The sparse QP's row bounds for one solve, and whether some lower bound exceeds its upper.

    Rows as ContingencyQp._build_constraints numbers them (agents/robot/qp.py): the first
    step's dynamics rows take v0 and v0 dt_s; speed rows 0 .. v_max; pass-before rows
    max(s_low, -infinity) .. template; stay-behind rows template .. min(s_up, infinity); jerk
    rows +-jerk_max dt_s, the first prev_accel -+ jerk_max first_dt_s; acceleration rows
    accel_min .. accel_max; comfort rows comfort_lower .. template (np.maximum / np.minimum:
    NaN propagates). Infeasible: some lower > upper + 1e-9.

    Args:
        bound_rows: the QP layout's rows, fixed between solves: (lower_template (m,) and
            upper_template (m,) the bounds that do not change, first_dyn_v (L,) and
            first_dyn_s (L,) the first step's speed and progress dynamics row per branch,
            speed_rows, low_rows (pass-before) and up_rows (stay-behind), (L, N) each,
            jerk_rows (J,) (the first against the previous command), accel_rows (n_a,) and
            comfort_rows (n_a,), one per acceleration variable).
        v0: current speed [m/s].
        prev_accel: the previous command [m/s^2].
        steps: (dt_s the plan step, first_dt_s the time of the first change from the previous
            command) [s].
        plan_bounds: (v_max speed bounds [m/s], s_low lower progress bounds [m], s_up upper
            progress bounds (+ headway x speed) [m]), (L, N) each.
        limits: (accel_min the most negative acceleration [m/s^2], accel_max the largest
            [m/s^2], jerk_max the largest |jerk| [m/s^3], comfort_lower -comfortable
            deceleration [m/s^2] (-infinity: none), infinity the QP's infinity (qp.py's _INF)).

    Returns:
        lower (m,), upper (m,), infeasible.
    """
    (lower_template, upper_template, first_dyn_v, first_dyn_s, speed_rows, low_rows, up_rows,
     jerk_rows, accel_rows, comfort_rows) = bound_rows
    dt_s, first_dt_s = steps
    v_max, s_low, s_up = plan_bounds
    accel_min, accel_max, jerk_max, comfort_lower, infinity = limits
    lower = lower_template.copy()
    upper = upper_template.copy()
    for l in range(len(first_dyn_v)):
        lower[first_dyn_v[l]] = v0
        upper[first_dyn_v[l]] = v0
        travel = v0 * dt_s
        lower[first_dyn_s[l]] = travel
        upper[first_dyn_s[l]] = travel
    n_branches, n_steps = speed_rows.shape
    for l in range(n_branches):
        for k in range(n_steps):
            lower[speed_rows[l, k]] = 0.0
            upper[speed_rows[l, k]] = v_max[l, k]
        for k in range(n_steps):
            lower[low_rows[l, k]] = _np_maximum(s_low[l, k], -infinity)
        for k in range(n_steps):
            upper[up_rows[l, k]] = _np_minimum(s_up[l, k], infinity)
    jerk_low, jerk_up = -jerk_max * dt_s, jerk_max * dt_s
    for j in range(len(jerk_rows)):
        lower[jerk_rows[j]] = jerk_low
        upper[jerk_rows[j]] = jerk_up
    lower[jerk_rows[0]] = prev_accel - jerk_max * first_dt_s
    upper[jerk_rows[0]] = prev_accel + jerk_max * first_dt_s
    for j in range(len(accel_rows)):
        lower[accel_rows[j]] = accel_min
        upper[accel_rows[j]] = accel_max
    for j in range(len(comfort_rows)):
        lower[comfort_rows[j]] = comfort_lower
    infeasible = False
    for i in range(len(lower)):
        if lower[i] > upper[i] + 1e-9:
            infeasible = True
    return lower, upper, infeasible


@numba.njit(_DAQP_INPUTS, cache=True)
def daqp_inputs(h_full, f_full, v0, lower, upper, condensed_rows, free):
    """DAQP's H, f, A, upper and lower bounds of the free variables and the bounded rows.

    The condensed rows' bounds are the sparse QP's (a trunk step's row: the tightest of its
    L copies, np.max / np.min with NaN propagating) shifted by v0 m_v0; a comfort row of a
    fixed slack (the last n_a rows, `free` False) has no lower bound; a row with neither bound
    (beyond +-NO_BOUND) is left out. The simple bounds come first: the accelerations' (the
    sparse QP's acceleration rows), then the free slacks' (0 .. DAQP_INF); every bound is
    clipped to +-DAQP_INF.

    Args:
        h_full: (nz, nz) the condensed Hessian, nz = 2 n_a (accelerations, slacks).
        f_full: (nz,) its linear cost.
        v0: the current speed [m/s].
        lower: (m,) the sparse QP's lower bounds.
        upper: (m,) its upper bounds.
        condensed_rows: the condensed layout's rows, fixed between solves: (m_matrix (G, nz)
            the condensed rows, m_v0 (G,) their shift per unit v0, trunk_rows (L, K) the sparse
            rows of the trunk steps' condensed rows per branch, trunk_pos (K,) their condensed
            rows, single_rows (S,) the sparse rows of the other condensed rows, single_pos (S,)
            their condensed rows, accel_rows (n_a,) the sparse QP's acceleration rows).
        free: (nz,) bool, the variables DAQP solves for (a slack of weight 0 is fixed at 0).

    Returns:
        h (F, F), f (F,), a (R, F), b_upper (F + R,), b_lower (F + R,): F free variables, R
        bounded rows.
    """
    m_matrix, m_v0, trunk_rows, trunk_pos, single_rows, single_pos, accel_rows = condensed_rows
    nz = len(free)
    n_a = nz // 2
    n_general = len(m_v0)
    lo = np.empty(n_general)
    up = np.empty(n_general)
    for k in range(len(trunk_pos)):
        low, high = lower[trunk_rows[0, k]], upper[trunk_rows[0, k]]
        for b in range(1, trunk_rows.shape[0]):
            low = _np_maximum(low, lower[trunk_rows[b, k]])
            high = _np_minimum(high, upper[trunk_rows[b, k]])
        lo[trunk_pos[k]] = low
        up[trunk_pos[k]] = high
    for k in range(len(single_pos)):
        lo[single_pos[k]] = lower[single_rows[k]]
        up[single_pos[k]] = upper[single_rows[k]]
    for g in range(n_general):
        shift = v0 * m_v0[g]
        lo[g] = lo[g] - shift
        up[g] = up[g] - shift
    comfort_start = n_general - n_a
    for j in range(n_a):
        if not free[n_a + j]:
            lo[comfort_start + j] = -DAQP_INF
    kept = np.flatnonzero(free)
    n_free = len(kept)
    rows = np.flatnonzero((lo > -NO_BOUND) | (up < NO_BOUND))
    n_rows = len(rows)
    h = np.empty((n_free, n_free))
    f = np.empty(n_free)
    a = np.empty((n_rows, n_free))
    for i in range(n_free):
        f[i] = f_full[kept[i]]
        for j in range(n_free):
            h[i, j] = h_full[kept[i], kept[j]]
    for r in range(n_rows):
        for j in range(n_free):
            a[r, j] = m_matrix[rows[r], kept[j]]
    b_lower = np.empty(n_free + n_rows)
    b_upper = np.empty(n_free + n_rows)
    for i in range(n_free):
        var = kept[i]
        if var < n_a:
            low, high = lower[accel_rows[var]], upper[accel_rows[var]]
        else:
            low, high = 0.0, DAQP_INF
        b_lower[i] = _np_maximum(low, -DAQP_INF)
        b_upper[i] = _np_minimum(high, DAQP_INF)
    for r in range(n_rows):
        b_lower[n_free + r] = _np_maximum(lo[rows[r]], -DAQP_INF)
        b_upper[n_free + r] = _np_minimum(up[rows[r]], DAQP_INF)
    return h, f, a, b_upper, b_lower


@numba.njit(_FULL_SOLUTION, cache=True)
def full_solution(z_free, free, lower, slack_rows):
    """(nz,) z = (a, c) from DAQP's free variables.

    A fixed slack takes the braking beyond the comfortable deceleration, max(0, the comfort
    row's lower bound - a).

    Args:
        z_free: (F,) DAQP's solution.
        free: (nz,) bool, its variables.
        lower: (m,) the sparse QP's lower bounds.
        slack_rows: (n_a,) its comfort rows (a + c >= -comfort deceleration).
    """
    nz = len(free)
    n_a = nz // 2
    z = np.zeros(nz)
    k = 0
    for i in range(nz):
        if free[i]:
            z[i] = z_free[k]
            k += 1
    for j in range(n_a):
        if not free[n_a + j]:
            z[n_a + j] = _np_maximum(0.0, lower[slack_rows[j]] - z[j])
    return z

"""The condensed QP's compiled assembly (qp_kernels.py) against its numpy formulation, bit
for bit: DAQP's inputs from the sparse QP's bounds, and the full solution from DAQP's."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from marl_social.agents.robot.condensed_qp import CondensedLayout, qp_kernels
from marl_social.agents.robot.qp_kernels import DAQP_INF, NO_BOUND
from marl_social.agents.robot.qp_types import QpInstance
from tests.agents.test_condensed_qp import N, _captured, _qp


def _numpy_bounds(problem, v0, prev_accel, v_max, s_low, s_up, accel_min, accel_max, jerk_max,
                  comfort_decel):
    """ContingencyQp._bounds before the kernel: (lower, upper, infeasible)."""
    r, dt, inf = problem._rows, problem.dt_s, 1e20
    lower, upper = problem._lower_template.copy(), problem._upper_template.copy()
    lower[r["dyn_v"][:, 0]] = upper[r["dyn_v"][:, 0]] = v0
    lower[r["dyn_s"][:, 0]] = upper[r["dyn_s"][:, 0]] = v0 * dt
    lower[r["speed"]], upper[r["speed"]] = 0.0, v_max
    lower[r["low"]] = np.maximum(s_low, -inf)
    upper[r["up"]] = np.minimum(s_up, inf)
    jerk = r["jerk"]
    lower[jerk], upper[jerk] = -jerk_max * dt, jerk_max * dt
    lower[jerk[0]] = prev_accel - jerk_max * problem.first_dt_s
    upper[jerk[0]] = prev_accel + jerk_max * problem.first_dt_s
    lower[r["accel"]], upper[r["accel"]] = accel_min, accel_max
    lower[r["comfort"]] = -inf if comfort_decel is None else -comfort_decel
    return lower, upper, bool(np.any(lower > upper + 1e-9))


def _same_bounds(problem, *args) -> bool:
    """`args`: v0, prev_accel, v_max, s_low, s_up, accel_min, accel_max, jerk_max, comfort."""
    fields = dict(zip(("v0", "prev_accel", "v_max", "s_low", "s_up", "accel_min", "accel_max",
                       "jerk_max", "comfort_decel"), args, strict=True))
    got = problem._bounds(QpInstance(np.ones(1), v_ref_mps=10.0, **fields))
    want = _numpy_bounds(problem, *args)
    return _same_bits(got[0], want[0]) and _same_bits(got[1], want[1]) and got[2] == want[2]


def _numpy_inputs(layout, h_full, f_full, lower, upper, v0, free):
    """What condensed_qp.solve handed DAQP before the kernel: (h, f, A, b_upper, b_lower)."""
    n_a = layout.n_accel
    lo = np.empty(layout.n_general)
    up = np.empty(layout.n_general)
    lo[layout._trunk_pos] = lower[layout._trunk_rows].max(axis=0)
    up[layout._trunk_pos] = upper[layout._trunk_rows].min(axis=0)
    lo[layout._single_pos] = lower[layout._single_rows]
    up[layout._single_pos] = upper[layout._single_rows]
    shift = v0 * layout.m_v0
    bl, bu = lo - shift, up - shift
    bl[layout.n_general - n_a:][~free[n_a:]] = -DAQP_INF
    rows = (bl > -NO_BOUND) | (bu < NO_BOUND)
    kept = np.flatnonzero(free)
    h = h_full.take(kept, axis=0).take(kept, axis=1)
    m = layout.m_matrix[rows].take(kept, axis=1)
    z_lower = np.concatenate([lower[layout._accel_rows], np.zeros(n_a)])[free]
    z_upper = np.concatenate([upper[layout._accel_rows], np.full(n_a, DAQP_INF)])[free]
    b_lower = np.maximum(np.concatenate([z_lower, bl[rows]]), -DAQP_INF)
    b_upper = np.minimum(np.concatenate([z_upper, bu[rows]]), DAQP_INF)
    return h, f_full[free], m, b_upper, b_lower


def _numpy_solution(layout, z_free, free, lower):
    n_a = layout.n_accel
    z = np.zeros(2 * n_a)
    z[free] = z_free
    fixed = ~free[n_a:]
    z[n_a:][fixed] = np.maximum(0.0, lower[layout._slack_rows][fixed] - z[:n_a][fixed])
    return z


def _same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def _compare(layout, lower, upper, v0, free, rng, zero_solution=False):
    nz = layout.nz
    h_full, f_full = rng.normal(size=(nz, nz)), rng.normal(size=nz)
    got = qp_kernels().daqp_inputs(h_full, f_full, v0, lower, upper, layout._condensed_rows,
                                   free)
    want = _numpy_inputs(layout, h_full, f_full, lower, upper, v0, free)
    assert all(_same_bits(g, w) for g, w in zip(got, want))
    z_free = (np.where(rng.random(int(free.sum())) < 0.5, 0.0, -0.0) if zero_solution
              else rng.normal(size=int(free.sum())))
    assert _same_bits(qp_kernels().full_solution(z_free, free, lower, layout._slack_rows),
                      _numpy_solution(layout, z_free, free, lower))


@pytest.mark.parametrize("case", range(15))
def test_the_inputs_of_captured_qps_are_numpys(case):
    args = _captured()[case]
    problem = _qp(len(args["weights"]))
    lower, upper, _ = problem._bounds(QpInstance(**args))
    # a 3-branch QP goes to the tree solver (qp.DAQP_MAX_BRANCHES): its condensed layout is
    # built here, the kernels take any
    layout = problem._condensed or CondensedLayout(problem)
    rng = np.random.default_rng(case)
    assert _same_bounds(problem, args["v0"], args["prev_accel"], args["v_max"], args["s_low"],
                        args["s_up"], args["accel_min"], args["accel_max"], args["jerk_max"],
                        args["comfort_decel"])
    for free_slacks in (np.ones(layout.n_accel, bool), rng.random(layout.n_accel) < 0.5):
        _compare(layout, lower, upper, args["v0"], np.concatenate(
            [np.ones(layout.n_accel, bool), free_slacks]), rng)


_BOUND = st.one_of(st.floats(-1e21, 1e21), st.sampled_from([np.inf, -np.inf, np.nan, 0.0, -0.0,
                                                            1e20, -1e20, 1e19, -1e19, 1e31]))


@settings(max_examples=40, deadline=None)
@given(n_branches=st.integers(1, 3), seed=st.integers(0, 2**32 - 1),
       special=st.lists(_BOUND, min_size=8, max_size=8), v0=st.floats(0.0, 30.0))
def test_any_bounds_give_numpys_bits(n_branches, seed, special, v0):
    """Random bounds with infinities, NaN, signed zeros and values around the cut-offs."""
    problem = _qp(n_branches)
    layout = problem._condensed or CondensedLayout(problem)  # 3 branches: the tree solver's
    rng = np.random.default_rng(seed)
    m = problem._a_matrix.shape[0]  # the sparse QP's rows
    lower, upper = rng.normal(scale=10.0, size=m), rng.normal(scale=10.0, size=m)
    for values in (lower, upper):
        values[rng.integers(0, m, size=len(special))] = special
    free = np.concatenate([np.ones(layout.n_accel, bool), rng.random(layout.n_accel) < 0.7])
    _compare(layout, lower, upper, v0, free, rng)


@settings(max_examples=40, deadline=None)
@given(n_branches=st.integers(1, 4), seed=st.integers(0, 2**32 - 1),
       special=st.lists(_BOUND, min_size=6, max_size=6), v0=st.floats(0.0, 30.0),
       prev_accel=st.floats(-8.0, 3.0), comfort=st.sampled_from([None, 2.0, 3.5]))
def test_the_row_bounds_are_numpys(n_branches, seed, special, v0, prev_accel, comfort):
    """Progress bounds with infinities, NaN, signed zeros, beyond the QP's infinity; a speed
    bound broadcast from one row (as the MPC passes it); the infeasible flag."""
    problem = _qp(n_branches)
    rng = np.random.default_rng(seed)
    shape = (n_branches, N)
    s_low, s_up = rng.normal(scale=20.0, size=shape), rng.normal(scale=20.0, size=shape) + 30.0
    for values in (s_low, s_up):
        values.flat[rng.integers(0, values.size, size=len(special))] = special
    v_max = np.broadcast_to(rng.uniform(0.0, 15.0, size=N), shape)
    assert _same_bounds(problem, v0, prev_accel, v_max, s_low, s_up, -8.0, 3.0, 10.0, comfort)


@pytest.mark.parametrize("n_branches", [1, 2, 3])
def test_signed_zero_ties_are_numpys(n_branches):
    """Every bound +0 or -0 at random and v0 = 0: the trunk rows' maxima and minima, the clips
    and the fixed slacks' max(0, lower - a) meet ties of signed zeros; numpy gives the second."""
    problem = _qp(n_branches)
    layout = problem._condensed or CondensedLayout(problem)  # 3 branches: the tree solver's
    rng = np.random.default_rng(n_branches)
    m = problem._a_matrix.shape[0]
    for _ in range(20):
        lower, upper = (np.where(rng.random(m) < 0.5, 0.0, -0.0) for _ in range(2))
        free = np.concatenate([np.ones(layout.n_accel, bool), rng.random(layout.n_accel) < 0.5])
        _compare(layout, lower, upper, 0.0, free, rng, zero_solution=True)
    shape = (n_branches, N)
    zeros = [np.where(rng.random(shape) < 0.5, 0.0, -0.0) for _ in range(3)]
    assert _same_bounds(problem, 0.0, -0.0, *zeros, -8.0, 3.0, 10.0, None)

"""The MPC's QP condensed and solved by DAQP (condensed_qp.py) against OSQP at a tight tolerance."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import osqp
import pytest
import scipy.sparse as sp

from marl_social.agents.robot import qp
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.qp_types import QpInstance, QpWeights
from marl_social.sim.dynamics import DT_S

CONFIG = MpcConfig()
WEIGHTS = QpWeights(CONFIG.w_speed, CONFIG.w_accel, CONFIG.w_jerk, CONFIG.w_comfort)
N = CONFIG.n_steps
DATA = Path(__file__).parent / "data"


def _qp(n_branches: int, use_daqp: bool = True) -> qp.ContingencyQp:
    return qp.ContingencyQp(n_branches, N, CONFIG.n_trunk, CONFIG.plan_dt_s, DT_S, WEIGHTS,
                            CONFIG.headway_s(), use_daqp=use_daqp)


def _captured(file_name: str = "captured_qps.npz") -> list[dict]:
    """Solve arguments captured from the scenarios, by case: in captured_qps.npz 15 (L = 1,
    2, 3; 9 of them QPs OSQP stopped short on: solved inaccurately, or degenerate after
    ROUND_ITER iterations); test_tree_ipm reads captured_tree_qps.npz with it."""
    data = np.load(DATA / file_name)
    cases: dict[int, dict] = {}
    for key in data.files:
        index, name = key.split("__")
        value = data[key]
        if value.ndim == 0:
            value = None if np.isnan(value) else float(value)
        cases.setdefault(int(index), {})[name] = value
    return [cases[i] for i in sorted(cases)]


def _tight(p: sp.csc_matrix, q: np.ndarray, a: sp.csc_matrix, lower: np.ndarray,
           upper: np.ndarray) -> tuple[np.ndarray, float]:
    """OSQP alone at a tight tolerance with all the iterations it needs: (x, objective)."""
    solver = osqp.OSQP()
    solver.setup(p, q, a, np.maximum(lower, -1e30), np.minimum(upper, 1e30), verbose=False,
                 eps_abs=1e-10, eps_rel=1e-10, max_iter=500_000, polishing=True,
                 adaptive_rho_interval=25)
    res = solver.solve(raise_error=False)
    assert res.info.status_val == osqp.SolverStatus.OSQP_SOLVED
    return res.x, float(res.info.obj_val)


def _reference(problem: qp.ContingencyQp, args: dict) -> tuple[np.ndarray, float]:
    lower, upper, _ = problem._bounds(QpInstance(**args))
    p = problem._p_matrix(args["weights"])
    p.data = problem._p_values(args["weights"], args["comfort"], args["goal_weight"])
    q = problem._q_vector(args["weights"], args["v_ref_mps"], args["prev_accel"],
                          args["goal_weight"], args["goal_m"])
    return _tight(p, q, problem._a_matrix, lower, upper)


def _agrees_with_tight_osqp(args: dict):
    """DAQP (beyond DAQP_MAX_BRANCHES branches: the tree solver) answers the QP of `args` with
    OSQP's optimum at 1e-10 (to 1e-6); its cost and whether DAQP answered."""
    problem = _qp(len(args["weights"]))
    sol = problem.solve(QpInstance(**args))
    by_daqp = len(args["weights"]) <= qp.DAQP_MAX_BRANCHES
    assert sol.solved and problem.last_solver == ("daqp" if by_daqp else "tree")
    x, cost = _reference(problem, args)
    assert np.allclose(sol.accel_mps2, x[problem._a_idx], atol=1e-6)
    assert np.allclose(sol.speed_mps, x[problem._v_idx], atol=1e-6)
    assert np.allclose(sol.progress_m, x[problem._s_idx], atol=1e-6)
    assert sol.cost == pytest.approx(cost, abs=1e-6)
    return sol.cost, cost, by_daqp


@pytest.mark.parametrize("case", range(15))
def test_daqp_agrees_with_a_tight_osqp_on_captured_qps(case):
    daqp_cost, osqp_cost, by_daqp = _agrees_with_tight_osqp(_captured()[case])
    if by_daqp:
        assert daqp_cost <= osqp_cost + 1e-8  # exact: not above OSQP's optimum


@pytest.mark.parametrize("case", [0, 7, 13])
def test_daqp_agrees_with_a_tight_osqp_with_the_pull_up_term(case):
    _agrees_with_tight_osqp({**_captured()[case], "goal_weight": CONFIG.w_pull_up,
                             "goal_m": 6.0})


def test_daqp_solves_the_degenerate_qp_osqp_needs_thousands_of_iterations_on():
    """tests/agents/data/degenerate_qp.npz (T-intersection, two branches): its beliefs and
    comfort factors are read back from P's values, which the layout then reproduces."""
    data = np.load(DATA / "degenerate_qp.npz")
    problem = _qp(2)
    p_values, q, lower, upper = data["p_values"], data["q"], data["lower"], data["upper"]
    dt = problem.dt_s
    v_diag = np.flatnonzero((problem._p_rows == problem._p_cols)
                            & np.isin(problem._p_rows, problem._v_idx[:, -1]))
    weights = p_values[v_diag] / (2.0 * WEIGHTS.speed * dt)
    slack = problem._c_idx[:, -1]  # each branch's own last slack
    c_diag = [np.flatnonzero((problem._p_rows == c) & (problem._p_cols == c))[0] for c in slack]
    comfort = p_values[c_diag] / (2.0 * WEIGHTS.comfort * dt * weights)
    assert np.allclose(problem._p_values(weights, comfort), p_values, rtol=1e-12, atol=1e-12)
    v0 = float(lower[problem._rows["dyn_v"][0, 0]])
    x, cost = problem._condensed.solve(weights, comfort, 0.0, q, lower.copy(), upper.copy(), v0)
    n = problem.n_vars
    p = sp.csc_matrix((p_values, (data["p_rows"], data["p_cols"])), shape=(n, n))
    a = sp.csc_matrix((data["a_data"], data["a_indices"], data["a_indptr"]),
                      shape=tuple(data["a_shape"]))
    ax = a @ x
    assert np.all(ax >= lower - 1e-7) and np.all(ax <= upper + 1e-7)
    x_ref, cost_ref = _tight(p, q, a, lower, upper)
    assert np.allclose(x[problem._a_idx], x_ref[problem._a_idx], atol=1e-6)
    assert cost == pytest.approx(cost_ref, abs=1e-6) and cost <= cost_ref + 1e-8


def test_an_infeasible_qp_is_reported_infeasible_by_daqp_and_by_the_fallback():
    """Moving at 10 m/s, a stay-behind bound 0.5 m ahead from the first step on: no plan can
    brake that hard. DAQP finds no optimum, OSQP (the fallback) none either: not solved."""
    args = _captured()[5]  # a two-branch QP
    args = {**args, "v0": 10.0, "s_up": np.full_like(args["s_up"], 0.5)}
    problem = _qp(2)
    lower, upper, _ = problem._bounds(QpInstance(**args))
    q = problem._q_vector(args["weights"], args["v_ref_mps"], args["prev_accel"])
    assert problem._condensed.solve(args["weights"], args["comfort"], 0.0, q, lower, upper,
                                    args["v0"]) is None
    sol = problem.solve(QpInstance(**args))
    assert not sol.solved and problem.last_solver == ""
    assert problem.solver_counts == {"daqp": 0, "tree": 0, "osqp": 0, "": 1}


def test_more_branches_than_daqp_max_go_to_the_tree_solver_and_use_daqp_false_to_osqp():
    args = _captured()[14]  # three branches
    assert _qp(3, use_daqp=False)._condensed is None
    problem = _qp(3, use_daqp=False)
    assert problem.solve(QpInstance(**args)).solved and problem.last_solver == "osqp"
    assert _qp(qp.DAQP_MAX_BRANCHES + 1)._condensed is None
    assert _qp(qp.DAQP_MAX_BRANCHES + 1)._tree is not None
    assert _qp(qp.DAQP_MAX_BRANCHES)._condensed is not None
    assert _qp(qp.DAQP_MAX_BRANCHES)._tree is None

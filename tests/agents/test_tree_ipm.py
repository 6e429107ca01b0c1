"""The MPC's QPs of 4 or more branches on their scenario tree (tree_ipm.py) against OSQP at 1e-10."""

from __future__ import annotations

import numpy as np
import pytest

from marl_social.agents.robot import qp, tree_ipm
from marl_social.agents.robot.qp_types import QpInstance
from tests.agents.test_condensed_qp import CONFIG, WEIGHTS, _qp, _reference
from tests.agents.test_condensed_qp import _captured as captured  # by file name

# the cases whose tree solve stalls at a degenerate optimum (status 3: its settled iterate
# taken as it is, the multipliers drifting); the others converge (status 0)
DEGENERATE = (0, 1)


def _captured() -> list[dict]:
    """10 solve arguments captured from the crosswalk and the signalized intersection: L = 4
    (cases 0-3; 0 and 1 degenerate, 3 with a comfort factor 0), 5 (4, 5), 6 (6), 7 (7, 8), 8 (9)."""
    return captured("captured_tree_qps.npz")


def _tree_status(problem: qp.ContingencyQp, args: dict) -> int:
    lower, upper, _ = problem._bounds(QpInstance(**args))
    tree = problem._tree
    lb, ub = tree.bounds(lower, upper, args["prev_accel"])
    alpha, beta = tree.costs(args["weights"], args["comfort"], args["goal_weight"],
                             args["goal_m"], args["v_ref_mps"], WEIGHTS, CONFIG.plan_dt_s,
                             problem.first_dt_s)
    x0 = np.array([args["v0"], 0.0, args["prev_accel"]])
    return tree.solve(alpha, beta, lb, ub, x0, lower)[0]


def _agrees_with_tight_osqp(args: dict) -> None:
    problem = _qp(len(args["weights"]))
    sol = problem.solve(QpInstance(**args))
    assert sol.solved and problem.last_solver == "tree"
    x, cost = _reference(problem, args)
    assert np.allclose(sol.accel_mps2, x[problem._a_idx], atol=1e-6)
    assert np.allclose(sol.speed_mps, x[problem._v_idx], atol=1e-6)
    assert np.allclose(sol.progress_m, x[problem._s_idx], atol=1e-6)
    assert sol.cost == pytest.approx(cost, abs=1e-6)


@pytest.mark.parametrize("case", range(10))
def test_the_tree_solver_agrees_with_a_tight_osqp_on_captured_qps(case):
    args = _captured()[case]
    assert _tree_status(_qp(len(args["weights"])), args) == (3 if case in DEGENERATE else 0)
    _agrees_with_tight_osqp(args)


@pytest.mark.parametrize("case", [2, 6])
def test_the_tree_solver_agrees_with_a_tight_osqp_with_the_pull_up_term(case):
    _agrees_with_tight_osqp({**_captured()[case], "goal_weight": CONFIG.w_pull_up,
                             "goal_m": 6.0})


@pytest.mark.parametrize("case", DEGENERATE)
def test_a_settled_iterate_meeting_the_rows_is_taken_without_the_active_set_polish(
        case, monkeypatch):
    def no_polish(*args, **kwargs):
        raise AssertionError("polished a settled iterate that meets the rows")

    problem = _qp(len(_captured()[case]["weights"]))
    monkeypatch.setattr(problem._active_set, "solve_near", no_polish)
    sol = problem.solve(QpInstance(**_captured()[case]))
    x, cost = _reference(problem, _captured()[case])
    assert sol.solved and problem.last_solver == "tree"
    assert np.allclose(sol.accel_mps2, x[problem._a_idx], atol=1e-6)
    assert sol.cost == pytest.approx(cost, abs=1e-6)


def test_a_settled_iterate_off_the_rows_is_polished_by_the_active_set(monkeypatch):
    """A stalled tree solve whose iterate misses a row (here: moved off its dynamics by
    4e-7) is made exact by the active-set solve, which agrees with a tight OSQP."""
    args = _captured()[DEGENERATE[0]]
    problem = _qp(len(args["weights"]))
    solve, polished = problem._tree.solve, []

    def off_rows(*a, **k):
        status, x, info = solve(*a, **k)
        assert status == 3
        return status, x + 4e-7, info  # rows off by more than TREE_PRIMAL_TOL

    near = problem._active_set.solve_near

    def counted(*a, **k):
        polished.append(True)
        return near(*a, **k)

    monkeypatch.setattr(problem._tree, "solve", off_rows)
    monkeypatch.setattr(problem._active_set, "solve_near", counted)
    sol = problem.solve(QpInstance(**args))
    x, cost = _reference(problem, args)
    assert polished and sol.solved and problem.last_solver == "tree"
    assert np.allclose(sol.accel_mps2, x[problem._a_idx], atol=1e-6)
    assert sol.cost == pytest.approx(cost, abs=1e-6)


def test_the_tree_solver_is_deterministic():
    args = _captured()[8]
    first, second = _qp(7).solve(QpInstance(**args)), _qp(7).solve(QpInstance(**args))
    for name in ("accel_mps2", "speed_mps", "progress_m"):
        assert np.array_equal(getattr(first, name), getattr(second, name))
    assert first.cost == second.cost


def test_an_infeasible_qp_is_not_solved_by_the_tree_and_reported_infeasible_by_the_fallback():
    """Moving at 10 m/s, a stay-behind bound 0.5 m ahead from the first step on in every
    branch: no plan can brake that hard. The tree solver gives up, OSQP (the fallback) finds
    no optimum either: not solved."""
    args = _captured()[2]  # four branches
    args = {**args, "v0": 10.0, "s_up": np.full_like(args["s_up"], 0.5)}
    problem = _qp(4)
    assert _tree_status(problem, args) != 0
    sol = problem.solve(QpInstance(**args))
    assert not sol.solved and problem.last_solver == ""
    assert problem.solver_counts == {"daqp": 0, "tree": 0, "osqp": 0, "": 1}


def test_a_tree_failure_falls_back_to_osqp(monkeypatch):
    """A tree solve that reports no convergence (here: no iterations allowed) is answered by
    OSQP, which solves it."""
    args = _captured()[2]
    monkeypatch.setattr(tree_ipm, "MAX_ITER", 0)
    problem = _qp(4)
    assert problem.solve(QpInstance(**args)).solved and problem.last_solver == "osqp"
    assert problem.solver_counts == {"daqp": 0, "tree": 0, "osqp": 1, "": 0}


def test_solver_selection_by_the_number_of_branches():
    for n_branches in (4, 5, 8):
        problem = _qp(n_branches)
        assert problem._tree is not None and problem._condensed is None
        assert _qp(n_branches, use_daqp=False)._tree is None
    assert _qp(qp.DAQP_MAX_BRANCHES)._tree is None
    args = _captured()[4]
    problem = _qp(5, use_daqp=False)
    assert problem.solve(QpInstance(**args)).solved and problem.last_solver == "osqp"

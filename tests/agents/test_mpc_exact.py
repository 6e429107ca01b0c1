"""The MPC's hard QPs: the exact active-set solve (active_set.py) and the reachability skip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import osqp
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from marl_social.agents.robot import active_set, qp
from marl_social.agents.robot.corridor import provably_infeasible, reachable_progress
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.qp_types import QpInstance, QpWeights
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.dynamics import DT_S

CONFIG = MpcConfig()
VEHICLE = VehicleParams()
WEIGHTS = QpWeights(CONFIG.w_speed, CONFIG.w_accel, CONFIG.w_jerk, CONFIG.w_comfort)
N = CONFIG.n_steps


def _qp(n_branches: int, use_daqp: bool = False) -> qp.ContingencyQp:
    """The QP of n_branches; OSQP only unless use_daqp (these tests are of its exact path)."""
    return qp.ContingencyQp(n_branches, N, CONFIG.n_trunk, CONFIG.plan_dt_s, DT_S, WEIGHTS,
                            CONFIG.headway_s(), use_daqp=use_daqp)


def _at_rest_behind_a_close_bound():
    """A T-intersection QP OSQP took 12 000 iterations on: a robot creeping at 0.1 m/s whose
    second branch must stay 0.11 m ahead from 2.75 s on (a near-single-point feasible set)."""
    s_up = np.full((2, N), np.inf)
    s_up[1, 11:] = [0.113, 1.46, 3.685, 6.282, 8.758, 11.19, 13.623, 16.055, 18.488, 20.92,
                    23.353, 25.785, 28.218]
    return {"weights": np.array([0.7828171, 0.2171829]), "v0": 0.10438854,
            "prev_accel": 0.56719942, "v_ref_mps": 10.7725015,
            "v_max": np.full((2, N), 3.8722057), "s_low": np.full((2, N), -np.inf),
            "s_up": s_up, "accel_min": -VEHICLE.brake_max_mps2,
            "accel_max": VEHICLE.accel_max_mps2, "jerk_max": CONFIG.jerk_max_mps3,
            "comfort_decel": CONFIG.comfort_decel_mps2, "comfort": np.array([0.0, 1.0])}


def _reference(problem: qp.ContingencyQp, args: dict) -> tuple[np.ndarray, float]:
    """The same QP by OSQP alone at a tight tolerance, with all the iterations it needs."""
    lower, upper, _ = problem._bounds(QpInstance(**args))
    p = problem._p_matrix(args["weights"])
    p.data = problem._p_values(args["weights"], args["comfort"])
    q = problem._q_vector(args["weights"], args["v_ref_mps"], args["prev_accel"])
    solver = osqp.OSQP()
    solver.setup(p, q, problem._a_matrix, np.maximum(lower, -1e30), np.minimum(upper, 1e30),
                 verbose=False, eps_abs=1e-10, eps_rel=1e-10, max_iter=500_000, polishing=True,
                 adaptive_rho_interval=25)
    res = solver.solve(raise_error=False)
    assert res.info.status_val == osqp.SolverStatus.OSQP_SOLVED
    return res.x[problem._a_idx], float(res.info.obj_val)


def _record_success(monkeypatch, method: str) -> list:
    """A list that gets, per call of ActiveSetSolver.<method>, whether it returned a solution."""
    calls, original = [], getattr(active_set.ActiveSetSolver, method)

    def recorded(self, *args):
        out = original(self, *args)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(active_set.ActiveSetSolver, method, recorded)
    return calls


def test_a_degenerate_qp_is_solved_exactly_from_the_iterates_active_set(monkeypatch):
    calls = _record_success(monkeypatch, "solve")
    problem, args = _qp(2), _at_rest_behind_a_close_bound()
    sol = problem.solve(QpInstance(**args))
    assert sol.solved and calls and calls[-1]  # the exact path gave the answer
    assert problem._ext.info.iter <= qp.ROUND_ITER  # after one round of iterations at most
    accel, cost = _reference(problem, args)
    assert np.allclose(sol.accel_mps2, accel, atol=1e-5)
    assert sol.cost <= cost + 1e-6
    # the plan meets the stay-behind bound and stops short of it
    s, v = sol.progress_m[1], sol.speed_mps[1]
    assert np.all(s + CONFIG.headway_s() * v <= args["s_up"][1] + 1e-7)
    assert np.all(v >= -1e-7)


def test_active_set_solution_meets_the_kkt_conditions_of_a_random_qp():
    rng = np.random.default_rng(3)
    n, m = 12, 20
    root = rng.normal(size=(n, n))
    p = sp.csc_matrix(root @ root.T + 0.1 * np.eye(n))
    q = rng.normal(size=n) * 5.0
    a = sp.csc_matrix(rng.normal(size=(m, n)))
    lower, upper = -rng.uniform(0.1, 1.0, m), rng.uniform(0.1, 1.0, m)
    lower[:2] = upper[:2] = 0.3  # two equalities
    solver = osqp.OSQP()
    solver.setup(p, q, a, lower, upper, verbose=False, eps_abs=1e-3, eps_rel=1e-3,
                 polishing=False)
    rough = solver.solve(raise_error=False)  # a loose iterate: its active set, roughly
    upper_p = sp.triu(p).tocsc()
    rows = np.repeat(np.arange(n), np.diff(upper_p.indptr))  # column of each entry
    exact = active_set.ActiveSetSolver(upper_p.indices, rows, a).solve(
        upper_p.data, q, lower, upper, rough.x, rough.y)
    assert exact is not None
    x, y, cost = exact
    ax = a @ x
    assert np.all(ax >= lower - 1e-9) and np.all(ax <= upper + 1e-9)
    assert np.allclose(p @ x + q + a.T @ y, 0.0, atol=1e-8)
    assert np.all(y[ax < upper - 1e-9] <= 1e-9) and np.all(y[ax > lower + 1e-9] >= -1e-9)
    assert cost == pytest.approx(0.5 * x @ (p @ x) + q @ x)
    tight = osqp.OSQP()
    tight.setup(p, q, a, lower, upper, verbose=False, eps_abs=1e-10, eps_rel=1e-10,
                max_iter=200_000)
    assert np.allclose(x, tight.solve(raise_error=False).x, atol=1e-6)


def test_active_set_gives_nothing_for_an_infeasible_qp():
    p = sp.csc_matrix(np.eye(2))
    a = sp.csc_matrix(np.array([[1.0, 0.0], [1.0, 0.0]]))
    lower, upper = np.array([1.0, -1e30]), np.array([1e30, 0.0])  # x0 >= 1 and x0 <= 0
    upper_p = sp.triu(p).tocsc()
    solver = active_set.ActiveSetSolver(upper_p.indices, np.arange(2), a)
    assert solver.solve(upper_p.data, np.zeros(2), lower, upper, np.array([0.5, 0.0]),
                        np.array([-1.0, 1.0])) is None


@pytest.mark.parametrize("kernels", [True, False])
def test_lu_factor_and_matvec_are_scipys_public_calls_bit_for_bit(kernels, monkeypatch):
    """_lu_factor is spla.splu (the same permutations and solves), _matvec is `@`; also
    through their fallbacks (a scipy without the private kernel modules)."""
    if not kernels:
        monkeypatch.setattr(active_set, "_superlu", None)
        monkeypatch.setattr(active_set, "_sparsetools", None)
    rng = np.random.default_rng(5)
    n = 40
    dense = rng.normal(size=(n, n)) * (rng.random((n, n)) < 0.15) + 3.0 * np.eye(n)
    matrix = sp.csc_matrix(dense)
    ours = active_set._lu_factor(matrix.data, matrix.indices, matrix.indptr, n)
    theirs = spla.splu(matrix)
    assert np.array_equal(ours.perm_c, theirs.perm_c)
    assert np.array_equal(ours.perm_r, theirs.perm_r)
    rhs = rng.normal(size=n)
    assert np.array_equal(ours.solve(rhs), theirs.solve(rhs))
    x = rng.normal(size=n)
    assert np.array_equal(active_set._matvec(matrix.tocsr(), x), matrix.tocsr() @ x)
    singular = sp.csc_matrix(np.diag([1.0, 0.0, 2.0]))
    with pytest.raises(RuntimeError):
        active_set._lu_factor(singular.data, singular.indices, singular.indptr, 3)


def test_second_guess_solves_a_degenerate_qp_the_iterates_multipliers_get_wrong(monkeypatch):
    """A T-intersection QP of two branches (near hidden car, seed 1) that OSQP left after
    ROUND_ITER iterations: the active set its multipliers give is wrong and CORRECTIONS
    corrections do not fix it (the MPC iterated on for 10 000 more); the rows within
    NEAR_BOUND of a bound give the optimum, which OSQP at a tight tolerance confirms."""
    data = np.load(Path(__file__).parent / "data" / "degenerate_qp.npz")
    a = sp.csc_matrix((data["a_data"], data["a_indices"], data["a_indptr"]),
                      shape=tuple(data["a_shape"]))
    solver = active_set.ActiveSetSolver(data["p_rows"], data["p_cols"], a)
    p_values, q, lower, upper = data["p_values"], data["q"], data["lower"], data["upper"]
    guesses = _record_success(monkeypatch, "_corrected")
    exact = solver.solve(p_values, q, lower, upper, data["x_guess"], data["y_guess"])
    assert guesses == [False, True]  # the first guess fails, the second holds
    x, y, cost = exact
    n = len(q)
    p = sp.csc_matrix((p_values, (data["p_rows"], data["p_cols"])), shape=(n, n))
    p_sym = p + sp.triu(p, k=1).T
    ax = a @ x
    assert np.all(ax >= lower - 1e-7) and np.all(ax <= upper + 1e-7)
    assert np.allclose(p_sym @ x + q + a.T @ y, 0.0, atol=1e-6)
    reference = osqp.OSQP()
    reference.setup(p, q, a, lower, upper, verbose=False, eps_abs=1e-10, eps_rel=1e-10,
                    max_iter=500_000, polishing=True, adaptive_rho_interval=25)
    res = reference.solve(raise_error=False)
    assert res.info.status_val == osqp.SolverStatus.OSQP_SOLVED
    assert np.allclose(x, res.x, atol=1e-5)
    assert cost <= float(res.info.obj_val) + 1e-6


@pytest.mark.parametrize("seed", range(5))
def test_reachable_progress_bounds_every_admissible_plan(seed):
    """Random plans within the acceleration, jerk and speed bounds never get further."""
    rng = np.random.default_rng(seed)
    dt, jerk, a_max = CONFIG.plan_dt_s, CONFIG.jerk_max_mps3, VEHICLE.accel_max_mps2
    for _ in range(200):
        v0, prev = rng.uniform(0.0, 12.0), rng.uniform(-6.0, 3.0)
        v_max = rng.uniform(2.0, 14.0, N)
        bound = reachable_progress(v0, prev, a_max, jerk, DT_S, dt, v_max)
        a_last, v, s = prev, v0, 0.0
        for k in range(N):
            step = jerk * (DT_S if k == 0 else dt)
            a = np.clip(a_last + rng.uniform(-step, step), -VEHICLE.brake_max_mps2, a_max)
            a = min(a, (v_max[k] - v) / dt)  # stay within the speed bound
            a = max(a, -v / dt)  # and v >= 0
            if abs(a - a_last) > step + 1e-12 or a > a_max:
                break  # no admissible step from here (a bound it cannot meet): stop the plan
            s += dt * v + 0.5 * a * dt * dt
            v += a * dt
            a_last = a
            assert s <= bound[k] + 1e-9


def test_reachable_progress_is_attained_by_full_acceleration():
    dt, v_max = CONFIG.plan_dt_s, np.full(N, 50.0)
    bound = reachable_progress(2.0, 3.0, 3.0, 15.0, DT_S, dt, v_max)
    t = CONFIG.plan_times_s
    assert np.allclose(bound, 2.0 * t + 1.5 * t * t)


def test_provably_infeasible_when_a_pass_must_end_behind_a_bound_or_out_of_reach():
    reach = np.linspace(1.0, 24.0, N)
    s_low, s_up = np.full((1, N), -np.inf), np.full((1, N), np.inf)
    assert not provably_infeasible(s_low, s_up, reach, 0.5)
    past = s_low.copy()
    past[0, 10] = 5.0  # past 5 m at step 10
    assert not provably_infeasible(past, s_up, reach, 0.5)
    behind = s_up.copy()
    behind[0, 15] = 4.0  # but behind 4 m at step 15: progress does not go back
    assert provably_infeasible(past, behind, reach, 0.5)
    assert not provably_infeasible(past, behind, reach, 1.5)  # within the margin
    far = s_low.copy()
    far[0, 3] = reach[3] + 1.0  # further than the robot can get
    assert provably_infeasible(far, s_up, reach, 0.5)


def test_kkt_template_gives_the_matrix_scipy_assembles_for_any_active_set(monkeypatch):
    """The KKT matrix cut from the template: scipy.sparse's assembly, entry for entry (so that
    its factorization, and every exact solve, are those of the direct assembly)."""
    problem = _qp(3)
    solver = problem._active_set
    rng = np.random.default_rng(7)
    p_values = problem._p_values(np.array([0.5, 0.3, 0.2]), np.array([1.0, 0.0, 0.5]), 30.0)
    kkt_values = solver._t_constant.copy()
    kkt_values[solver._t_p_pos] = p_values[solver._p_take]
    kkt_values[solver._t_x_diagonal] += active_set.REGULARIZATION
    n = solver.n_vars
    built, lu_factor = [], active_set._lu_factor

    def recorded(values, indices, indptr, size):
        built.append(sp.csc_matrix((values, indices, indptr), shape=(size, size)))
        return lu_factor(values, indices, indptr, size)

    monkeypatch.setattr(active_set, "_lu_factor", recorded)
    for _ in range(5):
        active = rng.random(solver.n_rows) < 0.4
        built.clear()
        solver._kkt_solve(solver._p_full, kkt_values, np.zeros(n), active,
                          np.zeros(solver.n_rows))
        rank = np.cumsum(active) - 1 + n
        keep = active[solver._a_i]
        a_i, a_j, a_v = rank[solver._a_i[keep]], solver._a_j[keep], solver._a_v[keep]
        size = n + int(active.sum())
        diag = np.arange(size)
        reg = np.where(diag < n, active_set.REGULARIZATION, -active_set.REGULARIZATION)
        direct = sp.csc_matrix(
            (np.concatenate([p_values[solver._p_take], a_v, a_v, reg]),
             (np.concatenate([solver._p_i, a_i, a_j, diag]),
              np.concatenate([solver._p_j, a_j, a_i, diag]))), shape=(size, size))
        (kkt,) = built
        assert np.array_equal(kkt.indptr, direct.indptr)
        assert np.array_equal(kkt.indices, direct.indices)
        assert np.array_equal(kkt.data, direct.data)  # bit for bit

"""The contingency MPC's quadratic program, built once per number of branches and updated.

Path-velocity decomposition: the robot's progress along its route, relative to where it is now.
Per branch l (one live hypothesis) and plan step k = 0..N-1 (length dt_s), the variables are the
acceleration a[l, k] held during step k [m/s^2], the speed v[l, k] and the progress s[l, k] at
the end of step k [m/s, m]. The first `n_trunk` accelerations are one shared variable per step
(non-anticipativity: the trunk is what is executed before the next observation); so are,
through the dynamics, the trunk's speeds and positions.

Rows (l <= A x <= u), per branch:

* dynamics (equalities): v[k] = v[k-1] + a[k] dt, s[k] = s[k-1] + v[k-1] dt + a[k] dt^2 / 2,
  with v[-1] = v0, s[-1] = 0 (exact for piecewise-constant acceleration);
* speed: 0 <= v[k] <= v_max[k] (speed limit and the curvature bound);
* pass before: s[k] >= s_low[k] (past an object, from corridor.py);
* stay behind: s[k] + h[k] v[k] <= s_up[k] (behind an object with a time headway h[k], ramped
  from 0 so that a gap already short now stays feasible; on the last step the terminal headway
  makes room for a stop beyond the horizon);
* jerk: |a[k] - a[k-1]| <= j_max dt (the first step against the previous command, over one
  simulator step); acceleration: -brake_max <= a <= accel_max;
* comfort (soft): a[k] + c[k] >= -comfort_decel with a slack c[k] >= 0 per acceleration
  variable, penalized by w_c c^2 (braking beyond the comfortable deceleration is allowed, at a
  price; Alsterda & Gerdes' comfortable contingency branch).

Cost (0.5 x'Px + q'x) = sum_l b_l dt sum_k [w_v (v - v_ref)^2 + w_a a^2 + w_j ((a_k - a_{k-1})
/ dt_k)^2 + w_g (s - goal)^2], dt_k = dt except for the first change (from the previous
command, made within one simulator step: first_dt_s); the pull-up term w_g (s - goal)^2 (0
unless asked for: a robot at rest short of its stop line drives up to it instead of creeping,
agents/robot/mpc.py) gives arriving sooner a value, which the speed term alone does not (its
gain grows with the distance covered, not with how soon). The sparsity of P and A depends
only on (L, N, n_trunk); a new step updates P's values
(the beliefs), q and the bounds, and OSQP warm-starts from the previous solution. A QP that
OSQP has not solved within ROUND_ITER iterations (a degenerate optimum: it may need thousands)
is solved exactly from the active set its iterate shows, the result checked against the KKT
conditions (agents/robot/active_set.py); only if that fails does OSQP iterate on.
"""

from __future__ import annotations

import numpy as np
import osqp
import scipy.sparse as sp

from marl_social.agents.robot.active_set import ActiveSetSolver
from marl_social.agents.robot.condensed_qp import CondensedLayout, qp_kernels
from marl_social.agents.robot.qp_types import QpInstance, QpSolution, QpWeights

_OK = frozenset(int(s) for s in (osqp.SolverStatus.OSQP_SOLVED,
                                  osqp.SolverStatus.OSQP_SOLVED_INACCURATE))
_MAX_ITER = int(osqp.SolverStatus.OSQP_MAX_ITER_REACHED)
_STOPPED = frozenset((_MAX_ITER, int(osqp.SolverStatus.OSQP_SOLVED_INACCURATE)))
# ADMM iterations before an exact solve from the iterate's active set (active_set.py) is
# tried: a hard QP needs thousands of iterations, but its iterate tells the active set after a
# few hundred; if that fails, rounds of twice as many iterations (at most MAX_ITER), each
# followed by another try
ROUND_ITER = 200
MAX_ITER = 4000
MAX_ROUNDS = 8  # 18 200 iterations in all; then the QP has failed (unless solved inaccurately)
OSQP_TOLERANCE = 1e-5  # OSQP's absolute and relative tolerance
# the QPs of at most this many branches are solved condensed by DAQP (condensed_qp.py), with
# OSQP as the fallback; DAQP's cost grows with its active set's size times variables^2: from 3
# branches (114-136 variables) the tree solver below is faster (thread CPU on the bench's
# 3-branch QPs: DAQP median / p90 1.24 / 2.13 ms, 36+ active-set steps on the hard ones; the
# tree 0.73 / 0.78), at 2 branches DAQP's median is (0.20 vs 0.52 ms; p90 0.72 vs 0.61)
DAQP_MAX_BRANCHES = 2
# the QPs of more branches are solved on their scenario tree by an interior point method
# (tree_ipm.py: a Riccati recursion per Newton step, linear in L), with OSQP as the fallback
# whose answer is only accepted if it meets the rows to TREE_PRIMAL_TOL [the row's unit]
TREE_PRIMAL_TOL = 1e-7
# a tree solve whose multipliers did not settle (a degenerate optimum) but whose iterate did
# (complementarity below TREE_POLISH_MU) is taken as it is if it meets the rows to
# TREE_PRIMAL_TOL, else made exact by the active-set solve from the rows within
# TREE_POLISH_NEAR of a bound [the row's unit]
TREE_POLISH_MU = 1e-9
TREE_POLISH_NEAR = 1e-6
_INF = 1e20  # OSQP's infinity
_OSQP_INFTY = 1e30  # what osqp.OSQP.update clips the bounds to (its OSQP_INFTY)
# what a QP's layout needs, built once per (L, N, n_trunk, steps, weights, headway) and shared
# by every ContingencyQp of that layout (read only: bounds are copied from the templates); a
# new episode's QPs then set up nothing but OSQP, and that only if they fall back to it
_STRUCTURE_FIELDS = ("_a_off", "_v_off", "_s_off", "_c_off", "n_vars", "_a_idx", "_v_idx",
                     "_s_idx", "_c_idx", "_p_slot", "_p_rows", "_p_cols", "_p_coef",
                     "_p_branch", "_p_comfort", "_p_progress_slot", "_p_progress_branch",
                     "_a_matrix", "_rows",
                     "_lower_template", "_upper_template", "_first_dyn_rows", "_p_initial",
                     "_active_set",
                     "_condensed", "_tree", "_p_offdiag")
_STRUCTURES: dict[tuple, dict] = {}


class ContingencyQp:
    """The QP of L branches over N steps with a shared trunk of n_trunk steps (module docstring).

    Args:
        n_branches: L >= 1.
        n_steps: N plan steps.
        n_trunk: shared first steps, 1 <= n_trunk < N.
        dt_s: plan step [s].
        first_dt_s: the time over which the first acceleration may change (a simulator step) [s].
        weights: the cost weights.
        headway_s: (N,) time headway h[k] of the stay-behind rows [s].
        use_daqp: solve condensed by DAQP first when the layout allows it (at most
            DAQP_MAX_BRANCHES branches), on the scenario tree (tree_ipm.py) beyond; False:
            OSQP only.
    """

    def __init__(self, n_branches: int, n_steps: int, n_trunk: int, dt_s: float,
                 first_dt_s: float, weights: QpWeights, headway_s: np.ndarray,
                 use_daqp: bool = True):
        if not (n_branches >= 1 and 1 <= n_trunk < n_steps):
            raise ValueError("ContingencyQp: need L >= 1 and 1 <= n_trunk < n_steps")
        self.n_branches, self.n_steps, self.n_trunk = n_branches, n_steps, n_trunk
        self.dt_s, self.first_dt_s, self.weights = dt_s, first_dt_s, weights
        headway_s = np.asarray(headway_s, dtype=np.float64)
        key = (n_branches, n_steps, n_trunk, dt_s, first_dt_s, weights, headway_s.tobytes())
        structure = _STRUCTURES.get(key)
        if structure is None:
            self._build_structure(headway_s)
            structure = {name: getattr(self, name) for name in _STRUCTURE_FIELDS}
            _STRUCTURES[key] = structure
        self.__dict__.update(structure)
        r = self._rows  # the rows `_bounds` fills, as qp_kernels.sparse_bounds takes them
        self._bound_rows = (self._lower_template, self._upper_template, *self._first_dyn_rows,
                            r["speed"], r["low"], r["up"], r["jerk"], r["accel"], r["comfort"])
        if not use_daqp:
            self._condensed = self._tree = None
        # OSQP is the fallback: most QPs never need it, and its setup costs about as much as
        # a solve (1-6 ms by L): set up at its first use (_setup_osqp), from the same data, so
        # that its state then is that of a setup here
        self._solver: osqp.OSQP | None = None
        self._ext = None
        # which solver gave each solve's answer: "daqp", "tree" (tree_ipm.py, or the exact
        # active-set solve from its iterate), "osqp" (or its exact active-set solve), or ""
        # (failed); and the count of each
        self.last_solver = ""
        self.solver_counts = {"daqp": 0, "tree": 0, "osqp": 0, "": 0}

    def _setup_osqp(self) -> osqp.OSQP:
        """Set OSQP up for this layout (at its first use; `_osqp`) and return it."""
        tolerance = OSQP_TOLERANCE
        self._solver = osqp.OSQP()
        # copies: OSQP keeps the arrays it is set up with and writes P's updates into them
        self._solver.setup(self._p_initial.copy(), np.zeros(self.n_vars), self._a_matrix.copy(),
                           self._lower_template.copy(), self._upper_template.copy(),
                           verbose=False, eps_abs=tolerance, eps_rel=tolerance,
                           max_iter=ROUND_ITER, polishing=True, warm_starting=True,
                           check_termination=10,
                           # a fixed rho-update interval: OSQP's default (0) times the setup
                           # and adapts on wall-clock time, which breaks bit-identical episodes
                           adaptive_rho_interval=25)
        # the compiled solver behind osqp.OSQP: update and solve call it directly, as
        # osqp.OSQP.update / solve do, without their per-call Python work (constant lookups
        # through importlib, the derivative cache, the info namespace): the same calls with
        # the same data
        self._ext = self._solver._solver
        return self._solver

    def _osqp(self):
        """OSQP's compiled solver, set up at the first call (`_setup_osqp`)."""
        if self._ext is None:
            self._setup_osqp()
        return self._ext

    def _build_structure(self, headway_s: np.ndarray) -> None:
        """The index maps, P's pattern, A and the bound templates (_STRUCTURE_FIELDS)."""
        n_branches, n_steps, n_trunk = self.n_branches, self.n_steps, self.n_trunk
        n_b = n_steps - n_trunk
        self._a_off = n_trunk
        self._v_off = n_trunk + n_branches * n_b
        self._s_off = self._v_off + n_branches * n_steps
        self._c_off = self._s_off + n_branches * n_steps
        self.n_vars = self._c_off + self._v_off  # one comfort slack per acceleration variable
        self._a_idx = np.array([[k if k < n_trunk else n_trunk + l * n_b + k - n_trunk
                                 for k in range(n_steps)] for l in range(n_branches)])
        self._v_idx = self._v_off + np.arange(n_branches * n_steps).reshape(n_branches, n_steps)
        self._s_idx = self._s_off + np.arange(n_branches * n_steps).reshape(n_branches, n_steps)
        self._c_idx = self._c_off + self._a_idx
        self._build_cost_pattern()
        self._build_constraints(headway_s)
        self._p_initial = self._p_matrix(np.full(n_branches, 1.0 / n_branches))
        self._active_set = ActiveSetSolver(self._p_rows, self._p_cols, self._a_matrix)
        self._condensed = (CondensedLayout(self) if self.n_branches <= DAQP_MAX_BRANCHES
                           else None)
        self._tree = (_tree_layout(self, headway_s) if self.n_branches > DAQP_MAX_BRANCHES
                      else None)
        self._p_offdiag = np.where(self._p_rows == self._p_cols, 0.5, 1.0)

    # -- cost ---------------------------------------------------------------------------------

    def _build_cost_pattern(self) -> None:
        """Triples (row, col, coefficient, branch) of P; duplicates are summed in Px.

        Per branch l and step k, in this order: v diag, s diag (0: keeps P's pattern
        full-rank; the pull-up term's value is set by _p_values when asked), comfort slack
        diag, a diag, and for k >= 1 the jerk terms of a[k - 1].
        """
        w, dt = self.weights, self.dt_s
        L, N = self.n_branches, self.n_steps
        first = dt / self.first_dt_s ** 2  # the first change happens within one simulator step
        a = self._a_idx
        prev = np.concatenate([a[:, :1], a[:, :-1]], axis=1)  # a[k - 1] (unused at k = 0)
        a_diag = np.full(N, 2.0 * w.accel * dt + 2.0 * w.jerk / dt)
        a_diag[0] = 2.0 * w.accel * dt + 2.0 * w.jerk * first
        shape = (L, N, 6)
        i = np.stack([self._v_idx, self._s_idx, self._c_idx, a, prev, prev], axis=-1)
        j = np.stack([self._v_idx, self._s_idx, self._c_idx, a, prev, a], axis=-1)
        coef = np.broadcast_to(np.stack(np.broadcast_arrays(
            2.0 * w.speed * dt, 0.0, 2.0 * w.comfort * dt, a_diag, 2.0 * w.jerk / dt,
            -2.0 * w.jerk / dt), axis=-1), shape)
        branch = np.broadcast_to(np.arange(L)[:, None, None], shape)
        is_comfort = np.broadcast_to(np.arange(6) == 2, shape)
        is_progress = np.broadcast_to(np.arange(6) == 1, shape)
        keep = np.ones(shape, bool)
        keep[:, 0, 4:] = False  # no jerk term before the first step's
        rows, cols = np.minimum(i, j)[keep], np.maximum(i, j)[keep]
        key = cols * self.n_vars + rows  # CSC order: by column, then row
        unique, self._p_slot = np.unique(key, return_inverse=True)
        self._p_rows, self._p_cols = unique % self.n_vars, unique // self.n_vars
        self._p_coef, self._p_branch = coef[keep], branch[keep]
        self._p_comfort = is_comfort[keep]
        self._p_progress_slot = self._p_slot[is_progress[keep]]  # (L * N,) s diag, by branch
        self._p_progress_branch = self._p_branch[is_progress[keep]]

    def _p_values(self, weights: np.ndarray, comfort: np.ndarray | None = None,
                  goal_weight: float = 0.0) -> np.ndarray:
        factor = weights[self._p_branch]
        if comfort is not None:
            factor = np.where(self._p_comfort, factor * comfort[self._p_branch], factor)
        values = np.bincount(self._p_slot, weights=self._p_coef * factor,
                             minlength=len(self._p_rows))
        if goal_weight > 0.0:  # the pull-up term on the s diagonal (else it stays 0)
            values[self._p_progress_slot] = (2.0 * self.dt_s) * (
                weights[self._p_progress_branch] * goal_weight)
        return values

    def _p_matrix(self, weights: np.ndarray) -> sp.csc_matrix:
        indptr = np.concatenate([[0], np.cumsum(np.bincount(self._p_cols,
                                                            minlength=self.n_vars))])
        return sp.csc_matrix((self._p_values(weights), self._p_rows, indptr),
                             shape=(self.n_vars, self.n_vars))

    def _q_vector(self, weights: np.ndarray, v_ref_mps: float, prev_accel: float,
                  goal_weight: float = 0.0, goal_m: float = 0.0) -> np.ndarray:
        w, dt = self.weights, self.dt_s
        q = np.zeros(self.n_vars)
        q[self._v_idx] = -2.0 * w.speed * dt * v_ref_mps * weights[:, None]
        if goal_weight > 0.0:
            q[self._s_idx] = -2.0 * goal_weight * dt * goal_m * weights[:, None]
        first = dt / self.first_dt_s ** 2
        q[self._a_idx[0, 0]] = -2.0 * w.jerk * first * prev_accel  # the weights sum to one
        return q

    # -- constraints --------------------------------------------------------------------------

    def _build_constraints(self, headway_s: np.ndarray) -> None:
        """A's entries and the row index of each kind of row (module docstring), vectorized.

        Rows, in order: per branch and step dyn_v, dyn_s, speed, low, up; the jerk rows (the
        first change, the trunk's, then each branch's); one acceleration, one comfort and one
        slack row per acceleration variable.
        """
        L, N, dt, n_a = self.n_branches, self.n_steps, self.dt_s, self._v_off
        a, v, s = self._a_idx, self._v_idx, self._s_idx
        base = 5 * np.arange(L * N).reshape(L, N)
        dyn_v, dyn_s, speed, low, up = (base + r for r in range(5))
        has_prev = np.broadcast_to(np.arange(N) >= 1, (L, N))
        v_prev = np.concatenate([v[:, :1], v[:, :-1]], axis=1)
        s_prev = np.concatenate([s[:, :1], s[:, :-1]], axis=1)
        entries = [  # (rows, cols, values, mask)
            (dyn_v, v, 1.0, None), (dyn_v, a, -dt, None), (dyn_v, v_prev, -1.0, has_prev),
            (dyn_s, s, 1.0, None), (dyn_s, a, -0.5 * dt * dt, None),
            (dyn_s, s_prev, -1.0, has_prev), (dyn_s, v_prev, -dt, has_prev),
            (speed, v, 1.0, None), (low, s, 1.0, None), (up, s, 1.0, None),
            (up, v, np.broadcast_to(headway_s, (L, N)), None),
        ]
        rows, cols, vals = [], [], []
        for r, c, x, mask in entries:
            mask = np.ones((L, N), bool) if mask is None else mask
            rows.append(r[mask])
            cols.append(c[mask])
            vals.append(np.broadcast_to(x, (L, N))[mask])
        # jerk rows: a[0] (against the previous command), the trunk, each branch after it
        cur = np.concatenate([np.arange(self.n_trunk), a[:, self.n_trunk:].ravel()])
        before = np.concatenate([[-1], np.arange(self.n_trunk - 1),
                                 a[:, self.n_trunk - 1:-1].ravel()])
        jerk = 5 * L * N + np.arange(len(cur))
        rows += [jerk, jerk[1:]]
        cols += [cur, before[1:]]
        vals += [np.ones(len(cur)), -np.ones(len(cur) - 1)]
        accel = jerk[-1] + 1 + np.arange(n_a)
        comfort_rows, slack_rows = accel + n_a, accel + 2 * n_a
        slack = self._c_off + np.arange(n_a)
        rows += [accel, comfort_rows, comfort_rows, slack_rows]
        cols += [np.arange(n_a), np.arange(n_a), slack, slack]
        vals += [np.ones(n_a)] * 4
        n_rows = int(slack_rows[-1]) + 1
        self._a_matrix = sp.csc_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(n_rows, self.n_vars))
        self._rows = {"dyn_v": dyn_v, "dyn_s": dyn_s, "speed": speed, "low": low, "up": up,
                      "jerk": jerk, "accel": accel, "comfort": comfort_rows,
                      "slack": slack_rows}
        lower, upper = np.full(n_rows, -_INF), np.full(n_rows, _INF)
        lower[dyn_v] = upper[dyn_v] = 0.0
        lower[dyn_s] = upper[dyn_s] = 0.0
        lower[self._rows["slack"]] = 0.0
        self._lower_template, self._upper_template = lower, upper
        # the first step's dynamics rows, whose bounds take v0 (contiguous, for the kernel)
        self._first_dyn_rows = (dyn_v[:, 0].copy(), dyn_s[:, 0].copy())

    def _bounds(self, inst: QpInstance) -> tuple[np.ndarray, np.ndarray, bool]:
        """(m,) lower and upper row bounds for this solve; whether a lower exceeds its upper.

        By more than 1e-9 (agents/robot/qp_kernels.sparse_bounds).
        """
        return qp_kernels().sparse_bounds(
            self._bound_rows, float(inst.v0), float(inst.prev_accel),
            (self.dt_s, self.first_dt_s), (inst.v_max, inst.s_low, inst.s_up),
            (float(inst.accel_min), float(inst.accel_max), float(inst.jerk_max),
             -_INF if inst.comfort_decel is None else -float(inst.comfort_decel), _INF))

    # -- solve --------------------------------------------------------------------------------

    def solve(self, inst: QpInstance) -> QpSolution:
        """Solve one instance (`QpInstance`: the weights, state and bounds of this step)."""
        weights = np.asarray(inst.weights, dtype=np.float64)
        comfort, goal_weight = inst.comfort, inst.goal_weight
        lower, upper, infeasible = self._bounds(inst)
        if infeasible:
            return self._count(self.failed(), "")
        self._q_last = self._q_vector(weights, inst.v_ref_mps, inst.prev_accel, goal_weight,
                                      inst.goal_m)
        if self._condensed is not None:
            dense = self._condensed.solve(weights, comfort, goal_weight, self._q_last, lower,
                                          upper, inst.v0)
            if dense is not None:
                x, cost = dense
                return self._count(QpSolution(True, cost, x[self._a_idx], x[self._v_idx],
                                              x[self._s_idx]), "daqp")
        if self._tree is not None:
            tree = self._solve_tree(inst, weights, lower, upper)
            if tree is not None:
                return self._count(tree, "tree")
        return self._count(self._solve_osqp(weights, lower, upper, comfort, goal_weight),
                           "osqp")

    def _count(self, solution: QpSolution, solver: str) -> QpSolution:
        """Record which solver answered (last_solver, solver_counts); the solution as is."""
        solver = solver if solution.solved else ""
        self.last_solver = solver
        self.solver_counts[solver] += 1
        return solution

    def _solve_tree(self, inst: QpInstance, weights: np.ndarray, lower: np.ndarray,
                    upper: np.ndarray) -> QpSolution | None:
        """The optimum by the tree interior point method (tree_ipm.py), or None (fallback).

        Its solution, converged or settled at a degenerate optimum (multipliers drifting, the
        primal iterate feasible and complementarity below TREE_POLISH_MU), is checked against
        this QP's rows (TREE_PRIMAL_TOL); a settled one that fails the check is made exact (and
        verified) by the active-set solve from its rows near a bound (TREE_POLISH_NEAR). With
        this step's linear cost self._q_last (`solve`); `weights` are inst's as float64 and
        lower, upper its (m,) row bounds.
        """
        tree = self._tree
        v0, prev_accel, comfort = inst.v0, inst.prev_accel, inst.comfort
        goal_weight, goal_m, v_ref_mps = inst.goal_weight, inst.goal_m, inst.v_ref_mps
        lb, ub = tree.bounds(lower, upper, prev_accel)
        alpha, beta = tree.costs(weights, comfort, goal_weight, goal_m, v_ref_mps,
                                 self.weights, self.dt_s, self.first_dt_s)
        status, x, info = tree.solve(alpha, beta, lb, ub, np.array([v0, 0.0, prev_accel]),
                                     lower)
        p_values = self._p_values(weights, comfort, goal_weight)
        if not np.all(np.isfinite(x)):
            return None
        if status != 0 and not (info[0] <= TREE_PRIMAL_TOL and info[2] <= TREE_POLISH_MU):
            return None  # neither converged nor settled
        # converged, or settled at a degenerate optimum (status 3: primal feasible, mu tiny,
        # only the multipliers drifting): the iterate, if it meets this QP's rows; a settled
        # one that does not is made exact by the active-set solve from its rows near a bound
        # (the polish moved settled iterates by <= 2e-8 over 120 episodes' QPs, at the cost of
        # a sparse factorization as long as the whole interior point solve)
        ax = self._a_matrix @ x
        if max(float(np.max(lower - ax)), float(np.max(ax - upper))) <= TREE_PRIMAL_TOL:
            cost = float(np.dot(p_values * self._p_offdiag * x[self._p_rows],
                                x[self._p_cols]) + self._q_last @ x)
        elif status != 0:
            exact = self._active_set.solve_near(p_values, self._q_last, lower, upper, x,
                                                TREE_POLISH_NEAR)
            if exact is None:
                return None
            x, _, cost = exact
        else:
            return None
        return QpSolution(True, cost, x[self._a_idx], x[self._v_idx], x[self._s_idx])

    def _solve_osqp(self, weights: np.ndarray, lower: np.ndarray, upper: np.ndarray,
                    comfort: np.ndarray | None, goal_weight: float) -> QpSolution:
        """OSQP's solve (and the exact solve from its iterate's active set); the fallback.

        With this step's linear cost self._q_last (`solve`).
        """
        # osqp.OSQP.update's order: the vectors (bounds clipped to OSQP's infinity), then P
        np.maximum(lower, -_OSQP_INFTY, out=lower)
        np.minimum(upper, _OSQP_INFTY, out=upper)
        ext = self._osqp()
        ext.update_data_vec(q=self._q_last, l=lower, u=upper)
        p_values = self._p_values(weights, comfort, goal_weight)
        ext.update_data_mat(P_x=p_values, P_i=None, A_x=None, A_i=None)
        ext.solve()
        if ext.info.status_val in _STOPPED:
            # stopped short of the tolerance: the iterate's active set may give the optimum
            exact = self._exact(p_values, lower, upper)
            if exact is None:
                exact = self._go_on(p_values, lower, upper)
            if exact is not None:
                return exact
        info = ext.info
        if info.status_val not in _OK:
            return self.failed()
        x = ext.solution.x
        if x is None:
            return self.failed()
        ax = self._a_matrix @ x
        violation = max(float(np.max(lower - ax)), float(np.max(ax - upper)))
        if not np.all(np.isfinite(x)) or violation > 1e-3:
            return self.failed()
        return QpSolution(True, float(info.obj_val), x[self._a_idx], x[self._v_idx],
                          x[self._s_idx])

    def _go_on(self, p_values: np.ndarray, lower: np.ndarray,
               upper: np.ndarray) -> QpSolution | None:
        """More rounds of iterations, twice as many each (at most MAX_ITER), then exact solves.

        Returns the exact solution, or None with OSQP's own result in its info (solved,
        infeasible, or stopped).
        """
        try:
            for round_ in range(1, MAX_ROUNDS):
                self._solver.update_settings(max_iter=min(ROUND_ITER << round_, MAX_ITER))
                self._ext.solve()
                status = self._ext.info.status_val
                if status not in _STOPPED:
                    return None
                exact = self._exact(p_values, lower, upper)
                if exact is not None or status != _MAX_ITER:
                    return exact
            return None
        finally:
            self._solver.update_settings(max_iter=ROUND_ITER)

    def _exact(self, p_values: np.ndarray, lower: np.ndarray,
               upper: np.ndarray) -> QpSolution | None:
        """The optimum from the stopped iterate's active set (active_set.py), or None.

        On success OSQP is warm-started from it: the next solve starts at this optimum.
        """
        solution = self._ext.solution
        exact = self._active_set.solve(p_values, self._q_last, lower, upper, solution.x,
                                       solution.y)
        if exact is None:
            return None
        x, y, cost = exact
        self._ext.warm_start(x=x, y=y)
        return QpSolution(True, cost, x[self._a_idx], x[self._v_idx], x[self._s_idx])

    def failed(self) -> QpSolution:
        """An unsolved QpSolution (NaN plans, infinite cost)."""
        shape = (self.n_branches, self.n_steps)
        nan = np.full(shape, np.nan)
        return QpSolution(False, np.inf, nan, nan.copy(), nan.copy())


def _tree_layout(qp: ContingencyQp, headway_s: np.ndarray):
    """tree_ipm.TreeLayout of qp: numba loads at the first 3+-branch QP, not at import."""
    from marl_social.agents.robot.tree_ipm import TreeLayout

    return TreeLayout(qp, headway_s)

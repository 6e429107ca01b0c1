"""The contingency QP as an optimal control problem on its scenario tree, by an interior point.

ContingencyQp (agents/robot/qp.py) poses the MPC's QP over (a, v, s, c) with the dynamics as
equality rows; its L branches share only the trunk (its first n_trunk steps). Here the same QP
is a linear-quadratic control problem on a tree of nodes, one per acceleration variable (node j
is the variable a[j] of qp.py's numbering: the trunk's steps 0..n_trunk-1, then branch l's steps
n_trunk..N-1 at n_trunk + l (N - n_trunk) + k - n_trunk; each node's parent is the step before,
the trunk's last node the parent of every branch's first). Node j of step k has

* the state x = (v[k-1], s[k-1], a[k-1]) (speed [m/s], progress [m] and acceleration [m/s^2]
  at the start of its step; the root's is (v0, 0, the previous command)),
* the control u = (a[k], c[k]) (acceleration [m/s^2], comfort slack [m/s^2]),
* the next state F x + G u (exact for a piecewise-constant acceleration over dt),
* the cost 0.5 y' diag(alpha) y + beta' y of its outputs y = E (x, u) = (v[k], s[k],
  a[k] - a[k-1], a[k], c[k]) (a trunk node carries the sum of its branches' terms),
* seven rows D (x, u) in [lb, ub] (+-inf: none): speed, pass-before, stay-behind (with the
  step's headway), jerk, acceleration, comfort (a + c) and slack (c); a trunk node's speed and
  progress rows take the tightest of its L copies.

A primal-dual interior point method (Mehrotra's predictor-corrector, infeasible start) solves
it; each Newton step is one Riccati recursion over the tree (backward from the leaves, the
branches' value functions summed at the trunk's last node; forward from the root), so that a
step costs O(nodes) = O(n_trunk + L (N - n_trunk)) small dense operations: linear in L. The
primal iterate always meets the dynamics (it is rolled out from the root). It stops when the
constraints hold to PRIMAL_TOL, the complementarity mu is below MU_TOL and the stationarity of
the controls, with the costates of the current multipliers, holds to DUAL_TOL (relative): the
KKT conditions of the QP. At a degenerate optimum (more rows active than the controls, or
rows active with a zero multiplier: a robot held at a stop line over many steps) the iterate
settles while the multipliers drift: it stops there (status 3) and the caller makes the iterate
exact with the active-set solve (qp.py, active_set.solve_near). Without convergence within
MAX_ITER (an infeasible QP, or numerical trouble) it reports failure and the caller falls
back (qp.py: OSQP and the exact active set, which tells an infeasible QP).

The kernel is compiled by numba at its first call (cache=True: a few seconds once, then read
from the cache), deterministic (no fast-math, no threads).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numba
import numpy as np

from marl_social.sim.kernel_cache import will_compile

MAX_ITER = 40  # interior point iterations before giving up (a feasible QP needs ~15-25)
PRIMAL_TOL = 1e-9  # largest violation of a row [the row's unit: m, m/s, m/s^2]
DUAL_TOL = 1e-9  # stationarity residual, relative to max(1, |linear cost|)
MU_TOL = 1e-11  # mean complementarity slack x multiplier
STALL_MU = 1e-9  # below it, a growing dual residual stops the iterations (status 3) ...
STALL_DUAL = 1e3  # ... if it is this many times DUAL_TOL
STEP_FRACTION = 0.995  # of the longest step keeping slacks and multipliers positive
N_ROWS = 7  # speed, low, up, jerk, accel, comfort, slack
_NO_BOUND = 1e19  # qp.py's bounds beyond this are none (its infinity is 1e20)
_KERNELS_LOADED: list[bool] = []  # [True] once a TreeLayout has called the kernels

if will_compile(Path(__file__).parent, ("tree_ipm",)):  # the first 3+-branch QP compiles them
    logging.getLogger("marl_social").warning(
        "compiling the MPC's tree solver (numba) once (about 10 s; cached in %s for later runs)",
        Path(__file__).with_name("__pycache__"))


@numba.njit(cache=True)
def _riccati_factor(parent, hess, fg, quu_inv, gain, p_next, h):
    """Backward sweep of the matrices: per node Quu^-1 (2x2) and the gain K (2x3).

    Args:
        parent: (n,) parent node (-1: root); a node's parent has a smaller index.
        hess: (n, 5, 5) each node's Hessian in (x, u) (cost and barrier terms).
        fg: (3, 5) the dynamics [F G].
        quu_inv: (n, 2, 2) out.
        gain: (n, 2, 3) out.
        p_next: (n, 3, 3) work: the value functions' Hessians summed per parent.
        h: (5, 5) work.

    Returns:
        False if a node's control Hessian is not positive definite.
    """
    n = parent.shape[0]
    p_next[:] = 0.0
    for j in range(n - 1, -1, -1):
        # h = hess + fg' P fg
        for r in range(5):
            for c in range(5):
                acc = hess[j, r, c]
                for a in range(3):
                    if fg[a, r] != 0.0:
                        row = 0.0
                        for b in range(3):
                            row += p_next[j, a, b] * fg[b, c]
                        acc += fg[a, r] * row
                h[r, c] = acc
        a00, b01, d11 = h[3, 3], 0.5 * (h[3, 4] + h[4, 3]), h[4, 4]
        det = a00 * d11 - b01 * b01
        if not (a00 > 0.0 and det > 0.0):
            return False
        i00, i11, i01 = d11 / det, a00 / det, -b01 / det
        quu_inv[j, 0, 0], quu_inv[j, 1, 1] = i00, i11
        quu_inv[j, 0, 1] = quu_inv[j, 1, 0] = i01
        for c in range(3):
            gain[j, 0, c] = -(i00 * h[3, c] + i01 * h[4, c])
            gain[j, 1, c] = -(i01 * h[3, c] + i11 * h[4, c])
        pa = parent[j]
        if pa >= 0:
            for r in range(3):
                for c in range(3):
                    # P = hxx + hxu K, symmetrized
                    v1 = h[r, c] + h[r, 3] * gain[j, 0, c] + h[r, 4] * gain[j, 1, c]
                    v2 = h[c, r] + h[c, 3] * gain[j, 0, r] + h[c, 4] * gain[j, 1, r]
                    p_next[pa, r, c] += 0.5 * (v1 + v2)
    return True


@numba.njit(cache=True)
def _riccati_solve(parent, rho, fg, quu_inv, gain, dz, work):
    """The Newton step dz (n, 5) for the linear term rho (n, 5), with dx = 0 at the root.

    work: the work arrays (p_next (n, 3), feed (n, 2), dx_next (n, 3)).
    """
    p_next, feed, dx_next = work
    n = parent.shape[0]
    p_next[:] = 0.0
    q = np.empty(5)
    for j in range(n - 1, -1, -1):
        for r in range(5):
            q[r] = rho[j, r] + fg[0, r] * p_next[j, 0] + fg[1, r] * p_next[j, 1] \
                + fg[2, r] * p_next[j, 2]
        feed[j, 0] = -(quu_inv[j, 0, 0] * q[3] + quu_inv[j, 0, 1] * q[4])
        feed[j, 1] = -(quu_inv[j, 1, 0] * q[3] + quu_inv[j, 1, 1] * q[4])
        pa = parent[j]
        if pa >= 0:
            for r in range(3):
                p_next[pa, r] += q[r] + gain[j, 0, r] * q[3] + gain[j, 1, r] * q[4]
    for j in range(n):
        pa = parent[j]
        for r in range(3):
            dz[j, r] = dx_next[pa, r] if pa >= 0 else 0.0
        for u in range(2):
            dz[j, 3 + u] = (gain[j, u, 0] * dz[j, 0] + gain[j, u, 1] * dz[j, 1]
                            + gain[j, u, 2] * dz[j, 2] + feed[j, u])
        for r in range(3):
            acc = 0.0
            for c in range(5):
                acc += fg[r, c] * dz[j, c]
            dx_next[j, r] = acc


@numba.njit(cache=True)
def _rollout(parent, x0, fg, z, x_next):
    """The states of z (n, 5) from its controls, from the root state x0 (3,)."""
    for j in range(parent.shape[0]):
        pa = parent[j]
        for r in range(3):
            z[j, r] = x_next[pa, r] if pa >= 0 else x0[r]
        for r in range(3):
            acc = 0.0
            for c in range(5):
                acc += fg[r, c] * z[j, c]
            x_next[j, r] = acc


@numba.njit(cache=True)
def _dot5(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4]


@numba.njit(cache=True)
def tree_ipm(tree, x0, alpha, beta, lb, ub, settings):
    """Mehrotra's predictor-corrector on the tree QP (module docstring).

    Args:
        tree: the tree's fixed arrays (TreeLayout.tree), (parent, fg, out_rows, rows):
            parent (n,) int64 parent of each node (-1: the root), parents before children;
            fg (3, 5) the dynamics [F G]: next state = F x + G u; out_rows (5, 5) E, the
            outputs y = E (x, u) the cost is on; rows (n, 7, 5) each node's constraint rows D.
        x0: (3,) the root's state.
        alpha: (n, 5) quadratic cost of each output.
        beta: (n, 5) its linear cost.
        lb: (n, 7) lower bounds (-inf: none).
        ub: (n, 7) upper bounds (inf: none).
        settings: (7,) MAX_ITER, PRIMAL_TOL, DUAL_TOL, MU_TOL, STALL_MU, STALL_DUAL,
            STEP_FRACTION.

    Returns:
        (status, iterations, z, x_next, info): status 0 converged, 1 not within max_iter, 2 a
        singular Newton system, 3 stalled (primal feasible, mu <= stall_mu, the dual residual
        growing: a degenerate optimum, for the caller to polish); z (n, 5) the nodes' (x, u);
        x_next (n, 3) their next states; info (3,) the last primal residual, relative dual
        residual and mu.
    """
    parent, fg, out_rows, rows = tree
    max_iter, primal_tol, dual_tol, mu_tol = int(settings[0]), settings[1], settings[2], \
        settings[3]
    stall_mu, stall_dual, step_fraction = settings[4], settings[5], settings[6]
    n = parent.shape[0]
    m = 2 * N_ROWS * n
    # one-sided rows i = 2 (7 j + r) + side: side 0 D z - lb >= 0, side 1 ub - D z >= 0
    bound = np.empty(m)
    live = np.zeros(m, np.bool_)
    for j in range(n):
        for r in range(N_ROWS):
            i = 2 * (N_ROWS * j + r)
            bound[i], live[i] = lb[j, r], np.isfinite(lb[j, r])
            bound[i + 1], live[i + 1] = -ub[j, r], np.isfinite(ub[j, r])
    n_live = max(1, int(live.sum()))
    h0 = np.zeros((n, 5, 5))
    lin = np.zeros((n, 5))
    scale = 1.0
    for j in range(n):
        for o in range(5):
            for r in range(5):
                lin[j, r] += beta[j, o] * out_rows[o, r]
                for c in range(5):
                    h0[j, r, c] += alpha[j, o] * out_rows[o, r] * out_rows[o, c]
        for r in range(5):
            scale = max(scale, abs(lin[j, r]))
    z = np.zeros((n, 5))
    x_next = np.zeros((n, 3))
    for j in range(n):  # start: a = 0 within its bounds, the slack 1
        z[j, 3], z[j, 4] = min(max(0.0, lb[j, 4]), ub[j, 4]), 1.0
    _rollout(parent, x0, fg, z, x_next)
    value, slack, mult, resid_p = np.empty(m), np.ones(m), np.zeros(m), np.zeros(m)
    sigma, comp, d_slack, d_mult = np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m)
    grad, rho, dz = np.empty((n, 5)), np.empty((n, 5)), np.empty((n, 5))
    hess, quu_inv, gain = np.empty((n, 5, 5)), np.empty((n, 2, 2)), np.empty((n, 2, 3))
    work33, work3, work3b, work2 = (np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3)),
                                    np.empty((n, 2)))
    h55, info, last_d = np.empty((5, 5)), np.zeros(3), np.inf
    for it in range(max_iter + 1):
        for j in range(n):
            for r in range(N_ROWS):
                d = _dot5(rows[j, r], z[j])
                i = 2 * (N_ROWS * j + r)
                value[i] = d - bound[i]
                value[i + 1] = -d - bound[i + 1]
        if it == 0:
            for i in range(m):
                if live[i]:
                    slack[i], mult[i] = max(value[i], 1.0), 1.0
        mu = 0.0
        worst_p = 0.0
        for i in range(m):
            if live[i]:
                resid_p[i] = value[i] - slack[i]
                worst_p = max(worst_p, abs(resid_p[i]))
                mu += slack[i] * mult[i]
        mu /= n_live
        # gradient of the Lagrangian (without the dynamics) per node, then the costates
        for j in range(n):
            for r in range(5):
                acc = lin[j, r]
                for c in range(5):
                    acc += h0[j, r, c] * z[j, c]
                grad[j, r] = acc
            for r in range(N_ROWS):
                i = 2 * (N_ROWS * j + r)
                w = mult[i] - mult[i + 1]
                if w != 0.0:
                    for c in range(5):
                        grad[j, c] -= w * rows[j, r, c]
        work3[:] = 0.0
        worst_d = 0.0
        for j in range(n - 1, -1, -1):
            pa = parent[j]
            for r in range(5):
                q = grad[j, r] + fg[0, r] * work3[j, 0] + fg[1, r] * work3[j, 1] \
                    + fg[2, r] * work3[j, 2]
                if r >= 3:
                    worst_d = max(worst_d, abs(q))
                elif pa >= 0:
                    work3[pa, r] += q
        info[0], info[1], info[2] = worst_p, worst_d / scale, mu
        if worst_p <= primal_tol and worst_d <= dual_tol * scale and mu <= mu_tol:
            return 0, it, z, x_next, info
        if (worst_p <= primal_tol and mu <= stall_mu and worst_d > last_d
                and worst_d > stall_dual * dual_tol * scale):
            # the iterate has settled but its multipliers drift (a degenerate optimum, whose
            # multipliers are not unique or not bounded): the caller polishes the iterate
            return 3, it, z, x_next, info
        last_d = worst_d
        if it == max_iter:
            break
        if worst_p <= primal_tol:
            # feasible up to rounding: a residual of a row's rounding (a progress of 50 m
            # has ulps of 1e-14) times mult / slack (1e14 and more at the end) would swamp
            # the multipliers' steps; the iterate is taken as feasible instead
            resid_p[:] = 0.0
        for i in range(m):
            sigma[i] = mult[i] / slack[i] if live[i] else 0.0
        for j in range(n):
            for r in range(5):
                for c in range(5):
                    hess[j, r, c] = h0[j, r, c]
            for r in range(N_ROWS):
                i = 2 * (N_ROWS * j + r)
                w = sigma[i] + sigma[i + 1]
                if w != 0.0:
                    for a in range(5):
                        wa = w * rows[j, r, a]
                        if wa != 0.0:
                            for c in range(5):
                                hess[j, a, c] += wa * rows[j, r, c]
        if not _riccati_factor(parent, hess, fg, quu_inv, gain, work33, h55):
            return 2, it, z, x_next, info
        step = 1.0
        target = 0.0
        for corrector in range(2):
            # rc = slack * mult (+ the predictor's second-order term - sigma mu) per row
            for i in range(m):
                if live[i]:
                    comp[i] = slack[i] * mult[i]
                    if corrector:
                        comp[i] += d_slack[i] * d_mult[i] - target
            for j in range(n):
                for c in range(5):
                    rho[j, c] = grad[j, c]
                for r in range(N_ROWS):
                    i = 2 * (N_ROWS * j + r)
                    c0 = sigma[i] * resid_p[i] + comp[i] / slack[i] if live[i] else 0.0
                    c1 = (sigma[i + 1] * resid_p[i + 1] + comp[i + 1] / slack[i + 1]
                          if live[i + 1] else 0.0)
                    w = c0 - c1
                    if w != 0.0:
                        for c in range(5):
                            rho[j, c] += w * rows[j, r, c]
            _riccati_solve(parent, rho, fg, quu_inv, gain, dz, (work3, work2, work3b))
            step = 1.0
            for j in range(n):
                for r in range(N_ROWS):
                    d = _dot5(rows[j, r], dz[j])
                    i = 2 * (N_ROWS * j + r)
                    for side in range(2):
                        k = i + side
                        if live[k]:
                            dv = d if side == 0 else -d
                            d_slack[k] = dv + resid_p[k]
                            d_mult[k] = -sigma[k] * (resid_p[k] + dv) - comp[k] / slack[k]
                            if d_slack[k] < 0.0:
                                step = min(step, -slack[k] / d_slack[k])
                            if d_mult[k] < 0.0:
                                step = min(step, -mult[k] / d_mult[k])
            if corrector == 0:
                mu_aff = 0.0
                for i in range(m):
                    if live[i]:
                        mu_aff += (slack[i] + step * d_slack[i]) * (mult[i] + step * d_mult[i])
                mu_aff /= n_live
                target = (mu_aff / mu) ** 3 * mu if mu > 0.0 else 0.0
        step = min(1.0, step_fraction * step)
        for j in range(n):
            z[j, 3] += step * dz[j, 3]
            z[j, 4] += step * dz[j, 4]
        _rollout(parent, x0, fg, z, x_next)
        for i in range(m):
            if live[i]:
                slack[i] += step * d_slack[i]
                mult[i] += step * d_mult[i]
    return 1, max_iter, z, x_next, info


def _settings() -> np.ndarray:
    """(7,) `tree_ipm`'s settings from this module's constants."""
    return np.array([MAX_ITER, PRIMAL_TOL, DUAL_TOL, MU_TOL, STALL_MU, STALL_DUAL,
                     STEP_FRACTION], dtype=np.float64)


class TreeLayout:
    """The tree of one ContingencyQp layout: nodes, dynamics, rows, and where qp.py keeps them.

    Args:
        qp: a ContingencyQp (its structure: index maps, rows, steps, headway via A).
        headway_s: (N,) the stay-behind rows' time headway [s].
    """

    def __init__(self, qp, headway_s: np.ndarray):
        L, N, nt, dt = qp.n_branches, qp.n_steps, qp.n_trunk, qp.dt_s
        self.n_trunk, self.n_vars, self._c_off = nt, qp.n_vars, qp._c_off
        n = qp._v_off  # one node per acceleration variable
        self.n_nodes = n
        self.parent = np.arange(-1, n - 1, dtype=np.int64)
        self.parent[qp._a_idx[:, nt]] = nt - 1
        step = np.empty(n, np.int64)
        step[qp._a_idx] = np.arange(N)[None, :]
        self.step = step
        self.fg = np.array([[1.0, 0.0, 0.0, dt, 0.0],
                            [dt, 1.0, 0.0, 0.5 * dt * dt, 0.0],
                            [0.0, 0.0, 0.0, 1.0, 0.0]])
        self.out_rows = np.array([self.fg[0], self.fg[1], [0.0, 0.0, -1.0, 1.0, 0.0],
                                  [0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0]])
        h = np.asarray(headway_s, dtype=np.float64)[step]
        rows = np.zeros((n, N_ROWS, 5))
        rows[:, 0] = self.fg[0]
        rows[:, 1] = self.fg[1]
        rows[:, 2] = self.fg[1] + h[:, None] * self.fg[0]
        rows[:, 3] = self.out_rows[2]
        rows[:, 4] = self.out_rows[3]
        rows[:, 5] = [0.0, 0.0, 0.0, 1.0, 1.0]
        rows[:, 6] = self.out_rows[4]
        self.rows = rows
        self.tree = (self.parent, self.fg, self.out_rows, rows)  # tree_ipm's fixed arrays
        r = qp._rows
        self._grid = np.stack([r["speed"], r["low"], r["up"]])  # (3, L, N) qp.py's rows
        self._var_rows = np.stack([r["jerk"], r["accel"], r["comfort"], r["slack"]], axis=1)
        self._branch_nodes = qp._a_idx[:, nt:]  # (L, N - nt)
        self._a_idx, self._v_idx, self._s_idx = qp._a_idx, qp._v_idx, qp._s_idx
        self._comfort_rows = r["comfort"]
        # which branches share each node (the trunk: all)
        member = np.zeros((n, L))
        member[qp._a_idx, np.arange(L)[:, None]] = 1.0
        self._member = member
        if not _KERNELS_LOADED:  # numba loads (or compiles) the kernels at their first call
            self._load_kernels()
            _KERNELS_LOADED.append(True)

    def _load_kernels(self) -> None:
        """One solve of this tree without rows: numba loads the kernels now, with the layout.

        Loading them from numba's cache takes ~0.1 s; the first 3+-branch layout is built
        ahead of the plans (mpc.py, `ContingencyMpc.build_layouts`), so that no plan does.
        """
        n = self.n_nodes
        free = np.full((n, N_ROWS), np.inf)
        tree_ipm(self.tree, np.zeros(3), np.ones((n, 5)), np.zeros((n, 5)), -free, free,
                 _settings())

    def bounds(self, lower: np.ndarray, upper: np.ndarray, prev_accel: float
               ) -> tuple[np.ndarray, np.ndarray]:
        """(n, 7) lb and ub of the nodes' rows from qp.py's (m,) bounds (+-inf: none).

        The root's jerk row is a[0] - a[-1] here, qp.py's a[0]: shifted by the previous
        command [m/s^2].
        """
        nt = self.n_trunk
        lb = np.empty((self.n_nodes, N_ROWS))
        ub = np.empty((self.n_nodes, N_ROWS))
        grid_lo, grid_up = lower[self._grid], upper[self._grid]  # (3, L, N)
        lb[:nt, :3] = grid_lo[:, :, :nt].max(axis=1).T
        ub[:nt, :3] = grid_up[:, :, :nt].min(axis=1).T
        lb[self._branch_nodes, :3] = np.moveaxis(grid_lo[:, :, nt:], 0, -1)
        ub[self._branch_nodes, :3] = np.moveaxis(grid_up[:, :, nt:], 0, -1)
        lb[:, 3:] = lower[self._var_rows]
        ub[:, 3:] = upper[self._var_rows]
        lb[0, 3] -= prev_accel
        ub[0, 3] -= prev_accel
        lb[lb <= -_NO_BOUND] = -np.inf
        ub[ub >= _NO_BOUND] = np.inf
        return lb, ub

    def costs(self, weights: np.ndarray, comfort: np.ndarray | None, goal_weight: float,
              goal_m: float, v_ref_mps: float, qp_weights, dt: float, first_dt: float
              ) -> tuple[np.ndarray, np.ndarray]:
        """(n, 5) alpha and beta of the outputs (v, s, jerk, a, c) per node (qp.py's cost)."""
        node_w = self._member @ weights
        comfort_w = weights if comfort is None else weights * comfort
        node_c = self._member @ comfort_w
        jerk = np.where(self.step == 0, qp_weights.jerk * dt / first_dt ** 2,
                        qp_weights.jerk / dt)
        alpha = 2.0 * np.column_stack([qp_weights.speed * dt * node_w,
                                       goal_weight * dt * node_w, jerk * node_w,
                                       qp_weights.accel * dt * node_w,
                                       qp_weights.comfort * dt * node_c])
        beta = np.zeros_like(alpha)
        beta[:, 0] = -2.0 * qp_weights.speed * dt * v_ref_mps * node_w
        beta[:, 1] = -2.0 * goal_weight * dt * goal_m * node_w
        return alpha, beta

    def solve(self, alpha: np.ndarray, beta: np.ndarray, lb: np.ndarray, ub: np.ndarray,
              x0: np.ndarray, lower: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
        """(status, x, info): `tree_ipm`'s status and info, x (n_vars,) qp.py's (a, v, s, c).

        Args:
            alpha: (n, 5) the nodes' quadratic costs (`costs`).
            beta: (n, 5) their linear costs.
            lb: (n, 7) the nodes' lower bounds (`bounds`).
            ub: (n, 7) their upper bounds.
            x0: (3,) the root's state: speed [m/s], 0 [m], the previous command [m/s^2].
            lower: (m,) qp.py's lower bounds (its comfort rows give the slacks).

        A node whose slack costs nothing (every branch through it has comfort factor 0) has
        its comfort and slack rows dropped and a unit cost on its slack (which then stays 0).
        x's slacks are the braking beyond the comfortable deceleration: the optimum's where a
        slack costs, a value meeting the rows at no cost where it does not.
        """
        free = alpha[:, 4] <= 0.0
        if free.any():
            alpha = alpha.copy()
            alpha[free, 4] = 1.0
            lb, ub = lb.copy(), ub.copy()
            lb[free, 5:] = -np.inf
            ub[free, 5:] = np.inf
        status, _, z, x_next, info = tree_ipm(self.tree, x0, alpha, beta, lb, ub, _settings())
        x = np.zeros(self.n_vars)
        accel = z[:, 3]
        x[:self.n_nodes] = accel
        x[self._v_idx] = x_next[self._a_idx, 0]
        x[self._s_idx] = x_next[self._a_idx, 1]
        comfort_lower = lower[self._comfort_rows]
        x[self._c_off:] = np.where(comfort_lower > -_NO_BOUND,
                                   np.maximum(0.0, comfort_lower - accel), 0.0)
        return status, x, info

"""The contingency QP condensed onto its accelerations and comfort slacks, solved by DAQP.

ContingencyQp (agents/robot/qp.py) poses the MPC's QP over x = (a, v, s, c): accelerations,
speeds, progress and comfort slacks, with the dynamics as equality rows. The dynamics fix v and
s given a and the current speed v0, x = T z + v0 t_v0 with z = (a, c), T and t_v0 depending only
on the layout (L, N, n_trunk, steps). On z the QP is small, dense and strictly convex:

    min 0.5 z'Hz + f'z   s.t.   lb <= z <= ub (acceleration, slack),  bl <= M z <= bu,

H = T'PT, f = T'(P t_v0 v0 + q), M = A_ineq T (speed, pass-before, stay-behind, jerk and comfort
rows; the trunk steps' rows, identical in every branch, once with the tightest bound). P's
values change per step only through per-branch factors (the belief w_l, w_l x comfort factor,
w_l x pull-up weight), so H is a weighted sum of blocks T'P_kT precomputed per layout. DAQP
(Arnstrom, Bemporad, Axehill, IEEE TAC 2022: a dual active-set method) solves it exactly.

A comfort slack whose weight is zero this step (every branch sharing it has comfort factor 0)
would make H singular: it is fixed at 0 with its comfort row dropped (braking beyond the
comfortable deceleration is then free, as in the sparse QP); the solution's slack is then set
to the braking beyond it, which meets the sparse QP's comfort row at no cost.
"""

from __future__ import annotations

import functools

import daqp
import numpy as np
import scipy.sparse as sp

from marl_social.sim.kernel_cache import load_kernels

_SOLVED = (1, 2)  # DAQP's exit flags of an optimum (2: optimal, soft constraints violated)


@functools.cache  # once per solve: a cached call, not load_kernels' lookup
def qp_kernels():
    """agents/robot/qp_kernels.py (row bounds, DAQP's inputs, the full solution), loaded once."""
    return load_kernels("marl_social.agents.robot", ("qp_kernels",),
                        "the MPC's QP kernels", 5)[0]


class CondensedLayout:
    """T, t_v0, the cost blocks and the condensed rows of one ContingencyQp layout.

    Attributes:
        t_matrix: (n, nz) T, x = T z + v0 t_v0 (n: the sparse QP's variables, nz = 2 n_accel).
        t_v0: (n,) the speeds [m/s per m/s] and positions [m per m/s] of a unit v0, a = c = 0.
        h_blocks: (3L, nz, nz) T'P_kT per factor k (w_l; w_l x comfort_l; w_l x w_g).
        f_blocks: (3L, nz) T'P_k t_v0; c_blocks: (3L,) t_v0'P_k t_v0.
        m_matrix: (n_general, nz) the condensed rows M; m_v0: (n_general,) M's shift per v0.

    Args:
        qp: a ContingencyQp (its structure: index maps, P's triples, A, rows).
    """

    def __init__(self, qp):
        L, N, nt = qp.n_branches, qp.n_steps, qp.n_trunk
        n, n_a, dt = qp.n_vars, qp._v_off, qp.dt_s
        self.n_branches, self.n_steps, self.n_trunk, self.n_accel = L, N, nt, n_a
        a_matrix = qp._a_matrix.toarray()
        rows = qp._rows
        z_cols = np.concatenate([np.arange(n_a), qp._c_off + np.arange(n_a)])
        vs_cols = np.arange(qp._v_off, qp._c_off)
        dyn = np.concatenate([rows["dyn_v"].ravel(), rows["dyn_s"].ravel()])
        rhs_v0 = np.zeros(a_matrix.shape[0])  # the dynamics rows' right side per unit of v0
        rhs_v0[rows["dyn_v"][:, 0]] = 1.0
        rhs_v0[rows["dyn_s"][:, 0]] = dt
        e_vs = a_matrix[np.ix_(dyn, vs_cols)]
        e_z = a_matrix[np.ix_(dyn, z_cols)]
        sol = np.linalg.solve(e_vs, np.column_stack([-e_z, rhs_v0[dyn]]))
        nz = 2 * n_a
        t = np.zeros((n, nz))
        t[z_cols, np.arange(nz)] = 1.0
        t[vs_cols] = sol[:, :nz]
        t_v0 = np.zeros(n)
        t_v0[vs_cols] = sol[:, nz]
        self.t_matrix, self.t_v0 = t, t_v0
        self.nz = nz
        # cost blocks: kind 0 (factor w_l), 1 (w_l x comfort factor), 2 (w_l x pull-up weight)
        slot_rows, slot_cols = qp._p_rows[qp._p_slot], qp._p_cols[qp._p_slot]
        kind = np.where(qp._p_comfort, 1, 0)
        keep = ~np.isin(qp._p_slot, qp._p_progress_slot)  # the pull-up entries: below
        block = kind[keep] * L + qp._p_branch[keep]
        i, j, coef = slot_rows[keep], slot_cols[keep], qp._p_coef[keep]
        off = i != j
        s_idx = qp._s_idx.ravel()
        goal_block = 2 * L + np.repeat(np.arange(L), N)
        entries = (np.concatenate([block, block[off], goal_block]),
                   np.concatenate([i, j[off], s_idx]), np.concatenate([j, i[off], s_idx]),
                   np.concatenate([coef, coef[off], np.full(L * N, 2.0 * dt)]))
        h_blocks = np.zeros((3 * L, nz, nz))
        f_blocks = np.zeros((3 * L, nz))
        c_blocks = np.zeros(3 * L)
        for k in range(3 * L):
            mine = entries[0] == k
            p_k = sp.csr_matrix((entries[3][mine], (entries[1][mine], entries[2][mine])),
                                shape=(n, n))
            pt = p_k @ t
            h_blocks[k] = t.T @ pt
            p_t0 = p_k @ t_v0
            f_blocks[k] = t.T @ p_t0
            c_blocks[k] = t_v0 @ p_t0
        self.h_blocks, self.f_blocks, self.c_blocks = h_blocks, f_blocks, c_blocks
        self._h_flat = h_blocks.reshape(3 * L, nz * nz)  # np.tensordot(factors, h_blocks, 1)
        # the condensed rows: speed, low, up (trunk once), jerk, comfort
        trunk_first = np.zeros((L, N), bool)
        trunk_first[0, :nt] = True
        trunk_first[:, nt:] = True
        general = np.concatenate([rows["speed"][trunk_first], rows["low"][trunk_first],
                                  rows["up"][trunk_first], rows["jerk"], rows["comfort"]])
        self.m_matrix = np.ascontiguousarray(a_matrix[general] @ t)
        self.m_v0 = a_matrix[general] @ t_v0
        self._accel_rows = rows["accel"]
        self._slack_rows = rows["comfort"]  # a + c >= -comfort_decel, one per slack
        # which branches share each acceleration (and slack) variable
        member = np.zeros((n_a, L))
        member[qp._a_idx, np.arange(L)[:, None]] = 1.0
        self._member = member
        self.n_general = len(general)
        # the condensed rows' sources: a trunk row has L (one per branch, in _trunk_rows'
        # columns), every other row one
        grids = (rows["speed"], rows["low"], rows["up"])
        n_grid = int(trunk_first.sum())
        position = np.arange(3 * n_grid).reshape(3, n_grid)
        self._trunk_rows = np.concatenate([g[:, :nt] for g in grids], axis=1)  # (L, 3 nt)
        self._trunk_pos = position[:, :nt].ravel()
        self._single_rows = np.concatenate([g[:, nt:].ravel() for g in grids]
                                           + [rows["jerk"], rows["comfort"]])
        self._single_pos = np.concatenate([position[:, nt:].ravel(),
                                           np.arange(3 * n_grid, len(general))])
        # what qp_kernels.daqp_inputs reads of this layout at every solve
        self._condensed_rows = (self.m_matrix, self.m_v0, self._trunk_rows, self._trunk_pos,
                                self._single_rows, self._single_pos, self._accel_rows)

    def solve(self, weights: np.ndarray, comfort: np.ndarray | None, goal_weight: float,
              q: np.ndarray, lower: np.ndarray, upper: np.ndarray, v0: float
              ) -> tuple[np.ndarray, float] | None:
        """The optimum (x, 0.5 x'Px + q'x) of the sparse QP, or None if DAQP fails.

        Args:
            weights: (L,) branch probabilities.
            comfort: (L,) comfort weight factors (None: 1).
            goal_weight: the pull-up weight w_g [1 / m^2 / s].
            q: (n,) the sparse QP's linear cost.
            lower: (m,) the sparse QP's lower bounds (qp.py's rows).
            upper: (m,) its upper bounds.
            v0: current speed [m/s].

        Returns:
            x: (n,) the sparse QP's variables (a, v, s, c); cost: its objective. None when DAQP
            reports no optimum (infeasible, singular, iteration limit): the caller's fallback.
        """
        n_a = self.n_accel
        comfort_w = weights if comfort is None else weights * comfort
        factors = np.concatenate([weights, comfort_w, weights * goal_weight])
        free = np.concatenate([np.ones(n_a, bool), self._member @ comfort_w > 0.0])
        h_full = np.dot(factors[None], self._h_flat).reshape(self.nz, self.nz)
        f_full = v0 * (factors @ self.f_blocks) + self.t_matrix.T @ q
        h, f, m, b_upper, b_lower = qp_kernels().daqp_inputs(
            h_full, f_full, float(v0), lower, upper, self._condensed_rows, free)
        z_free, fval, exitflag, _ = daqp.solve(h, f, m, b_upper, b_lower,
                                               np.zeros(len(b_lower), np.int32))
        if exitflag not in _SOLVED or not np.all(np.isfinite(z_free)):
            return None
        # a slack of weight 0 takes the braking beyond the comfortable deceleration: the sparse
        # QP's comfort row holds, at no cost
        z = qp_kernels().full_solution(z_free, free, lower, self._slack_rows)
        x = self.t_matrix @ z + v0 * self.t_v0
        const = 0.5 * v0 * v0 * float(factors @ self.c_blocks) + v0 * float(q @ self.t_v0)
        return x, float(fval) + const

"""An exact, verified solve of a convex QP from a guess of its active constraints.

min 0.5 x'Px + q'x  s.t.  l <= Ax <= u (P positive semidefinite, its sparsity fixed; rows with
l == u are equalities). OSQP (ADMM) needs thousands of iterations on a few of the MPC's QPs
(agents/robot/qp.py): a robot at rest kept within centimetres of where it stands by a
stay-behind bound, so that many speed, position and dynamics rows are active at once and
their multipliers are not unique (a degenerate optimum), or a speed bound active over the
whole horizon. After a few hundred iterations its iterate usually already tells which rows are
active; with them, the optimum solves one linear (KKT) system

    [P    A_a'] [x  ]   [-q ]
    [A_a  0   ] [y_a] = [b_a],    b_a = the bound each active row is at,

solved with a small regularization (dependent active rows) and iterative refinement, as
OSQP's own polishing does. Unlike a polish, the result is accepted only if it meets every KKT
condition of the full problem, which makes it the optimum whatever the guess was: primal
feasibility, stationarity Px + q + A'y = 0, and multipliers of the right sign (>= 0 at an
upper bound, <= 0 at a lower one; OSQP's convention). A wrong guess is corrected a few times
(a row whose multiplier has the wrong sign leaves the set, a violated row joins it); if it
still fails, None, and the caller goes on iterating.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

REGULARIZATION = 1e-9  # on the KKT system's diagonal (dependent active rows)
REFINEMENT_STEPS = 3  # iterative refinement against the unregularized system
CORRECTIONS = 4  # active-set corrections after the first guess
PRIMAL_TOL = 1e-7  # largest violation of a bound accepted [the row's unit: m, m/s, m/s^2]
DUAL_TOL = 1e-7  # stationarity residual and wrong-sign multiplier accepted, relative to |q|


class ActiveSetSolver:
    """Solves the QPs of one sparsity pattern from an active-set guess (module docstring).

    Args:
        p_rows: (nnz,) row of each entry of P's upper triangle.
        p_cols: (nnz,) its column.
        a_matrix: (m, n) the constraint matrix A (fixed).
    """

    def __init__(self, p_rows: np.ndarray, p_cols: np.ndarray, a_matrix: sp.csc_matrix):
        self.n_vars, self.n_rows = a_matrix.shape[1], a_matrix.shape[0]
        off = p_rows != p_cols  # the lower triangle mirrors these
        self._p_i = np.concatenate([p_rows, p_cols[off]])
        self._p_j = np.concatenate([p_cols, p_rows[off]])
        self._p_take = np.concatenate([np.arange(len(p_rows)), np.flatnonzero(off)])
        coo = a_matrix.tocoo()
        self._a_i, self._a_j, self._a_v = coo.row, coo.col, coo.data
        self._a = a_matrix.tocsr()
        self._a_t = a_matrix.T.tocsr()

    def solve(self, p_values: np.ndarray, q: np.ndarray, lower: np.ndarray, upper: np.ndarray,
              x_guess: np.ndarray, y_guess: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The verified optimum (x, y, 0.5 x'Px + q'x) from an iterate's guess; None if not.

        Args:
            p_values: (nnz,) the values of P's upper triangle (the constructor's entries).
            q: (n,) the linear cost.
            lower: (m,) lower bounds (very negative: none).
            upper: (m,) upper bounds (very large: none).
            x_guess: (n,) the iterate's primal variables.
            y_guess: (m,) its multipliers (> 0 pushing against an upper bound).
        """
        n = self.n_vars
        p_full = sp.csr_matrix((p_values[self._p_take], (self._p_i, self._p_j)), shape=(n, n))
        equality = lower == upper
        z = self._a @ x_guess
        # OSQP's polishing rule: a row is active at the bound its multiplier pushes against
        at_lower = equality | (z - lower < -y_guess)
        at_upper = ~at_lower & (upper - z < y_guess)
        tol = DUAL_TOL * max(1.0, float(np.max(np.abs(q))))
        for _ in range(CORRECTIONS + 1):
            active = at_lower | at_upper
            bound = np.where(at_lower, lower, upper)
            solved = self._kkt_solve(p_full, p_values, q, active, bound)
            if solved is None:
                return None
            x, y = solved
            ax = self._a @ x
            violated_low = ax < lower - PRIMAL_TOL
            violated_up = ax > upper + PRIMAL_TOL
            wrong_sign = ~equality & ((at_lower & (y > tol)) | (at_upper & (y < -tol)))
            stationarity = p_full @ x + q + self._a_t @ y
            if not (violated_low.any() or violated_up.any() or wrong_sign.any()):
                if float(np.max(np.abs(stationarity))) > tol:
                    return None
                return x, y, 0.5 * float(x @ (p_full @ x)) + float(q @ x)
            at_lower = (at_lower & ~wrong_sign) | violated_low
            at_upper = (at_upper & ~wrong_sign & ~at_lower) | violated_up
        return None

    def _kkt_solve(self, p_full: sp.csr_matrix, p_values: np.ndarray, q: np.ndarray,
                   active: np.ndarray, bound: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray] | None:
        """(x, y) of the QP with the active rows as equalities, y zero on the others."""
        n = self.n_vars
        rank = np.cumsum(active) - 1 + n  # KKT index of each active row
        keep = active[self._a_i]
        a_i, a_j, a_v = rank[self._a_i[keep]], self._a_j[keep], self._a_v[keep]
        size = n + int(active.sum())
        diag = np.arange(size)
        reg = np.where(diag < n, REGULARIZATION, -REGULARIZATION)
        kkt = sp.csc_matrix((np.concatenate([p_values[self._p_take], a_v, a_v, reg]),
                             (np.concatenate([self._p_i, a_i, a_j, diag]),
                              np.concatenate([self._p_j, a_j, a_i, diag]))), shape=(size, size))
        try:
            factor = spla.splu(kkt)
        except RuntimeError:  # singular even with the regularization
            return None
        b = bound[active]
        rhs = np.concatenate([-q, b])
        sol = factor.solve(rhs)
        y = np.zeros(self.n_rows)
        for _ in range(REFINEMENT_STEPS):  # against the unregularized system
            y[active] = sol[n:]
            x = sol[:n]
            residual = np.concatenate([-q - p_full @ x - self._a_t @ y, b - (self._a @ x)[active]])
            sol = sol + factor.solve(residual)
        if not np.all(np.isfinite(sol)):
            return None
        y[active] = sol[n:]
        return sol[:n], y

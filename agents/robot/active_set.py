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
still fails, a second guess takes every row within NEAR_BOUND of a bound as active (at a
degenerate optimum the iterate's multipliers are the slowest to settle: its position already
shows the active rows), corrected the same way; if that fails too, None, and the caller goes on
iterating.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

try:  # the compiled kernels behind scipy's `csr @ x` and spla.splu, called without their
    # per-call Python checks and dispatch (_matvec, _lu_factor); the public calls otherwise
    from scipy.sparse import _sparsetools
    from scipy.sparse.linalg._dsolve import _superlu
except ImportError:  # pragma: no cover - a scipy without these modules
    _sparsetools = _superlu = None

REGULARIZATION = 1e-9  # on the KKT system's diagonal (dependent active rows)
REFINEMENT_STEPS = 3  # iterative refinement against the unregularized system
CORRECTIONS = 4  # active-set corrections after the first guess
PRIMAL_TOL = 1e-7  # largest violation of a bound accepted [the row's unit: m, m/s, m/s^2]
DUAL_TOL = 1e-7  # stationarity residual and wrong-sign multiplier accepted, relative to |q|
NEAR_BOUND = 1e-2  # the second guess: the rows this close to a bound [the row's unit]


# spla.splu's defaults, as it hands them to gstrf (COLAMD ordering, SuperLU's pivoting)
_SPLU_OPTIONS = {"DiagPivotThresh": None, "ColPerm": None, "PanelSize": None, "Relax": None}


def _matvec(matrix: sp.csr_matrix, x: np.ndarray) -> np.ndarray:
    """(m,) matrix @ x by scipy's own kernel: the same sums in the same order as `@`.

    Without the ~10 us of `@`'s Python dispatch.

    Args:
        matrix: (m, n) float64 CSR matrix.
        x: (n,) float64 vector.
    """
    if _sparsetools is None:
        return matrix @ x
    out = np.zeros(matrix.shape[0])
    _sparsetools.csr_matvec(matrix.shape[0], matrix.shape[1], matrix.indptr, matrix.indices,
                            matrix.data, x, out)
    return out


def _lu_factor(values: np.ndarray, indices: np.ndarray, indptr: np.ndarray, size: int):
    """SuperLU factorization of a canonical CSC matrix: spla.splu's call of gstrf.

    The same call with splu's defaults, without building a sparse matrix object and its format
    checks. Raises RuntimeError if the matrix is singular (as splu).

    Args:
        values: (nnz,) float64 entries, by column, rows sorted in each column, no duplicates.
        indices: (nnz,) their rows.
        indptr: (size + 1,) where each column starts in values.
        size: the matrix is (size, size).
    """
    if _superlu is None:
        return spla.splu(sp.csc_matrix((values, indices, indptr), shape=(size, size)))
    return _superlu.gstrf(size, len(values), values, indices.astype(np.intc),
                          indptr.astype(np.intc), csc_construct_func=sp.csc_array, ilu=False,
                          options=_SPLU_OPTIONS)


class _Prepared(NamedTuple):
    """One QP as `_corrected` reads it (`_prepare`).

    Attributes:
        p_full: (n, n) P, both triangles.
        kkt_values: the KKT template's values (_build_kkt_template), regularized.
        q: (n,) the linear cost.
        lower: (m,) lower bounds.
        upper: (m,) upper bounds.
        equality: (m,) bool, the rows with lower == upper.
        tol: the dual tolerance (DUAL_TOL relative to |q|).
    """

    p_full: sp.csr_matrix
    kkt_values: np.ndarray
    q: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    equality: np.ndarray
    tol: float


class ActiveSetSolver:
    """Solves the QPs of one sparsity pattern from an active-set guess (module docstring).

    The KKT matrix of every active set is a part of one template, the KKT matrix with every row
    of A active, in compressed sparse column form (rows sorted in each column, P's diagonal and
    the regularization summed: what scipy.sparse makes of the same entries): dropping the
    inactive rows and columns keeps that order, so that each solve selects its entries with a
    few array operations instead of assembling and sorting a sparse matrix.

    Args:
        p_rows: (nnz,) row of each entry of P's upper triangle.
        p_cols: (nnz,) its column.
        a_matrix: (m, n) the constraint matrix A (fixed).
    """

    def __init__(self, p_rows: np.ndarray, p_cols: np.ndarray, a_matrix: sp.csc_matrix):
        self.n_vars, self.n_rows = a_matrix.shape[1], a_matrix.shape[0]
        n = self.n_vars
        off = p_rows != p_cols  # the lower triangle mirrors these
        self._p_i = np.concatenate([p_rows, p_cols[off]])
        self._p_j = np.concatenate([p_cols, p_rows[off]])
        self._p_take = np.concatenate([np.arange(len(p_rows)), np.flatnonzero(off)])
        coo = a_matrix.tocoo()
        self._a_i, self._a_j, self._a_v = coo.row, coo.col, coo.data
        self._a = a_matrix.tocsr()
        self._a_t = a_matrix.T.tocsr()
        # the full P (both triangles) as scipy builds it from these entries; solve sets its
        # values: entry k of its data is p_values[_p_full_take[k]]
        self._p_full = sp.csr_matrix((np.arange(1.0, len(self._p_i) + 1.0),
                                      (self._p_i, self._p_j)), shape=(n, n))
        self._p_full_take = self._p_take[self._p_full.data.astype(np.intp) - 1]
        self._build_kkt_template()

    def _build_kkt_template(self) -> None:
        """The (n + m)-square KKT matrix of every row active, by column, rows sorted.

        Entries: P (both triangles; a diagonal entry of value 0 where P has none, which the
        regularization then makes the entry scipy would make of it alone), A' below P, A to the
        right of P, -REGULARIZATION on the multipliers' diagonal; +REGULARIZATION is added to
        P's diagonal (solve).
        """
        n, m = self.n_vars, self.n_rows
        missing = np.setdiff1d(np.arange(n), self._p_i[self._p_i == self._p_j])
        p_i = np.concatenate([self._p_i, missing])
        p_j = np.concatenate([self._p_j, missing])
        n_p, n_a = len(p_i), len(self._a_i)
        rows = np.concatenate([p_i, n + self._a_i, self._a_j, n + np.arange(m)])
        cols = np.concatenate([p_j, self._a_j, n + self._a_i, n + np.arange(m)])
        order = np.lexsort((rows, cols))  # by column, then row
        if np.any((np.diff(cols[order]) == 0) & (np.diff(rows[order]) == 0)):
            raise ValueError("ActiveSetSolver: duplicate entries in P or A")
        self._t_rows, self._t_cols = rows[order], cols[order]
        source = np.argsort(order)  # template position of each entry above
        # the entries of P's values: template position and index into p_values
        self._t_p_pos = source[:len(self._p_i)]
        constant = np.zeros(len(rows))
        constant[source[n_p:n_p + n_a]] = self._a_v
        constant[source[n_p + n_a:n_p + 2 * n_a]] = self._a_v
        constant[source[n_p + 2 * n_a:]] = -REGULARIZATION
        self._t_constant = constant
        diagonal = (self._t_rows == self._t_cols) & (self._t_rows < n)
        self._t_x_diagonal = np.flatnonzero(diagonal)

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
        qp = self._prepare(p_values, q, lower, upper)
        equality = qp.equality
        z = _matvec(self._a, x_guess)
        # OSQP's polishing rule: a row is active at the bound its multiplier pushes against
        at_lower = equality | (z - lower < -y_guess)
        at_upper = ~at_lower & (upper - z < y_guess)
        exact = self._corrected(qp, at_lower, at_upper)
        if exact is not None:
            return exact
        # the second guess: every row within NEAR_BOUND of a bound, whatever its multiplier (a
        # degenerate optimum, whose multipliers the iterate has not sorted out yet)
        near_lower = equality | (z - lower < NEAR_BOUND)
        near_upper = ~near_lower & (upper - z < NEAR_BOUND)
        if np.array_equal(near_lower, at_lower) and np.array_equal(near_upper, at_upper):
            return None
        return self._corrected(qp, near_lower, near_upper)

    def solve_near(self, p_values: np.ndarray, q: np.ndarray, lower: np.ndarray,
                   upper: np.ndarray, x_guess: np.ndarray, near: float
                   ) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The verified optimum from a primal guess alone: the rows within `near` of a bound.

        For a guess that is already (nearly) optimal, from a method whose multipliers are
        not to be trusted (agents/robot/tree_ipm.py at a degenerate optimum); corrected as
        `solve`'s guesses. Arguments as `solve`; near in the rows' units.
        """
        qp = self._prepare(p_values, q, lower, upper)
        equality = qp.equality
        z = _matvec(self._a, x_guess)
        near_lower = equality | (z - lower < near)
        near_upper = ~near_lower & (upper - z < near)
        return self._corrected(qp, near_lower, near_upper)

    def _prepare(self, p_values: np.ndarray, q: np.ndarray, lower: np.ndarray,
                 upper: np.ndarray) -> _Prepared:
        """P (both triangles), the regularized KKT values, the equality rows, the dual tolerance.

        For p_values (as `solve`); the tolerance is DUAL_TOL relative to |q|.
        """
        p_full = self._p_full
        p_full.data = p_values[self._p_full_take]
        kkt_values = self._t_constant.copy()
        kkt_values[self._t_p_pos] = p_values[self._p_take]
        kkt_values[self._t_x_diagonal] += REGULARIZATION
        tol = DUAL_TOL * max(1.0, float(np.max(np.abs(q))))
        return _Prepared(p_full, kkt_values, q, lower, upper, lower == upper, tol)

    def _corrected(self, qp: _Prepared, at_lower: np.ndarray, at_upper: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The verified optimum from one guess, corrected up to CORRECTIONS times; or None.

        The guess: the rows at their lower bound (at_lower, (m,) bool) and those at their
        upper bound (at_upper, (m,) bool, none of at_lower), of the QP `_prepare` gave.
        """
        p_full, kkt_values, q, lower, upper, equality, tol = qp
        for _ in range(CORRECTIONS + 1):
            active = at_lower | at_upper
            bound = np.where(at_lower, lower, upper)
            solved = self._kkt_solve(p_full, kkt_values, q, active, bound)
            if solved is None:
                return None
            x, y = solved
            ax = _matvec(self._a, x)
            violated_low = ax < lower - PRIMAL_TOL
            violated_up = ax > upper + PRIMAL_TOL
            wrong_sign = ~equality & ((at_lower & (y > tol)) | (at_upper & (y < -tol)))
            if not (violated_low.any() or violated_up.any() or wrong_sign.any()):
                px = _matvec(p_full, x)
                stationarity = px + q + _matvec(self._a_t, y)
                if float(np.max(np.abs(stationarity))) > tol:
                    return None
                return x, y, 0.5 * float(x @ px) + float(q @ x)
            at_lower = (at_lower & ~wrong_sign) | violated_low
            at_upper = (at_upper & ~wrong_sign & ~at_lower) | violated_up
        return None

    def _kkt_solve(self, p_full: sp.csr_matrix, kkt_values: np.ndarray, q: np.ndarray,
                   active: np.ndarray, bound: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray] | None:
        """(x, y) of the QP with the active rows as equalities, y zero on the others.

        Args:
            p_full: (n, n) P, both triangles.
            kkt_values: the template's values (_build_kkt_template), regularized.
            q: (n,) the linear cost.
            active: (m,) bool, the rows held at a bound.
            bound: (m,) the bound each row is held at.
        """
        n = self.n_vars
        kept = np.concatenate([np.ones(n, bool), active])
        index = np.cumsum(kept) - 1  # KKT index of each template row / column
        keep = kept[self._t_rows] & kept[self._t_cols]
        size = int(index[-1]) + 1
        per_column = np.bincount(index[self._t_cols[keep]], minlength=size)
        indptr = np.concatenate([[0], np.cumsum(per_column)])
        try:
            factor = _lu_factor(kkt_values[keep], index[self._t_rows[keep]], indptr, size)
        except RuntimeError:  # singular even with the regularization
            return None
        b = bound[active]
        rhs = np.concatenate([-q, b])
        sol = factor.solve(rhs)
        y = np.zeros(self.n_rows)
        for _ in range(REFINEMENT_STEPS):  # against the unregularized system
            y[active] = sol[n:]
            x = sol[:n]
            residual = np.concatenate([-q - _matvec(p_full, x) - _matvec(self._a_t, y),
                                       b - _matvec(self._a, x)[active]])
            sol = sol + factor.solve(residual)
        if not np.all(np.isfinite(sol)):
            return None
        y[active] = sol[n:]
        return sol[:n], y

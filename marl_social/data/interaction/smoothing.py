"""Smoothers of equally spaced samples.

Positions (`whittaker_smooth`) and arc length with speed under the Demonstration's dynamics
(`smooth_arc_length`).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.linalg import solveh_banded
from scipy.sparse.linalg import spsolve

SPEED_CUTOFF_HZ = 0.5  # s(t) smoothing: gain 1/2 at this frequency [Hz]


def whittaker_smooth(y, step: float, cutoff: float) -> np.ndarray:
    """Whittaker-Henderson smoother, the discrete cubic smoothing spline of equally spaced samples.

    f = argmin sum_k |y_k - f_k|^2 + lam sum_k |f_{k+1} - 2 f_k + f_{k-1}|^2, a banded
    solve, O(n). As a filter its gain is 1 / (1 + lam (2 - 2 cos(w h))^2); lam is chosen for
    gain 1/2 at the cutoff (scipy's make_smoothing_spline is the continuous equivalent, but
    costs more per sample and made the whole pipeline several times slower).

    Args:
        y: (n, d) samples every `step` (any unit: s or m), n >= 3.
        step: spacing of the samples (s or m).
        cutoff: frequency of gain 1/2 in cycles per unit of step (Hz for seconds).

    Returns:
        (n, d) smoothed samples.
    """
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    lam = 1.0 / (2.0 - 2.0 * math.cos(min(2.0 * math.pi * cutoff * step, math.pi))) ** 2
    second = sp.diags([np.ones(n - 2), -2.0 * np.ones(n - 2), np.ones(n - 2)], [0, 1, 2],
                      shape=(n - 2, n))
    gram = (second.T @ second).tocsr()
    ab = np.zeros((3, n))
    ab[2] = 1.0 + lam * gram.diagonal(0)
    ab[1, 1:] = lam * gram.diagonal(1)
    ab[0, 2:] = lam * gram.diagonal(2)
    return solveh_banded(ab, y)



def smooth_arc_length(s_obs, dt_s: float, cutoff_hz: float = SPEED_CUTOFF_HZ):
    """Fit arc length and speed that follow the Demonstration's dynamics exactly.

    Solves  min_{s, v}  sum_k (s_k - s_obs_k)^2 + lam sum_k j_k^2,
            j_k = (v_{k+2} - 2 v_{k+1} + v_k) / dt^2  (jerk),
            s.t. s_{k+1} = s_k + dt (v_k + v_{k+1}) / 2  (trapezoid rule),
    a sparse equality-constrained least-squares problem (KKT system, O(K)). As a filter on
    s_obs it has the transfer function 1 / (1 + lam w^6); lam = (2 pi cutoff_hz)^-6 gives gain
    1/2 at cutoff_hz. Polynomials up to degree 5 pass without bias in the interior, up to
    degree 2 (constant acceleration) up to the ends.

    Args:
        s_obs: (K,) arc lengths at equally spaced times [m], K >= 3.
        dt_s: time step between the samples [s].
        cutoff_hz: frequency of gain 1/2 of the filter [Hz].

    Returns:
        s: (K,) [m], v: (K,) [m/s]; u = diff(v) / dt are the controls.
    """
    y = np.asarray(s_obs, dtype=np.float64)
    k = len(y)
    if k < 3:
        raise ValueError(f"smooth_arc_length: need at least 3 samples, got {k}")
    lam = (2.0 * math.pi * cutoff_hz) ** -6
    second = sp.diags([np.ones(k - 2), -2.0 * np.ones(k - 2), np.ones(k - 2)], [0, 1, 2],
                      shape=(k - 2, k)) / dt_s ** 2
    hess = sp.block_diag([sp.identity(k), lam * (second.T @ second)])
    ds = sp.diags([-np.ones(k - 1), np.ones(k - 1)], [0, 1], shape=(k - 1, k))
    avg = sp.diags([np.ones(k - 1), np.ones(k - 1)], [0, 1], shape=(k - 1, k)) * (0.5 * dt_s)
    cons = sp.hstack([ds, -avg])
    kkt = sp.bmat([[hess, cons.T], [cons, None]], format="csc")
    rhs = np.concatenate([y, np.zeros(k), np.zeros(k - 1)])
    sol = spsolve(kkt, rhs)
    return sol[:k], sol[k:2 * k]

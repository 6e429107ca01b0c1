"""Discrete-choice inverse optimal control on the simulator's human drivers' decisions.

The continuous IRL of agents/irl/laplace.py (Laplace approximation, the paper's section III-C)
models a demonstration as a local optimum of a continuous control sequence. The simulator's
humans are not that: each step they sample one of A first accelerations from

    P(u | theta) = softmax_u(-Q*(u; theta)),   Q*(u; theta) = min_{c allowed} theta . Phi[u, c]

(agents/human.py and models/driver.py, eq. 8 and 11; theta here is the unnormalized
beta * theta_H). Given the recorded decisions (marl_social/data/decisions.py: Phi from the
human's own tracks, the allowed continuations, the sampled index) this likelihood is exact, so
maximum likelihood recovers beta * theta_H itself: its direction is the human's trade-off
between features, its scale the rationality in the same simulator-step cost units the robot's
model of a human uses (perception/belief/social.py), so a fit gives the robot theta_hat and beta_hat
at once.

    log P(u* | theta) = -Q*(u*) - log sum_u exp(-Q*(u))
    d/dtheta          = -Phi[u*, c*(u*)] + sum_u P(u) Phi[u, c*(u)]

(Q* is a minimum of linear functions: piecewise linear and concave in theta; c*(u) the
minimizing continuation, the gradient is exact wherever the minimizer is unique.) theta >= 0 is
fitted with scipy's L-BFGS-B on per-feature scaled variables. A feature that never varies
between a decision's candidates is not identifiable and is held at 0 (reported in
extra["identifiable"]). A feature that perfectly separated the choices would have an unbounded
maximum-likelihood weight; the recorded humans' crosswalk feature does not (candidates graze
the crosswalk with a partial, smooth occupancy), and the fit reports scipy's convergence.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.special import logsumexp

from marl_social.agents.irl.laplace import FITTABLE, IrlResult
from marl_social.data.decisions import DecisionSet
from marl_social.sim.costs import FEATURE_NAMES, N_FEATURES


def _q_and_argmin(theta: np.ndarray, data: DecisionSet) -> tuple[np.ndarray, np.ndarray]:
    """Q* (N, A) (inf where no continuation is allowed) and the minimizing continuation (N, A)."""
    totals = np.where(data.allowed, data.features @ theta, np.inf)  # (N, A, C)
    best = totals.argmin(axis=-1)
    return np.take_along_axis(totals, best[..., None], axis=-1)[..., 0], best


def choice_log_likelihood(theta, data: DecisionSet) -> tuple[np.ndarray, np.ndarray]:
    """Per-decision log P(chosen | theta) (N,) and its gradient w.r.t. theta (N, F)."""
    theta = np.nan_to_num(np.asarray(theta, dtype=np.float64))
    q, best = _q_and_argmin(theta, data)
    n = np.arange(len(data))
    log_p = -q - logsumexp(-q, axis=-1, keepdims=True)  # -inf where Q = inf
    phi_best = np.take_along_axis(data.features, best[..., None, None], axis=2)[:, :, 0]
    p = np.exp(log_p)  # (N, A)
    grad = -phi_best[n, data.chosen] + np.einsum("na,naf->nf", p, phi_best)
    return log_p[n, data.chosen], grad


def fit_choice_theta(decisions: DecisionSet, fitted=FITTABLE, max_iter: int = 1000
                     ) -> IrlResult:
    """Maximum likelihood of beta * theta from recorded decisions.

    Args:
        decisions: the recorded decisions, N of them.
        fitted: feature names to fit (tracking is constant along the route: not identifiable).
        max_iter: iteration limit of L-BFGS-B.

    Returns:
        IrlResult with theta = beta * theta_H (NaN where not fitted), its direction and
        scale; extra["method"] = "discrete-choice", extra["identifiable"] per feature.
    """
    t_start = time.perf_counter()
    unknown = sorted(set(fitted) - set(FITTABLE))
    if unknown:
        raise ValueError(f"choice IRL: cannot fit feature(s) {unknown}; fittable: "
                         f"{list(FITTABLE)}")
    if len(decisions) == 0:
        raise ValueError("choice IRL: no decisions to fit")
    idx = np.array([FEATURE_NAMES.index(f) for f in fitted])
    # per-feature scale: the mean spread of the feature between a decision's allowed candidates
    phi = np.where(decisions.allowed[..., None], decisions.features, np.nan)[..., idx]
    spread = np.nanmean(np.nanmax(phi, axis=(1, 2)) - np.nanmin(phi, axis=(1, 2)), axis=0)
    identifiable = spread > 0
    unit = np.where(identifiable, 1.0 / np.where(identifiable, spread, 1.0), 0.0)
    n = len(decisions)

    def objective(w):
        theta = np.zeros(N_FEATURES)
        theta[idx] = w * unit
        log_p, grad = choice_log_likelihood(theta, decisions)
        return -log_p.sum() / n, -grad[:, idx].sum(axis=0) * unit / n

    from scipy.optimize import minimize  # here: scipy.optimize takes ~0.7 s to import

    res = minimize(objective, np.where(identifiable, 1.0, 0.0), jac=True, method="L-BFGS-B",
                   bounds=[(0.0, None) if ok else (0.0, 0.0) for ok in identifiable],
                   options={"maxiter": max_iter})
    theta = np.full(N_FEATURES, np.nan)
    theta[idx] = res.x * unit
    norm = float(np.linalg.norm(theta[idx]))
    direction = theta / norm if norm > 0 else theta * np.nan
    log_p, _ = choice_log_likelihood(theta, decisions)
    return IrlResult(
        theta, tuple(fitted), direction, norm, float(-log_p.sum()), n, 0,
        time.perf_counter() - t_start, bool(res.success), str(res.message),
        extra={"method": "discrete-choice",
               "identifiable": {f: bool(ok) for f, ok in zip(fitted, identifiable)}})


def choice_neg_log_likelihood(theta, decisions: DecisionSet) -> float:
    """-sum log P(chosen | theta) over the decisions (exact)."""
    return float(-choice_log_likelihood(theta, decisions)[0].sum())

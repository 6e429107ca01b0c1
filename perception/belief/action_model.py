"""The noisily-rational action model: how likely a human's observed acceleration is (eq. 9-10).

The robot predicts a human's action distribution from its Q-values (Boltzmann, rationality
beta) and weighs the acceleration it observed, blurred by the observation noise, plus an
outlier term; `bounded_log_likelihood` caps what one observation can do to a belief.
`perception/belief/social.py` (hidden agents, traffic speed) and `phase.py` (signal phases)
both score humans with it.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.models.boltzmann import boltzmann
from marl_social.perception.belief import compiled

# the model of a human averaged over the robot's estimate of its speed: three-point Gauss-Hermite
# nodes at -sqrt 3, 0, +sqrt 3 standard deviations of the estimate, weights 1/6, 2/3, 1/6
# (`speed_nodes_mps`, `speed_averaged_log_likelihood`)
SPEED_NODES_SIGMA = np.array([-math.sqrt(3.0), 0.0, math.sqrt(3.0)])
LOG_SPEED_NODE_WEIGHTS = np.log(np.array([1.0, 4.0, 1.0]) / 6.0)
for _constant in (SPEED_NODES_SIGMA, LOG_SPEED_NODE_WEIGHTS):
    _constant.setflags(write=False)
SIGMA_MIN_MPS2 = 1e-3  # the observation noise on a_obs is at least this [m/s^2]
OUTLIER_PROB_MAX = 1.0 - 1e-12  # rho stays below 1 (some weight on the model)
OUTLIER_MARGIN_SIGMAS = 3.0  # the outlier density spans the actions' range +- this many sigma


def action_log_likelihood(q_values: np.ndarray, beta: float, a_obs: float,
                          actions_mps2: np.ndarray, sigma_mps2: float,
                          outlier_prob: float = 0.0) -> np.ndarray:
    """Log P(a_obs | x) of one observed acceleration under several hypotheses x (eq. 9-10).

        P(a_obs | x) = (1 - rho) sum_u softmax(-beta Q*(x, .))[u] N(a_obs; u, sigma^2)
                       + rho U(a_obs)

    rho = outlier_prob (0 gives eq. 10 exactly): a uniform density U over the actions' range
    widened by 3 sigma on each side, for observations no candidate explains (a tracking glitch,
    a model mismatch); it bounds what one step can do to the belief.

    Args:
        q_values: (..., A) Q*_H(x, u) of the A candidate actions (eq. 11) per hypothesis.
        beta: rationality of the model (inf = argmin).
        a_obs: observed acceleration [m/s^2]; non-finite values give zeros (uninformative).
        actions_mps2: (A,) accelerations the candidate actions execute as [m/s^2].
        sigma_mps2: std of the observation noise on a_obs [m/s^2].
        outlier_prob: rho in [0, 1).

    Returns:
        (...) log-likelihoods.
    """
    q = np.asarray(q_values, dtype=np.float64)
    sigma = max(float(sigma_mps2), SIGMA_MIN_MPS2)
    actions = np.asarray(actions_mps2, dtype=np.float64)
    log_gauss_norm = math.log(sigma * math.sqrt(2 * math.pi))
    if q.shape[-1] == 0:
        raise ValueError("action_log_likelihood: no candidate actions (q_values' last axis is "
                         "empty)")
    if math.isinf(beta):
        log_model = _argmin_log_model(q, a_obs, actions, sigma, log_gauss_norm)
    else:  # numpy's np.exp and np.log, the steps between them compiled
        log_model = _compiled_log_model(q, beta, a_obs, actions, sigma, log_gauss_norm)
    if log_model is None:
        return np.zeros(q.shape[:-1])
    rho = min(max(float(outlier_prob), 0.0), OUTLIER_PROB_MAX)  # np.clip's value, no call
    if rho == 0.0:
        return log_model
    width = actions.max() - actions.min() + 2.0 * OUTLIER_MARGIN_SIGMAS * sigma
    log_outlier = math.log(rho / width)
    return np.logaddexp(math.log1p(-rho) + log_model, log_outlier)


def speed_nodes_mps(v_mps: float, std_mps: float) -> np.ndarray:
    """(3,) speeds [m/s] at which a human's Q* is evaluated to average over its speed estimate.

    v_mps + SPEED_NODES_SIGMA * std_mps, the estimate and its std [m/s], at least 0 (a car
    does not reverse).
    """
    return np.maximum(float(v_mps) + SPEED_NODES_SIGMA * max(float(std_mps), 0.0), 0.0)


def speed_averaged_log_likelihood(q_nodes: np.ndarray, beta: float, a_obs: float,
                                  actions_mps2: np.ndarray, sigma_mps2: float,
                                  outlier_prob: float = 0.0) -> np.ndarray:
    """`action_log_likelihood` averaged over the robot's uncertainty about the human's speed.

        P(a_obs | x) = sum_s w_s P(a_obs | x, v_s)

    over the Gauss-Hermite nodes v_s of `speed_nodes_mps` (weights 1/6, 2/3, 1/6). A human's
    best action can change across ~0.1 m/s of its speed (whether it can still make its curve
    speed, or stop before a crosswalk): a model evaluated at the robot's estimate alone is then
    confidently wrong about a human whose true speed lies on the other side, and the belief
    reads that human's ordinary braking as evidence of a hidden agent.

    Args:
        q_nodes: (3, ..., A) Q*_H from each node's speed.
        beta: rationality of the model (inf = argmin).
        a_obs: observed acceleration [m/s^2].
        actions_mps2: (A,) accelerations the candidate actions execute as [m/s^2].
        sigma_mps2: std of the observation noise on a_obs [m/s^2].
        outlier_prob: rho in [0, 1) (action_log_likelihood).

    Returns:
        (...) log-likelihoods; zeros (uninformative) where any is not finite.
    """
    ll = action_log_likelihood(q_nodes, beta, a_obs, actions_mps2, sigma_mps2, outlier_prob)
    if not np.all(np.isfinite(ll)):
        return np.zeros(ll.shape[1:])
    weights = LOG_SPEED_NODE_WEIGHTS.reshape((-1,) + (1,) * (ll.ndim - 1))
    return logsumexp(ll + weights, axis=0)


def _argmin_log_model(q: np.ndarray, a_obs: float, actions: np.ndarray, sigma: float,
                      log_gauss_norm: float) -> np.ndarray | None:
    """Log sum_u argmin(q)[u] N(a_obs; u, sigma^2) (...): beta = inf; None if not finite."""
    if not math.isfinite(a_obs) or not np.all(np.isfinite(q)):
        return None
    with np.errstate(divide="ignore"):
        log_p = np.log(boltzmann(q, math.inf))
    with np.errstate(over="ignore"):  # an absurd a_obs gives -inf everywhere: uninformative
        log_gauss = -0.5 * ((a_obs - actions) / sigma) ** 2 - log_gauss_norm
    return logsumexp(log_p + log_gauss, axis=-1)


def _compiled_log_model(q: np.ndarray, beta: float, a_obs: float, actions: np.ndarray,
                        sigma: float, log_gauss_norm: float) -> np.ndarray | None:
    """Log sum_u softmax(-beta q)[u] N(a_obs; u, sigma^2) (...), finite beta; None if not finite.

    numpy's np.exp and np.log; belief_kernels.boltzmann_exponents, row_sums and
    shifted_log_model_terms do the rest in the order of the numpy formulation they replaced
    (tests/perception/test_belief_kernels.py compares them bit for bit, any row length).
    """
    if not math.isfinite(a_obs):
        return None
    kernels = compiled.kernels()
    rows = np.ascontiguousarray(q).reshape(-1, q.shape[-1])
    z = kernels.boltzmann_exponents(rows, float(beta))
    if not len(z) and len(rows):  # a Q-value is not finite
        return None
    log_norm = np.log(kernels.row_sums(np.exp(z)))  # each sum >= exp(0) = 1
    shifted, top = kernels.shifted_log_model_terms(
        z, log_norm, float(a_obs), np.ascontiguousarray(actions), sigma, log_gauss_norm)
    with np.errstate(divide="ignore"):
        log_sum = np.log(kernels.row_sums(np.exp(shifted)))
    return (log_sum + top).reshape(q.shape[:-1])


def bounded_log_likelihood(log_lik: np.ndarray, max_ratio: float) -> np.ndarray:
    """Log-likelihoods (...) of one observation, none more than max_ratio below the maximum.

    Then no single observation changes the log-odds between any two sets of hypotheses by more
    than max_ratio [nats] (each set's likelihood is a belief-weighted mean of values within a
    factor exp(max_ratio) of each other). Non-finite input is returned unchanged (the filter
    ignores it).

    Args:
        log_lik: (...) log P(a_obs | hypothesis).
        max_ratio: the bound [nats], > 0.
    """
    ll = np.asarray(log_lik, dtype=np.float64)
    if not ll.size:
        return ll
    return compiled.kernels().bounded(np.ascontiguousarray(ll).ravel(),
                                      float(max_ratio)).reshape(ll.shape)


def logsumexp(x: np.ndarray, axis: int) -> np.ndarray:
    """Log sum exp along axis, safe for -inf entries (all -inf gives -inf).

    Kept local: scipy.special.logsumexp (>= 1.15, log1p of the non-max terms) differs in the
    last bits, which would change seeded episodes.
    """
    top = np.max(x, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.exp(x - top).sum(axis=axis, keepdims=True)) + top
    return np.squeeze(out, axis=axis)

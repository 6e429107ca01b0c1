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
    if not math.isfinite(a_obs) or not np.all(np.isfinite(q)):
        return np.zeros(q.shape[:-1])
    sigma = max(float(sigma_mps2), SIGMA_MIN_MPS2)
    if math.isinf(beta):
        with np.errstate(divide="ignore"):
            log_p = np.log(boltzmann(q, beta))
    else:
        z = -beta * (q - q.min(axis=-1, keepdims=True))
        log_p = z - np.log(np.exp(z).sum(axis=-1, keepdims=True))
    actions = np.asarray(actions_mps2, dtype=np.float64)
    with np.errstate(over="ignore"):  # an absurd a_obs gives -inf everywhere: uninformative
        log_gauss = (-0.5 * ((a_obs - actions) / sigma) ** 2
                     - math.log(sigma * math.sqrt(2 * math.pi)))
    log_model = logsumexp(log_p + log_gauss, axis=-1)
    rho = min(max(float(outlier_prob), 0.0), OUTLIER_PROB_MAX)  # np.clip's value, no call
    if rho == 0.0:
        return log_model
    width = actions.max() - actions.min() + 2.0 * OUTLIER_MARGIN_SIGMAS * sigma
    log_outlier = math.log(rho / width)
    return np.logaddexp(math.log1p(-rho) + log_model, log_outlier)


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
    if not np.all(np.isfinite(ll)):
        return ll
    return np.maximum(ll, ll.max() - max_ratio)


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

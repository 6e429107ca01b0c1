"""Discrete Bayes filtering in log space (Algorithm 1) and the traffic-speed belief (eq. 12).

`bayes_step` is one filter step on a discrete belief (L,): a Markov prediction
(`markov_transition`, so beliefs never lock), the product of the likelihoods of independent
sources (summed log-likelihoods, eq. 9 and 12), and a normalization with a floor, so that a
belief is never NaN or all-zero. `TrafficSpeedBelief` is the social information I = v_traffic
over a small grid of speeds, filtered the same way.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.perception.belief import compiled

BELIEF_FLOOR = 1e-6  # default: no belief drops below this before normalization
TRAFFIC_HAZARD_PER_STEP = 0.002  # default mass moving between traffic speeds per step


def normalize(pdf: np.ndarray) -> np.ndarray:
    """filterpy.discrete_bayes.normalize, inline: pdf (L,) scaled to sum to one, in place.

    The same operations, so the same bits: filterpy divides by Python's sum() of the entries,
    a left-to-right sum, which np.cumsum's last entry is too (without the per-entry Python
    loop; tests/perception/belief/test_bayes.py checks it against filterpy).
    """
    if np.ndim(pdf) != 1:  # filterpy's sum() then runs over the rows
        pdf /= sum(np.asarray(pdf, dtype=float))
    elif len(pdf):  # filterpy divides an empty pdf by 0: nothing happens
        pdf /= np.cumsum(np.asarray(pdf, dtype=float))[-1]
    return pdf


def bayes_update(likelihood: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """filterpy.discrete_bayes.update, inline: the normalized posterior (L,).

    Of prior and likelihood, both (L,) (the same operations as filterpy, see `normalize`).
    """
    return normalize(prior * likelihood)


def markov_transition(n: int, p_move: float) -> np.ndarray:
    """(n, n) column-stochastic Markov matrix of a hazard p_move.

    Each hypothesis keeps 1 - p_move of its mass and spreads p_move evenly over the others
    (identity for n = 1).

    Args:
        n: number of hypotheses.
        p_move: mass moving away from each hypothesis per step, clipped to [0, 1].
    """
    if n <= 1:
        return np.ones((max(n, 0), max(n, 0)))
    p = float(np.clip(p_move, 0.0, 1.0))
    mat = np.full((n, n), p / (n - 1))
    np.fill_diagonal(mat, 1.0 - p)
    return mat


def sanitize_log_likelihood(log_lik: np.ndarray) -> np.ndarray:
    """Log-likelihoods (..., L) of one or more sources made safe, each source's maximum 0.

    A source with NaN or +inf anywhere, or -inf everywhere (nothing explains it), carries no
    usable information: zeros.
    """
    ll = np.asarray(log_lik, dtype=np.float64)
    top = ll.max(axis=-1, keepdims=True)  # NaN if any NaN, +inf if any +inf
    good = np.isfinite(top)
    return np.where(good, ll - np.where(good, top, 0.0), 0.0)


def bayes_step(prior, log_likelihoods, transition=None, floor: float = BELIEF_FLOOR
               ) -> np.ndarray:
    """One discrete Bayes filter step (Algorithm 1, steps 2-3; eq. 9 and 12).

    Args:
        prior: (L,) belief after the previous step.
        log_likelihoods: (L,) or (S, L) log P(observation_s | hypothesis l) for S independent
            sources (own sensors, each human...), multiplied (summed in log space). A source
            with NaN or +inf anywhere, or -inf everywhere, is ignored.
        transition: (L, L) column-stochastic Markov matrix applied first (prediction), or None.
        floor: every belief is raised to at least this before the final normalization.

    Returns:
        (L,) posterior, finite, positive, summing to 1.
    """
    prior = np.asarray(prior, dtype=np.float64)
    total_prior = prior.sum()
    if not (math.isfinite(total_prior) and total_prior > 0.0 and prior.min() >= 0.0):
        prior, total_prior = np.ones_like(prior), float(len(prior))
    predicted = prior / total_prior
    if transition is not None:
        predicted = np.asarray(transition) @ predicted
    ll = np.atleast_2d(np.asarray(log_likelihoods, dtype=np.float64))
    if ll.ndim == 2 and len(ll) and ll.shape[1] and predicted.shape == ll.shape[1:]:
        # the same arithmetic compiled between np.exp (joint_bayes_update's kernels, V = 1)
        posterior = _compiled_step(np.array(predicted, dtype=np.float64), ll, floor)
        if posterior is not None:
            return posterior
    predicted = np.maximum(predicted, 0.0)
    total = sanitize_log_likelihood(sanitize_log_likelihood(ll).sum(axis=0))
    posterior = bayes_update(np.exp(total), predicted)
    if not np.all(np.isfinite(posterior)):
        posterior = predicted / predicted.sum() if predicted.sum() > 0 else np.ones(len(prior))
    return normalize(np.maximum(posterior, floor))


def _compiled_step(predicted: np.ndarray, log_likelihoods: np.ndarray, floor: float
                   ) -> np.ndarray | None:
    """bayes_step after the prediction, compiled: (L,) posterior, None if it is not finite.

    The first source is the kernels' "own" one, the others their (S - 1, L, 1) "humans";
    `predicted` (L,) (a fresh array) is clipped at 0 in place.
    """
    kernels = compiled.kernels()
    ll = np.ascontiguousarray(log_likelihoods)
    n = ll.shape[1]
    with np.errstate(invalid="ignore"):
        evidence = np.exp(kernels.joint_log_likelihood(predicted, ll[0], ll[1:].reshape(-1, n, 1),
                                                       1))
    posterior, _, _ = kernels.joint_posterior(predicted, evidence[:n], float(floor), 1)
    return posterior.reshape(n) if len(posterior) else None


def joint_bayes_update(prior_l: np.ndarray, prior_v: np.ndarray, own_log_lik: np.ndarray,
                       social_log_lik: np.ndarray, transition: np.ndarray, floor: float
                       ) -> tuple:
    """`bayes_step` of the joint b(l, v) of a hidden-agent and a traffic-speed belief, the same bits.

    The joint prior is outer(prior_l, prior_v) (both normalized beliefs with a floor: finite and
    positive, so `bayes_step`'s check of the prior always passes and is left out); the sources
    are the own sensors' (L,) log-likelihood, the same for every v (sanitized once over its L
    entries: the maximum of its V copies is the same number), and each human's (L, V) one,
    added in bayes_step's order (own first, then the humans). The steps between the matrix
    product and np.exp, and after it, are compiled (belief_kernels.joint_log_likelihood,
    joint_posterior), with numpy's arithmetic in its order.

    Args:
        prior_l: (L,) belief over the hypotheses.
        prior_v: (V,) belief over the traffic speeds.
        own_log_lik: (L,) log P(own sensors | l).
        social_log_lik: (H, L, V) log P(a_i | l, v) of H humans (H may be 0).
        transition: (L V, L V) column-stochastic joint transition (kron(T_l, T_v)).
        floor: every joint belief is raised to at least this before the final normalization.

    Returns:
        the (L, V) posterior joint belief (finite, positive, summing to 1); its marginals
        (L,) and (V,), floored and normalized (`floored_marginals`); and, for the debugging
        summaries, exp(sanitized sum of the humans' log-likelihoods) (L, V) and exp(sanitized
        own log-likelihood) (L,).
    """
    n, n_v = len(prior_l), len(prior_v)
    prior = np.multiply.outer(prior_l, prior_v).ravel()
    predicted = transition @ (prior / np.add.reduce(prior))
    kernels = compiled.kernels()
    social = np.ascontiguousarray(social_log_lik, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        evidence = np.exp(kernels.joint_log_likelihood(
            predicted, np.ascontiguousarray(own_log_lik, dtype=np.float64), social, n_v))
    joint, by_l, by_v = kernels.joint_posterior(predicted, evidence[:n * n_v], float(floor), n_v)
    if not len(joint):  # bayes_step's fallback: the prediction alone
        total_predicted = predicted.sum()
        joint = predicted / total_predicted if total_predicted > 0 else np.ones(len(prior))
        joint = normalize(np.maximum(joint, floor)).reshape(n, n_v)
        by_l, by_v = floored_marginals(joint, floor)
    return joint, by_l, by_v, evidence[n * n_v:2 * n * n_v].reshape(n, n_v), evidence[2 * n * n_v:]


def floored_marginals(joint: np.ndarray, floor: float) -> tuple[np.ndarray, np.ndarray]:
    """The (L,) and (V,) marginals of a joint (L, V) belief, each floored and normalized.

    `normalize(np.maximum(joint.sum(axis=k), floor))` for k = 1 and 0, the same bits.
    """
    by_l = np.maximum(joint.sum(axis=1), floor)
    by_l /= np.add.accumulate(by_l)[-1]
    by_v = np.maximum(joint.sum(axis=0), floor)
    by_v /= np.add.accumulate(by_v)[-1]
    return by_l, by_v


class TrafficSpeedBelief:
    """Belief over the traffic speed v_traffic on a grid (social information, eq. 12).

        b(v | u_H) ∝ b(v) prod_i P(u_H,i | v)

    with a small Markov transition (hazard_per_step) before each update.

    Args:
        grid_mps: (V,) candidate traffic speeds [m/s].
        hazard_per_step: mass moving between grid values per step.
        floor: belief floor before normalization.
    """

    def __init__(self, grid_mps, hazard_per_step: float = TRAFFIC_HAZARD_PER_STEP,
                 floor: float = BELIEF_FLOOR):
        """Start uniform over grid_mps."""
        self.grid_mps = np.asarray(grid_mps, dtype=np.float64)
        if self.grid_mps.ndim != 1 or len(self.grid_mps) == 0:
            raise ValueError("TrafficSpeedBelief: grid_mps must be a non-empty 1-D sequence")
        self.floor = float(floor)
        self.transition = markov_transition(len(self.grid_mps), hazard_per_step)
        self.reset()

    def reset(self) -> None:
        """Back to the uniform prior."""
        self.probabilities = np.full(len(self.grid_mps), 1.0 / len(self.grid_mps))

    def update(self, log_likelihoods) -> np.ndarray:
        """Fold in one step and return the (V,) posterior.

        Args:
            log_likelihoods: (H, V) log P(a_obs,i | v) for H humans (H may be 0: prediction
                only).
        """
        ll = np.asarray(log_likelihoods, dtype=np.float64).reshape(-1, len(self.grid_mps))
        if len(ll) == 0:
            ll = np.zeros((1, len(self.grid_mps)))
        self.probabilities = bayes_step(self.probabilities, ll, self.transition, self.floor)
        return self.probabilities

    @property
    def expected_mps(self) -> float:
        """E[v_traffic] under the belief [m/s]."""
        return float(self.probabilities @ self.grid_mps)

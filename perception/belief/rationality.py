"""The robot's belief over each human's rationality beta (social+beta).

With a fixed beta_hat (BeliefConfig.beta_grid_hat empty) a human's observed action is scored
with it (eq. 10). With a grid, the likelihood is marginalized over the human's belief b_i(beta)
and that belief is updated with the joint prediction b(l, v) (confidence-aware prediction,
Fridovich-Keil et al. 2019): an erratic human's actions then move the hidden-agent belief less.
Either way the result is clipped to max_log_likelihood_ratio below its maximum.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from marl_social.perception.belief.action_model import bounded_log_likelihood, logsumexp
from marl_social.perception.belief.bayes import bayes_update, normalize
from marl_social.perception.belief.config import BeliefConfig


class RationalityBelief:
    """The rationality grid and how a human's belief over it updates.

    Args:
        config: BeliefConfig (beta_hat, beta_grid_hat, max_log_likelihood_ratio, floor).

    Attributes:
        grid: (B,) the rationality grid [1/cost] (empty: beta_hat fixed).
        prior: (B,) a new human's belief over it (uniform).
    """

    def __init__(self, config: BeliefConfig):
        self.config = config
        self.grid = np.asarray(config.beta_grid_hat, dtype=np.float64)
        self.prior = np.full(len(self.grid), 1.0 / max(len(self.grid), 1))

    @property
    def inferred(self) -> bool:
        """Whether beta is inferred (a grid) rather than fixed."""
        return bool(len(self.grid))

    def log_likelihood(self, score: Callable[[float], np.ndarray], belief: np.ndarray,
                       predicted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(L, V) bounded log P(a_obs | x_l, v) of one human, and its updated belief (B,).

        Args:
            score: beta -> (L, V) log-likelihood of the human's action at that rationality
                (action_scoring.ActionScoring.log_likelihood).
            belief: (B,) the human's belief over the grid (empty with a fixed beta).
            predicted: (L, V) predicted joint belief b(l, v).
        """
        cfg = self.config
        if not self.inferred:
            ll = score(cfg.beta_hat)
            return bounded_log_likelihood(ll, cfg.max_log_likelihood_ratio), belief
        ll = np.stack([score(beta) for beta in self.grid])  # (B, L, V)
        if not np.all(np.isfinite(ll)):
            return np.zeros(ll.shape[1:]), belief
        log_b = np.log(belief)[:, None, None]
        marginal = logsumexp((ll + log_b).reshape(len(ll), -1), axis=0).reshape(ll.shape[1:])
        marginal = bounded_log_likelihood(marginal, cfg.max_log_likelihood_ratio)
        top = ll.max()
        evidence = (np.exp(ll - top) * predicted[None]).sum(axis=(1, 2))  # (B,) up to a constant
        updated = bayes_update(evidence, belief)
        return marginal, normalize(np.maximum(updated, cfg.floor))

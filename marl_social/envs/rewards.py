"""Rewards: each agent's own step cost, negated, minus a collision penalty.

The cost is the paper's c = theta^T phi (eq. 13) with the agent's *own* weights theta and the
feature set every agent shares (`marl_social/sim/costs.py`), so a reward ranks actions exactly
as the agent's own planner ranks them.
"""

from __future__ import annotations

import numpy as np


def step_rewards(theta: np.ndarray, features: np.ndarray, collided: np.ndarray,
                 collision_penalty: float) -> np.ndarray:
    """Reward of every agent for one step.

    Args:
        theta: (n, F) each agent's own cost weights.
        features: (n, F) each agent's step features phi [simulator-step units].
        collided: (n,) bool, the agent touches another agent or a static polygon this step.
        collision_penalty: subtracted from a colliding agent's reward (>= 0).

    Returns:
        (n,) float64 reward = -(theta . phi) - collision_penalty * collided.
    """
    cost = np.einsum("nf,nf->n", theta, features)
    return -cost - collision_penalty * collided

"""Scoring a human's observed action against the robot's prediction of it (eq. 9-10).

P(a_obs | x_l, v) = sum_u softmax(-beta Q*_H(x_l, v, .))[u] t_nu(a_obs - u; sigma)
(action_model.action_log_likelihood; averaged over the robot's estimate of the
human's speed where the Q-values come from three speeds, speed_averaged_log_likelihood), with
sigma from the human's own execution noise and the robot's track of it. The Q-values come from
human_prediction.HumanPrediction; the rationality beta from rationality.RationalityBelief.
"""

from __future__ import annotations

import math

import numpy as np

from marl_social.perception.belief.action_model import (
    action_log_likelihood,
    speed_averaged_log_likelihood,
)
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.tracking import TrackSet
from marl_social.sim.dynamics import DT_S


class ActionScoring:
    """The likelihood of a human's observed acceleration under each hypothesis and speed.

    Args:
        config: BeliefConfig (accel_noise_mps2, tail_dof, marginalize_speed).
    """

    def __init__(self, config: BeliefConfig):
        self.config = config

    def log_likelihood(self, q_values: np.ndarray, actions_mps2: np.ndarray, beta: float,
                       a_est: float, sigma_mps2: float) -> np.ndarray:
        """(L, V) log P(a_est | x_l, v) of the predicted Q-values.

        Args:
            q_values: (L, V, A) Q*_H, or (3, L, V, A) from three speeds about the estimate.
            actions_mps2: (A,) accelerations the candidate actions execute as [m/s^2].
            beta: the rationality assumed [1/cost].
            a_est: the acceleration read off the human's track [m/s^2].
            sigma_mps2: std of a_est about the executed action [m/s^2].
        """
        score = (action_log_likelihood if q_values.ndim == 3
                 else speed_averaged_log_likelihood)
        return score(q_values, beta, a_est, actions_mps2, sigma_mps2, self.config.tail_dof)

    def observation_sigma_mps2(self, tracks: TrackSet, k: int, heading_rad: float) -> float:
        """Std of a human's acceleration read off the robot's track about its action [m/s^2].

        sqrt(accel_noise_mps2^2 + var_track), var_track the along-route variance of the
        track's velocity change over the last step (TrackSet.velocity_change_cov) / dt^2: the
        robot's own estimation error, which grows with its sensor noise.

        Args:
            tracks: the robot's current tracks.
            k: the human's row in tracks.
            heading_rad: its route heading [rad].
        """
        base = self.config.accel_noise_mps2
        if tracks.velocity_change_cov is None:
            return base
        var_track = variance_along(tracks.velocity_change_cov[k], heading_rad) / DT_S ** 2
        return math.sqrt(base * base + max(var_track, 0.0))

    def speed_std_mps(self, tracks: TrackSet, k: int, heading_rad: float) -> float | None:
        """Std of the robot's estimate of a human's speed along its route [m/s].

        From the track's velocity covariance (TrackSet.velocity_cov). None (the model at the
        estimate alone) without it or with BeliefConfig.marginalize_speed off.

        Args:
            tracks: the robot's current tracks.
            k: the human's row in tracks.
            heading_rad: its route heading [rad].
        """
        if not self.config.marginalize_speed or tracks.velocity_cov is None:
            return None
        return math.sqrt(max(variance_along(tracks.velocity_cov[k], heading_rad), 0.0))


def variance_along(cov: np.ndarray, heading_rad: float) -> float:
    """d^T cov d of a (2, 2) covariance along the unit vector d of heading_rad [rad]."""
    d = np.array([math.cos(heading_rad), math.sin(heading_rad)])
    return float(d @ cov @ d)

"""The three jobs of social perception, each alone: prediction, scoring, rationality."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import marl_social
from marl_social.perception.belief import (
    ActionScoring,
    BeliefConfig,
    HumanPrediction,
    RationalityBelief,
)

ACTIONS = np.array([-4.0, -2.0, 0.0, 1.0])  # (A,) [m/s^2]
# (L=2, V=1, A) Q-values: hypothesis 0 makes braking hard (-4) best, hypothesis 1 coasting (0)
Q = np.array([[[0.0, 2.0, 6.0, 8.0]], [[8.0, 4.0, 0.0, 1.0]]])


def test_scoring_favours_the_hypothesis_that_predicts_the_observed_action():
    scoring = ActionScoring(BeliefConfig())
    braking = scoring.log_likelihood(Q, ACTIONS, beta=1.0, a_est=-3.9, sigma_mps2=0.5)
    coasting = scoring.log_likelihood(Q, ACTIONS, beta=1.0, a_est=0.1, sigma_mps2=0.5)
    assert braking.shape == (2, 1)
    assert braking[0, 0] > braking[1, 0] and coasting[1, 0] > coasting[0, 0]
    # a noisier reading of the action is weaker evidence
    blurred = scoring.log_likelihood(Q, ACTIONS, beta=1.0, a_est=-3.9, sigma_mps2=3.0)
    assert blurred[0, 0] - blurred[1, 0] < braking[0, 0] - braking[1, 0]


def test_a_fixed_rationality_is_bounded_and_never_updates():
    config = BeliefConfig(max_log_likelihood_ratio=1.0)
    fixed = RationalityBelief(config)
    assert not fixed.inferred and fixed.prior.size == 0
    calls = []
    ll, belief = fixed.log_likelihood(lambda beta: calls.append(beta) or np.array(
        [[0.0], [-10.0]]), fixed.prior, np.full((2, 1), 0.5))
    assert calls == [config.beta_hat] and belief is fixed.prior
    assert ll.max() - ll.min() == pytest.approx(1.0)  # clipped to the bound


def test_a_consistent_human_is_believed_rational_an_erratic_one_not():
    rationality = RationalityBelief(replace(BeliefConfig(), beta_grid_hat=(0.1, 3.0)))
    scoring = ActionScoring(BeliefConfig())
    predicted = np.array([[0.5], [0.5]])

    def updated(a_est: float, steps: int = 5) -> np.ndarray:
        belief = rationality.prior
        for _ in range(steps):
            _, belief = rationality.log_likelihood(
                lambda beta: scoring.log_likelihood(Q[:1], ACTIONS, beta, a_est, 0.3),
                belief, predicted[:1])
        return belief

    assert updated(-4.0)[1] > 0.8  # always the best action: a high beta
    assert updated(1.0)[0] > 0.8  # always the worst one: a low beta


def test_the_prediction_alone_gives_every_hypothesis_and_traffic_speed():
    env = marl_social.parallel_env(scenario="occluded_crosswalk")
    belief = marl_social.policies(env)["robot_0"].belief
    grid = belief.traffic.grid_mps
    prediction = HumanPrediction(env.unwrapped.road_map, belief.hypotheses, grid,
                                 belief.config)
    road_map = env.unwrapped.road_map
    route = road_map.routes["human_0"]
    crosswalk_s = float(route.project(road_map.crosswalks[0].center[None])[0][0])
    q = prediction.human_q_values(route, crosswalk_s - 25.0, 11.0, 0.0)  # 25 m short of it
    assert q.shape == (len(belief.hypotheses), len(grid), len(prediction.executed(11.0)))
    assert np.all(np.isfinite(q))
    # a pedestrian hypothesised on the crosswalk ahead makes driving on costlier than "none"
    none = int(np.argmin([h.present for h in belief.hypotheses]))
    fastest = int(np.argmax(prediction.executed(11.0)))
    assert (q[:, :, fastest] >= q[none, :, fastest] - 1e-9).all()
    assert (q[:, :, fastest] > q[none, :, fastest]).any()

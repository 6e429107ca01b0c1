"""Discrete-choice IRL on the simulator's own human drivers (agents/irl/choice.py): the recorded
decisions reproduce the humans' Q* exactly, and the fit recovers their beta * theta."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from marl_social.agents.irl.choice import (
    choice_log_likelihood,
    choice_neg_log_likelihood,
    fit_choice_theta,
)
from marl_social.agents.irl.laplace import cosine_similarity
from marl_social.cli import main
from marl_social.data.decisions import DecisionSet, load_decisions, save_decisions
from marl_social.evaluation.record import record_decisions
from marl_social.evaluation.rollout import record_episode
from marl_social.evaluation.run import run_episode
from marl_social.scenarios import make_scenario

WITHOUT_CROSSWALK = ("speed", "accel", "jerk", "safety")
RECORDING = {"robot_planner": "cruise", "pedestrian": "crossing"}


@pytest.fixture(scope="module")
def decisions() -> dict:
    """Decisions of humans with a fixed rationality, 12 randomized episodes each (1800
    decisions). Six are too few for the weakly identified safety weight: over different
    6-episode sets the cosine without the crosswalk weight ranged 0.92-0.99. Recorded in this
    process: the 24 short episodes take less than two spawned workers take to start."""
    return {beta: record_decisions(seeds=range(12), overrides={**RECORDING, "human_beta": beta})
            for beta in (2.0, 20.0)}


def test_recorded_features_reproduce_the_humans_q_values():
    env = marl_social.parallel_env(scenario="occluded_crosswalk", max_cycles=120, **RECORDING)
    pols = marl_social.policies(env)
    human = pols["human_0"]
    human.record_decisions = True
    q_values = []
    decide = human.action_distribution

    def spy(obs):
        p = decide(obs)
        q_values.append(human.last_q.copy())
        return p

    human.action_distribution = spy
    record_episode(env, pols, seed=4)
    theta = human.model.theta.as_array()
    assert len(human.decisions) == len(q_values) > 100
    braked = 0
    for (features, allowed, chosen), q in zip(human.decisions, q_values):
        rebuilt = np.where(allowed, features @ theta, np.inf).min(axis=-1)
        np.testing.assert_allclose(rebuilt, q, rtol=1e-12, atol=1e-9)
        assert np.isfinite(q[chosen])
        braked += human.model.first_actions_mps2[chosen] <= -3.0
    assert braked > 0  # the episode includes its braking for the pedestrian


def test_recording_decisions_does_not_change_the_episode():
    plain = run_episode(seed=2, max_cycles=80, **RECORDING)
    recorded = run_episode(seed=2, max_cycles=80, record_human_decisions=True, **RECORDING)
    assert np.array_equal(plain.trace.states, recorded.trace.states)
    assert plain.decisions is None and len(recorded.decisions["human_0"]) == 80


@pytest.mark.slow
def test_likelihood_gradient_matches_finite_differences(decisions):
    data = decisions[2.0].subset(np.arange(300))
    theta = np.array([0.0, 1.7, 0.3, 0.2, 1.1, 900.0])
    _, grad = choice_log_likelihood(theta, data)
    for k in range(1, 6):
        h = 1e-6 * max(1.0, theta[k])
        up, down = theta.copy(), theta.copy()
        up[k] += h
        down[k] -= h
        fd = -(choice_neg_log_likelihood(up, data) - choice_neg_log_likelihood(down, data)) / (2 * h)
        assert grad[:, k].sum() == pytest.approx(fd, rel=1e-4, abs=1e-6)


@pytest.mark.slow
def test_recovers_the_humans_weights_and_rationality(decisions):
    scales = {}
    for beta, data in decisions.items():
        truth = beta * data.theta_true[0]
        result = fit_choice_theta(data)
        assert result.converged
        assert cosine_similarity(result.theta, truth) >= 0.95
        assert cosine_similarity(result.theta, truth, WITHOUT_CROSSWALK) >= 0.95
        # the exact likelihood is at least as high as the truth's on its training data
        assert result.neg_log_lik <= choice_neg_log_likelihood(truth, data) + 1e-6
        scales[beta] = result.scale
        assert scales[beta] == pytest.approx(np.linalg.norm(truth[1:]), rel=0.5)
    # ten times more rational humans: a scale about ten times larger
    assert 5.0 < scales[20.0] / scales[2.0] < 20.0


@pytest.mark.slow
def test_held_out_choices_prefer_the_learned_weights(decisions):
    data = decisions[2.0]
    first = np.arange(len(data)) < 450
    train, test = data.subset(first), data.subset(~first)
    learned = fit_choice_theta(train)
    rng = np.random.default_rng(3)
    for direction in [np.r_[0.0, np.ones(5)]] + [np.r_[0.0, rng.random(5)] for _ in range(3)]:
        # a fair rival: the direction's best scale on the training decisions
        rival = min((c * learned.scale * direction / np.linalg.norm(direction)
                     for c in np.geomspace(1e-3, 10, 25)),
                    key=lambda theta: choice_neg_log_likelihood(theta, train))
        assert (choice_neg_log_likelihood(learned.theta, test)
                < choice_neg_log_likelihood(rival, test))


@pytest.mark.slow
def test_decision_files_round_trip_and_fit_from_the_cli(decisions, tmp_path, capsys):
    path = save_decisions(tmp_path / "decisions.npz", decisions[20.0])
    loaded = load_decisions(path)
    assert np.array_equal(loaded.features, decisions[20.0].features)
    assert np.array_equal(loaded.chosen, decisions[20.0].chosen)
    assert main(["irl", "fit", str(path), "-o", str(tmp_path / "theta.json")]) == 0
    out = capsys.readouterr().out
    assert "discrete choice" in out and "robot_beta_hat=" in out
    scenario = make_scenario("occluded_crosswalk",
                             robot_theta_hat=str(tmp_path / "theta.json"))
    assert scenario.params.robot_theta_hat[5] > 100 * scenario.params.robot_theta_hat[1]
    assert main(["irl", "fit", str(tmp_path / "missing.npz")]) == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.slow
def test_bad_decision_data_is_rejected_with_the_field_named(decisions):
    data = decisions[20.0]
    with pytest.raises(ValueError, match="chosen index out of range"):
        DecisionSet(data.features, data.allowed, np.full(len(data), 99), data.first_actions_mps2,
                    data.theta_true, data.beta_true, data.agent, data.source, data.t_s)
    with pytest.raises(ValueError, match="allowed must be"):
        DecisionSet(data.features, data.allowed[:, :, :2], data.chosen, data.first_actions_mps2,
                    data.theta_true, data.beta_true, data.agent, data.source, data.t_s)
    with pytest.raises(ValueError, match="cannot fit"):
        fit_choice_theta(data, fitted=("tracking",))

"""One action space for all agents and padding for finished ones: SuperSuit's vector envs."""

from __future__ import annotations

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test

import marl_social
from marl_social.envs.homogeneous import ACTION_SPACE, homogeneous_spaces

ss = pytest.importorskip("supersuit")


def test_pettingzoo_api_on_the_padded_envs():
    parallel_api_test(marl_social.parallel_env(homogeneous_spaces=True), num_cycles=300)
    api_test(marl_social.env(homogeneous_spaces=True), num_cycles=100)


def test_every_agent_has_the_same_spaces():
    env = marl_social.parallel_env(homogeneous_spaces=True)
    assert len(env.possible_agents) == 3  # a car, a human car and a pedestrian
    for agent in env.possible_agents:
        assert env.action_space(agent) == ACTION_SPACE
        assert env.observation_space(agent) == env.observation_space(env.possible_agents[0])
    with pytest.raises(TypeError, match="homogeneous_spaces"):
        marl_social.parallel_env(homogeneous_spaces="yes")


def test_normalized_actions_map_to_each_agents_own_limits_keeping_zero():
    env = marl_social.parallel_env(homogeneous_spaces=True)
    env.reset(seed=0)
    raw = env.unwrapped
    for agent in env.possible_agents:
        low, high = raw.action_space(agent).low, raw.action_space(agent).high
        np.testing.assert_allclose(env.to_env_action(agent, [1.0, 1.0]), high, rtol=1e-6)
        np.testing.assert_allclose(env.to_env_action(agent, [-1.0, -1.0]), low, rtol=1e-6)
        np.testing.assert_array_equal(env.to_env_action(agent, [0.0, 0.0]), [0.0, 0.0])
        np.testing.assert_allclose(env.to_env_action(agent, [-0.5, 0.25]),
                                   [0.5 * low[0], 0.25 * high[1]], rtol=1e-6)
    with pytest.raises(ValueError, match="robot_0"):
        env.step({a: [np.nan, 0.0] if a == "robot_0" else [0, 0] for a in env.agents})


def test_a_padded_episode_equals_the_raw_one_with_mapped_actions():
    padded = marl_social.parallel_env(homogeneous_spaces=True, max_cycles=300)
    raw = marl_social.parallel_env(max_cycles=300)
    obs_p, _ = padded.reset(seed=4)
    obs_r, _ = raw.reset(seed=4)
    rng = np.random.default_rng(4)
    finished_early = set()
    while raw.agents:
        for a in raw.agents:
            np.testing.assert_array_equal(obs_p[a], obs_r[a])
        assert padded.agents == padded.possible_agents  # nobody leaves a padded episode
        normalized = {a: rng.uniform(-1, 1, 2) for a in padded.agents}
        live = list(raw.agents)
        mapped = {a: padded.to_env_action(a, normalized[a]) for a in live}
        obs_p, rew_p, term_p, trunc_p, _ = padded.step(normalized)
        obs_r, rew_r, term_r, trunc_r, _ = raw.step(mapped)
        for a in padded.possible_agents:
            if a in live:
                assert (rew_p[a], term_p[a], trunc_p[a]) == (rew_r[a], term_r[a], trunc_r[a])
            else:  # finished earlier: zero observation and reward
                finished_early.add(a)
                assert rew_p[a] == 0.0 and not obs_p[a].any()
    assert padded.agents == []
    assert all(trunc_p[a] or term_p[a] for a in padded.possible_agents)


def test_supersuit_vector_env_on_the_full_env_with_auto_reset():
    env = marl_social.parallel_env(homogeneous_spaces=True, max_cycles=40)
    n = len(env.possible_agents)
    size = env.observation_space("robot_0").shape[0]
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, 2, num_cpus=0, base_class="gymnasium")
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (2 * n, size)
    rng = np.random.default_rng(0)
    ends = 0
    for _ in range(100):  # crosses max_cycles at least twice: the vector env auto-resets
        obs, rew, term, trunc, _ = vec.step(rng.uniform(-1, 1, (2 * n, 2)).astype(np.float32))
        assert obs.shape == (2 * n, size) and np.all(np.isfinite(obs)) and np.all(np.isfinite(rew))
        ends += int(np.all((term | trunc).reshape(2, n), axis=1).sum())  # copies that ended
    assert ends >= 4  # each copy ends at least at every max_cycles
    vec.close()


def test_autopilot_robot_as_the_only_learner_vectorizes():
    env = homogeneous_spaces(marl_social.autopilot(marl_social.parallel_env(max_cycles=30),
                                                   controlled=["robot_0"]))
    assert env.possible_agents == ["robot_0"]
    vec = ss.concat_vec_envs_v1(ss.pettingzoo_env_to_vec_env_v1(env), 2, num_cpus=0,
                                base_class="gymnasium")
    obs, _ = vec.reset(seed=1)
    first = obs.copy()
    ended = np.zeros(2, dtype=bool)
    for step in range(40):  # full throttle, straight on
        obs, rew, term, trunc, _ = vec.step(np.ones((2, 2), dtype=np.float32) * [1.0, 0.0])
        assert np.all(np.isfinite(rew))
        if step == 10:
            assert np.all(obs[:, 0] > first[:, 0] + 5.0)  # the robots drove forward
        ended |= (term | trunc).astype(bool)
    assert obs.shape == first.shape == (2, env.observation_space("robot_0").shape[0])
    assert ended.all()  # both copies finished an episode (max_cycles 30) and went on
    vec.close()


def test_seeded_autopilot_episodes_repeat_after_unseeded_resets():
    """After one seeded reset, later resets without a seed are reproducible too."""
    def returns():
        env = marl_social.autopilot(marl_social.parallel_env(max_cycles=25),
                                    controlled=["robot_0"])
        out = []
        env.reset(seed=5)
        for _ in range(3):
            total = 0.0
            while env.agents:
                total += env.step({"robot_0": np.zeros(2)})[1]["robot_0"]
            out.append(total)
            env.reset()
        return out

    assert returns() == returns()

"""The env RLlib trains on (training/env.py) and the belief observation (envs/belief_observation):
spaces from possible_agents, final observations in the ending step, render, the opt-in belief
that is the social planner's own."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from marl_social.envs.belief_observation import ARRIVAL_HORIZON_S, belief_observation
from marl_social.envs.policies import policies
from marl_social.training.scene import SceneSettings

pytest.importorskip("ray.rllib", reason="needs the [rllib] extra: pip install -e '.[rllib]'")
from marl_social.training.env import SceneEnv


def _run(env, action, seed=0, limit=400):
    """Step `env` with a constant normalized action to the episode's end: the list of steps."""
    obs, _ = env.reset(seed=seed)
    steps = []
    while env.agents and len(steps) < limit:
        out = env.step({a: np.full(env.action_spaces[a].shape, action, np.float32)
                        for a in env.agents})
        steps.append(out)
    return obs, steps


def test_spaces_cover_every_possible_agent_before_the_first_reset():
    env = SceneEnv({"learn": "both", "observation": "ego+belief"})
    assert env.possible_agents == ["robot_0", "human_0"]
    assert set(env.observation_spaces) == set(env.action_spaces) == set(env.possible_agents)
    assert env.agents == []  # nothing live before reset, the spaces are there all the same
    assert env.observation_spaces["robot_0"].shape[0] > env.observation_spaces["human_0"].shape[0]
    obs, _ = env.reset(seed=3)
    for agent, o in obs.items():
        assert env.observation_spaces[agent].contains(o), agent


def test_an_agent_gets_its_final_observation_and_reward_in_the_step_it_ends():
    env = SceneEnv({"learn": "robot", "max_cycles": 150,
                    "overrides": {"pedestrian": "none"}})
    _, steps = _run(env, 1.0)  # full throttle: the robot arrives (or collides) early
    obs, rewards, terms, truncs, infos = steps[-1]
    assert "robot_0" in obs and "robot_0" in rewards
    assert terms["robot_0"] or truncs["robot_0"]
    assert terms["__all__"] or truncs["__all__"]
    assert env.observation_spaces["robot_0"].contains(obs["robot_0"])
    metrics = infos["robot_0"]["episode_metrics"]
    assert set(metrics) == {"robot_collision", "hard_brake", "yielded", "time_to_pass_s"}
    for earlier in steps[:-1]:  # the robot was live until then, and the episode not over
        assert "robot_0" in earlier[0] and not earlier[2]["__all__"]


def test_truncation_is_reported_as_truncation():
    env = SceneEnv({"learn": "robot", "max_cycles": 5})
    _, steps = _run(env, 0.0)
    assert len(steps) == 5
    _, _, terms, truncs, _ = steps[-1]
    assert truncs["__all__"] and truncs["robot_0"] and not terms["__all__"]


def test_humans_learn_with_one_shared_policy_and_the_robot_on_its_planner():
    from marl_social.training.scene import policy_of

    env = SceneEnv({"learn": "humans", "overrides": {"robot_planner": "cruise"}})
    assert env.possible_agents == ["human_0"] and policy_of("human_0") == "human"
    assert policy_of("human_7") == policy_of("human_0") != policy_of("robot_0")
    _, steps = _run(env, 0.2, limit=20)
    assert steps and all("human_0" in s[1] for s in steps)


def test_render_through_the_rllib_env_returns_frames():
    env = SceneEnv({"overrides": {"render_mode": "rgb_array"}, "max_cycles": 3})
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8


def test_episodes_draw_variants_and_randomization_from_the_seeded_stream():
    settings = {"variants": ["crossing", "none"], "randomize": "wide", "max_cycles": 2}
    first, second = SceneEnv(settings), SceneEnv(settings)
    for env in (first, second):
        env.reset(seed=5)
    a, b = first.reset(), second.reset()  # the next episode of each: the same draw
    np.testing.assert_array_equal(a[0]["robot_0"], b[0]["robot_0"])


def test_bad_settings_are_one_line_errors():
    with pytest.raises(ValueError, match="learn must be one of"):
        SceneSettings(learn="pedestrians")
    with pytest.raises(ValueError, match="ego\\+belief"):
        SceneSettings(learn="humans", observation="ego+belief")
    with pytest.raises(ValueError, match="control must be one of"):
        SceneSettings(control="steer")


# -- the belief observation --------------------------------------------------------------------

def test_belief_observation_is_the_social_planners_belief_and_opt_in():
    plain = marl_social.parallel_env(pedestrian="crossing")
    env = marl_social.parallel_env(pedestrian="crossing", observation="ego+belief")
    social = policies(marl_social.parallel_env(pedestrian="crossing"))["robot_0"]
    size = plain.observation_space("robot_0").shape[0]
    n_hyp = len(social.belief.hypotheses)
    assert env.observation_space("robot_0").shape == (size + n_hyp + 1,)
    assert env.observation_space("human_0") == plain.observation_space("human_0")
    obs_plain, _ = plain.reset(seed=4)
    obs, _ = env.reset(seed=4)
    social.reset(4)
    for _ in range(40):
        # the other agents' observations and the robot's own part are the plain env's
        for agent in plain.agents:
            np.testing.assert_array_equal(obs[agent][:size], obs_plain[agent])
        assert env.observation_space("robot_0").contains(obs["robot_0"])
        social(obs_plain["robot_0"])  # the social planner folds in the same observation
        np.testing.assert_allclose(obs["robot_0"][size:size + n_hyp],
                                   social.belief.probabilities, rtol=1e-6, atol=1e-7)
        arrival = obs["robot_0"][-1]
        assert 0.0 <= arrival <= ARRIVAL_HORIZON_S
        actions = {a: np.array([0.5, 0.0]) if a != "pedestrian_0" else np.zeros(2)
                   for a in plain.agents}
        obs_plain = plain.step(actions)[0]
        obs = env.step(actions)[0]
        if "robot_0" not in obs:
            break


def test_arrival_time_reads_the_live_hypotheses_in_the_robots_lane():
    env = belief_observation(marl_social.autopilot(marl_social.parallel_env(pedestrian="none"),
                                                   ["robot_0"]))
    obs, _ = env.reset(seed=1)
    features = env.features
    arrival_s, where_m = features._arrivals()
    present = np.array([h.present for h in features.belief.hypotheses])
    assert arrival_s[~present].tolist() == [ARRIVAL_HORIZON_S] * int((~present).sum())
    assert np.isfinite(where_m[present]).any()  # some hypotheses cross the robot's lane
    live = features.belief.live() & present & (where_m >= 0.0)
    expected = arrival_s[live].min() if live.any() else ARRIVAL_HORIZON_S
    assert obs["robot_0"][-1] == pytest.approx(expected)


def test_bad_observation_option_is_an_error():
    with pytest.raises(ValueError, match="observation must be"):
        marl_social.parallel_env(observation="belief")
    with pytest.raises(ValueError, match="homogeneous_spaces"):
        marl_social.parallel_env(observation="ego+belief", homogeneous_spaces=True)

"""The paper scenario is tuned as the paper describes (Fig. 2, Figs. 3-6)."""

from __future__ import annotations

import numpy as np
import pytest

import marl_social
from marl_social.agents.cruise import cruise_policies


def _cruise_episode(**overrides):
    """Run the scenario with the cruise baseline; return per-step records."""
    env = marl_social.parallel_env(**overrides)
    policies = cruise_policies(env)
    obs, infos = env.reset(seed=0)
    cw_x = env.road_map.crosswalks[0].center[0]
    cw_near_edge = cw_x - 0.5 * env.road_map.crosswalks[0].width_m
    rows = []
    while "robot_0" in env.agents:
        actions = {a: policies[a](obs[a]) for a in env.agents}
        obs, _, _, _, infos = env.step(actions)
        w = env.world
        rows.append({
            "t": w.time_s,
            "robot_front_gap": cw_near_edge - (w.state[0, 0] + 2.25),
            "robot_v": w.state[0, 3],
            "robot_a": w.accel_mps2[0],
            "human_a": w.accel_mps2[1],
            "robot_sees_ped": "pedestrian_0" in infos.get("robot_0", {}).get("visible", []),
            "human_sees_ped": "pedestrian_0" in infos.get("human_0", {}).get("visible", []),
            "collision": infos.get("robot_0", {}).get("collision", False),
        })
    return rows


def test_robot_first_sees_crossing_pedestrian_late():
    rows = _cruise_episode(pedestrian="crossing")
    first = next(r for r in rows if r["robot_sees_ped"])
    time_to_crosswalk = first["robot_front_gap"] / first["robot_v"]
    assert 1.2 <= time_to_crosswalk <= 1.8, time_to_crosswalk
    # the human saw the pedestrian all along and braked well before the robot could see it
    human_brake = next(r["t"] for r in rows if r["human_a"] < -0.5)
    assert human_brake < first["t"] - 1.0
    assert all(r["human_sees_ped"] for r in rows if r["t"] <= first["t"])
    # the robot that ignores what it cannot see has to brake hard (paper Fig. 3)
    assert min(r["robot_a"] for r in rows) <= -5.0
    assert not any(r["collision"] for r in rows)


def test_waiting_pedestrian_does_not_make_the_human_brake():
    rows = _cruise_episode(pedestrian="waiting")
    assert min(r["human_a"] for r in rows) > -0.5
    assert min(r["robot_a"] for r in rows) > -0.5


def test_variants_have_the_right_agents():
    assert marl_social.parallel_env(pedestrian="none").possible_agents == ["robot_0", "human_0"]
    assert marl_social.parallel_env().possible_agents == ["robot_0", "human_0", "pedestrian_0"]
    env = marl_social.parallel_env(scenario="long_road", n_vehicles=5)
    assert env.possible_agents == ["robot_0", "human_0", "human_1", "human_2", "human_3"]


def test_params_are_frozen():
    env = marl_social.parallel_env()
    with pytest.raises(AttributeError):
        env.scenario.params.human_lead_m = 3.0


def test_rewards_penalize_speed_deviation_and_collisions():
    env = marl_social.parallel_env(pedestrian="none", robot_desired_speed_mps=13.0)
    env.reset(seed=0)
    _, rew, _, _, _ = env.step({a: np.zeros(2) for a in env.agents})
    # robot drives 11.5 m/s but wants 13 -> speed cost 1.5^2; human drives at its own wish
    assert rew["robot_0"] < rew["human_0"]
    assert rew["robot_0"] == pytest.approx(-(1.5 ** 2) - env.world.step_features()[0, 4],
                                           rel=1e-6)


def test_n_humans_knob_builds_a_platoon_and_is_validated():
    for n in range(5):
        env = marl_social.parallel_env(scenario="occluded_crosswalk", n_humans=n)
        humans = [a for a in env.possible_agents if a.startswith("human")]
        assert humans == [f"human_{k}" for k in range(n)]
    with pytest.raises(ValueError, match="n_humans"):
        marl_social.parallel_env(scenario="occluded_crosswalk", n_humans=5)
    with pytest.raises(ValueError, match="robot_epsilon"):
        marl_social.parallel_env(scenario="occluded_crosswalk", robot_epsilon=1.0)
    with pytest.raises(ValueError, match="robot_beta_hat"):
        marl_social.parallel_env(scenario="occluded_crosswalk", robot_beta_hat=-1.0)


def test_robot_planner_parameters_are_validated():
    from dataclasses import replace

    from marl_social.agents.robot.settings import robot_configs

    env = marl_social.parallel_env(scenario="occluded_crosswalk", robot_beta_hat=2.0,
                                   robot_epsilon=0.1, robot_theta_hat={"crosswalk": 500.0})
    spec = env.agent_specs["robot_0"]
    mpc, belief = robot_configs(spec, "social")
    assert (belief.beta_hat, belief.epsilon, mpc.epsilon) == (2.0, 0.1, 0.1)
    assert belief.theta_hat.crosswalk == 500.0 and belief.beta_grid_hat == ()
    assert robot_configs(spec, "social+beta")[1].beta_grid_hat
    with pytest.raises(ValueError, match="unknown planner parameter"):
        robot_configs(replace(spec, planner={"beta": 1.0}), "social")


@pytest.mark.slow
def test_following_humans_stop_behind_the_braking_leader():
    """Human drivers never plan into a predicted vehicle collision: with three humans in a
    platoon braking for a crossing pedestrian, no human rear-ends another (the safety feature
    alone, at most 1 per step, is cheaper than the speed cost of stopping)."""
    from marl_social.evaluation.run import randomized_overrides, run_episode

    for seed in range(3):
        result = run_episode("occluded_crosswalk", seed=seed, max_cycles=100, n_humans=3,
                             robot_planner="cruise", **randomized_overrides(seed))
        trace = result.trace
        assert not trace.collided.any(), seed
        x = trace.states[:, 1:4, 0]  # human_0..2 along the lane
        assert np.all(np.diff(x, axis=1) < -4.5)  # ordered, never overlapping (4.5 m cars)
        assert trace.states[:, 1, 3].min() < 3.0  # the leader really slowed down

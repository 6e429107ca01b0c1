"""Social information reaches the plan: the traffic speed the robot believes in (eq. 12) is the
speed its MPC tracks."""

from __future__ import annotations

import numpy as np

import marl_social


def _robot_and_observation():
    env = marl_social.parallel_env(pedestrian="none", n_humans=0, robot_planner="social")
    robot = marl_social.policies(env)["robot_0"]
    robot.reset(0)
    obs, _ = env.reset(seed=0)
    return robot, obs["robot_0"]


def _believe(robot, index: int) -> None:
    """Put (almost) all of the traffic-speed belief on grid value `index`."""
    traffic = robot.belief.traffic
    p = np.full(len(traffic.grid_mps), 1e-6)
    p[index] = 1.0
    traffic.probabilities = p / p.sum()


def test_the_believed_traffic_speed_sets_the_planned_speed():
    slow, obs = _robot_and_observation()
    fast, _ = _robot_and_observation()
    _believe(slow, 0)
    _believe(fast, -1)
    grid = slow.belief.traffic.grid_mps
    a_slow = float(slow(obs)[0])
    a_fast = float(fast(obs)[0])
    assert slow.v_ref() < fast.v_ref()
    assert abs(slow.v_ref() - grid[0]) < 0.5 and abs(fast.v_ref() - min(grid[-1], 13.9)) < 0.5
    # the robot starts at its desired speed: slow traffic makes it slow down, fast traffic not
    assert a_slow < -0.1 < a_fast + 0.1 and a_slow < a_fast


def test_planners_that_do_not_read_the_humans_track_their_own_speed():
    env = marl_social.parallel_env(pedestrian="none", n_humans=0, robot_planner="aggressive")
    robot = marl_social.policies(env)["robot_0"]
    robot.reset(0)
    _believe(robot, 0)
    assert robot.v_ref() == min(robot.spec.v_desired_mps, env.road_map.speed_limit_mps)

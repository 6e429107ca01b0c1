"""Built-in policies for every agent of an env.

    policies = marl_social.policies(env)       # {agent: policy}; policy(obs) -> action

Every policy is built from its agent's spec (its own parameters), the shared observation
layout and the static map; it never receives the env or the world.
"""

from __future__ import annotations

import numpy as np

from marl_social.agents.cruise import CruiseVehiclePolicy
from marl_social.agents.human import BoltzmannDriver
from marl_social.agents.pedestrian import BoltzmannPedestrian
from marl_social.agents.robot.planner import RobotPlanner
from marl_social.perception.tracking import TrackSet


def make_policy(spec, layout, road_map, agent_names, robot_planner: str = "social"):
    """The built-in planner of one agent: humans and pedestrians are Boltzmann planners; the
    robot runs `robot_planner` (agents/robot.py, or the cruise baseline).
    """
    if spec.role == "pedestrian":
        return BoltzmannPedestrian(spec, layout, road_map)
    if spec.role == "human":
        return BoltzmannDriver(spec, layout, road_map)
    if robot_planner == "cruise":
        return CruiseVehiclePolicy(spec, layout, road_map)
    return RobotPlanner(spec, layout, road_map, agent_names, mode=robot_planner)


def policies(env) -> dict:
    """{agent: policy} for every possible agent of a SocialDrivingEnv (or a wrapper of one);
    the robot's planner is the scenario's `robot_planner` parameter.
    """
    base = getattr(env, "unwrapped", env)
    mode = base.scenario.params.robot_planner
    return {name: make_policy(spec, base.obs_layout, base.road_map, base.possible_agents, mode)
            for name, spec in base.agent_specs.items()}


def truth_tracks(env, observer: str) -> TrackSet:
    """The true current state of every other active agent as a TrackSet (the oracle's
    privileged input; no other planner receives it).
    """
    base = getattr(env, "unwrapped", env)
    world = base.world
    i = base.possible_agents.index(observer)
    others = np.flatnonzero(world.active & (np.arange(world.n) != i))
    return TrackSet(
        ids=others + 1, xy=world.state[others, :2].copy(),
        velocity=world.velocity_mps[others].copy(), pos_std_m=np.zeros(len(others)),
        length_m=world.length_m[others], width_m=world.width_m[others],
        is_pedestrian=world.is_pedestrian[others], seen=np.ones(len(others), bool),
        age_unseen_s=np.zeros(len(others)), heading_rad=world.state[others, 2].copy(),
    )

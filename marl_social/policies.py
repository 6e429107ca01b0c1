"""Built-in policies for every agent, and the autopilot wrapper for RL users.

    policies = marl_social.policies(env)       # {agent: policy}; policy(obs) -> action
    env1 = marl_social.autopilot(env, controlled=["robot_0"])

Every policy is built from its agent's spec (its own parameters), the shared observation
layout and the static map; it never receives the env or the world.
"""

from __future__ import annotations

import numpy as np
from pettingzoo import ParallelEnv

from marl_social.agents.cruise import CruiseVehiclePolicy
from marl_social.agents.human import BoltzmannDriver
from marl_social.agents.pedestrian import BoltzmannPedestrian


def make_policy(spec, layout, road_map, agent_names, robot_planner: str = "social"):
    """The built-in planner of one agent: humans and pedestrians are Boltzmann planners; the
    robot runs `robot_planner` (agents/robot.py, or the cruise baseline)."""
    if spec.role == "pedestrian":
        return BoltzmannPedestrian(spec, layout, road_map)
    if spec.role == "human":
        return BoltzmannDriver(spec, layout, road_map)
    if robot_planner == "cruise":
        return CruiseVehiclePolicy(spec, layout, road_map)
    from marl_social.agents.robot import RobotPlanner

    return RobotPlanner(spec, layout, road_map, agent_names, mode=robot_planner)


def policies(env) -> dict:
    """{agent: policy} for every possible agent of a SocialDrivingEnv (or a wrapper of one);
    the robot's planner is the scenario's `robot_planner` parameter."""
    base = getattr(env, "unwrapped", env)
    mode = base.scenario.params.robot_planner
    return {name: make_policy(spec, base.obs_layout, base.road_map, base.possible_agents, mode)
            for name, spec in base.agent_specs.items()}


class AutopilotEnv(ParallelEnv):
    """A ParallelEnv exposing only `controlled` agents; every other agent is driven by its
    built-in policy from its own observation.

    Args:
        env: a SocialDrivingEnv.
        controlled: names of the agents the user acts for.
    """

    def __init__(self, env, controlled):
        self.env = env
        base = getattr(env, "unwrapped", env)
        unknown = [a for a in controlled if a not in base.possible_agents]
        if unknown or not controlled:
            raise ValueError(f"autopilot: controlled agents {unknown or controlled!r} not in "
                             f"{base.possible_agents}")
        self.controlled = list(controlled)
        self.possible_agents = [a for a in base.possible_agents if a in self.controlled]
        self.metadata = base.metadata
        self.render_mode = base.render_mode
        self.observation_spaces = {a: base.observation_space(a) for a in self.possible_agents}
        self.action_spaces = {a: base.action_space(a) for a in self.possible_agents}
        self._autopilots = {a: p for a, p in policies(base).items() if a not in self.controlled}
        self.agents = []
        self._last_obs = {}

    @property
    def unwrapped(self):
        return self.env.unwrapped if hasattr(self.env, "unwrapped") else self.env

    def observation_space(self, agent):
        return self.observation_spaces[agent]

    def action_space(self, agent):
        return self.action_spaces[agent]

    def reset(self, seed=None, options=None):
        obs, infos = self.env.reset(seed=seed, options=options)
        for i, (name, policy) in enumerate(sorted(self._autopilots.items())):
            policy.reset(None if seed is None else seed * 1000 + i + 1)
        self._last_obs = obs
        self.agents = [a for a in self.env.agents if a in self.controlled]
        return ({a: obs[a] for a in self.agents}, {a: infos[a] for a in self.agents})

    def step(self, actions):
        unknown = [a for a in actions if a not in self.controlled]
        if unknown:
            raise ValueError(f"autopilot: actions for agent(s) {unknown} that the user does not "
                             f"control (controlled: {self.controlled})")
        full = dict(actions)
        for a in self.env.agents:
            if a not in self.controlled:
                policy = self._autopilots[a]
                if getattr(policy, "mode", None) == "oracle":
                    from marl_social.run import truth_tracks

                    policy.observe_truth(truth_tracks(self.env, a))
                full[a] = policy(self._last_obs[a])
        if not self.agents:
            return {}, {}, {}, {}, {}
        obs, rew, term, trunc, infos = self.env.step(full)
        self._last_obs = obs
        mine = [a for a in obs if a in self.controlled]
        # once every controlled agent is done, the wrapped episode is over
        self.agents = [a for a in self.env.agents if a in self.controlled]
        pick = lambda d: {a: d[a] for a in mine}
        return pick(obs), pick(rew), pick(term), pick(trunc), pick(infos)

    def render(self):
        return self.env.render()

    def close(self):
        self.env.close()

    def state(self) -> np.ndarray:
        return self.env.state()


def autopilot(env, controlled) -> AutopilotEnv:
    """Wrap a SocialDrivingEnv so only `controlled` agents are exposed (see AutopilotEnv)."""
    return AutopilotEnv(env, controlled)

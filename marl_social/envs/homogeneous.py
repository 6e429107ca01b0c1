"""One observation space and one action space for every agent, for vectorised RL pipelines.

The env's agents differ in their action spaces (a car's [a m/s^2, delta rad] within its own
limits, a pedestrian's [vx, vy] m/s) and some leave the episode early. SuperSuit's
`pettingzoo_env_to_vec_env_v1` (one vector slot per agent) needs both to be uniform:

    env = marl_social.parallel_env(homogeneous_spaces=True)   # or homogeneous_spaces(env)
    vec = ss.pettingzoo_env_to_vec_env_v1(env)
    vec = ss.concat_vec_envs_v1(vec, 4, base_class="gymnasium")

* Actions: every agent's space is Box(-1, 1, (2,)). Each component maps to its agent's own
  space keeping 0 at 0: a >= 0 -> a * high, a < 0 -> a * |low| (a car: -1 is full braking, +1
  full throttle, 0 neither; a pedestrian: +-1 is +-its top speed per axis). A policy tells the
  kinds apart from the observation's `is_pedestrian` ego field.
* Observations: already one Box for all agents (marl_social/sim/observation.py).
* Agents that finish early (padding, "black death"): every possible agent stays in `agents`
  until the wrapped episode ends. An agent reports its own termination or truncation at the
  step it happens, with its real observation and reward; after that it gets all-zero
  observations, reward 0, its actions are ignored, and it reports truncated=True again only
  when the whole episode ends (so each agent's vector slot sees one episode per env episode
  plus, after an early finish, one zero-reward padding stretch).
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces
from pettingzoo.utils.wrappers import BaseParallelWrapper

ACTION_SPACE = spaces.Box(-1.0, 1.0, shape=(2,), dtype=np.float32)  # every agent's action space


class HomogeneousSpacesEnv(BaseParallelWrapper):
    """A SocialDrivingEnv with one action space for all agents and padding for finished ones.

    See the module docstring for the action mapping and the padding.

    Args:
        env: a SocialDrivingEnv or a parallel wrapper of one (e.g. `autopilot(env, ["robot_0"])`
            for a single learner among the built-in policies).
    """

    def __init__(self, env):
        super().__init__(env)
        first = env.observation_space(env.possible_agents[0])
        if any(env.observation_space(a) != first for a in env.possible_agents):
            raise ValueError("homogeneous_spaces: the agents' observation spaces differ")
        self.possible_agents = list(env.possible_agents)
        self._low = {a: np.asarray(env.action_space(a).low, np.float64)
                     for a in self.possible_agents}
        self._high = {a: np.asarray(env.action_space(a).high, np.float64)
                      for a in self.possible_agents}
        self._zero_obs = np.zeros(first.shape, dtype=np.float32)
        self.agents: list[str] = []

    def action_space(self, agent: str) -> spaces.Box:
        """Box(-1, 1, (2,)) for every agent (see the module docstring)."""
        if agent not in self._low:
            raise ValueError(f"unknown agent {agent!r}; agents: {self.possible_agents}")
        return ACTION_SPACE

    def observation_space(self, agent: str) -> spaces.Box:
        """The shared observation Box."""
        return self.env.observation_space(agent)

    def to_env_action(self, agent: str, action) -> np.ndarray:
        """A normalized action in the wrapped env's units (checked: ValueError naming the agent).

        Args:
            agent: a live agent of the wrapped env.
            action: (2,) normalized action, nominally in [-1, 1].

        Returns:
            (2,) float64 action: [a m/s^2, delta rad] or pedestrian [vx, vy] m/s.
        """
        a = self.env.unwrapped.check_action(agent, action)
        return from_normalized(a, self._low[agent], self._high[agent])

    def check_action(self, agent: str, action) -> np.ndarray:
        """The wrapped env's check of a normalized action (for the AEC conversion)."""
        return self.to_env_action(agent, action)

    def reset(self, seed=None, options=None):
        """Reset the wrapped env; returns (observations, infos) of every possible agent."""
        obs, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.possible_agents)
        return self._pad_obs(obs), {a: infos.get(a, {}) for a in self.agents}

    def step(self, actions: dict):
        """Step with normalized actions; finished agents' actions are ignored.

        Args:
            actions: {agent: (2,) normalized action} for every agent in `agents`; a key that
                names no agent of the env is a ValueError.
        """
        if self.env.unwrapped.world is None:
            raise RuntimeError("step() called before reset()")
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict {{agent: action}}, got "
                            f"{type(actions).__name__}")
        unknown = [a for a in actions if a not in self.possible_agents]
        if unknown:
            raise ValueError(f"actions for unknown agent(s) {unknown}; agents: "
                             f"{self.possible_agents}")
        if not self.agents:  # finished episode: nothing left to step (PettingZoo convention)
            return {}, {}, {}, {}, {}
        live = self.env.agents
        missing = [a for a in live if a not in actions]
        if missing:
            raise ValueError(f"no action for live agent(s) {missing}")
        env_actions = {a: self.to_env_action(a, actions[a]) for a in live}
        obs, rew, term, trunc, infos = self.env.step(env_actions)
        over = not self.env.agents
        padded = [a for a in self.agents if a not in obs]  # finished at an earlier step
        rewards = {a: rew.get(a, 0.0) for a in self.agents}
        terminations = {a: term.get(a, False) for a in self.agents}
        truncations = {a: trunc.get(a, over) for a in self.agents}
        infos = {a: infos.get(a, {}) for a in self.agents}
        for a in padded:
            infos[a] = {"padding": True}
        observations = self._pad_obs(obs)
        if over:
            self.agents = []
        return observations, rewards, terminations, truncations, infos

    def _pad_obs(self, obs: dict) -> dict:
        return {a: obs[a] if a in obs else self._zero_obs.copy() for a in self.possible_agents}

    def state(self) -> np.ndarray:
        """The wrapped env's global state (marl_social/envs/spaces.py)."""
        return self.env.state()


def from_normalized(action: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """A normalized (2,) action in [-1, 1] in an agent's own units, keeping 0 at 0.

    a >= 0 -> a * high, a < 0 -> a * |low| (see the module docstring).

    Args:
        action: (2,) float64 normalized action.
        low: (2,) the agent's action space's lower bounds (<= 0).
        high: (2,) its upper bounds (>= 0).
    """
    return np.where(action >= 0.0, action * high, -action * low)


def homogeneous_spaces(env) -> HomogeneousSpacesEnv:
    """Wrap a SocialDrivingEnv for vectorised pipelines (see HomogeneousSpacesEnv).

    Args:
        env: a SocialDrivingEnv or a parallel wrapper of one (e.g. an AutopilotEnv).
    """
    return HomogeneousSpacesEnv(env)

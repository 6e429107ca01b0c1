"""The autopilot wrapper for RL users: a ParallelEnv of only the agents the user acts for.

Every other agent is driven by its built-in policy.

    env1 = marl_social.autopilot(env, controlled=["robot_0"])
"""

from __future__ import annotations

import numpy as np
from pettingzoo import ParallelEnv

from marl_social.envs.policies import policies, truth_signal_phase, truth_tracks
from marl_social.sim.seeds import checked_seed


class AutopilotEnv(ParallelEnv):
    """A ParallelEnv exposing only `controlled` agents.

    Every other agent is driven by its built-in policy from its own observation.

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
        self.state_space = base.state_space
        self._autopilots = {a: p for a, p in policies(base).items() if a not in self.controlled}
        self.agents = []
        self._last_obs = {}
        self._seed_stream: np.random.Generator | None = None

    @property
    def unwrapped(self):
        return self.env.unwrapped if hasattr(self.env, "unwrapped") else self.env

    def observation_space(self, agent):
        return self.observation_spaces[agent]

    def action_space(self, agent):
        return self.action_spaces[agent]

    def reset(self, seed=None, options=None):
        """Reset the env and the built-in policies; returns the controlled agents' (obs, infos).

        A seed seeds each built-in policy (seed * 1000 + its rank + 1); a later reset without
        one draws their seeds from a stream seeded by the last seed (entropy if never seeded),
        so a seeded run of many episodes is reproducible.
        """
        seed = checked_seed(seed)
        obs, infos = self.env.reset(seed=seed, options=options)
        if seed is not None:
            self._seed_stream = np.random.default_rng(seed)
        elif self._seed_stream is None:
            self._seed_stream = np.random.default_rng()
        for i, (name, policy) in enumerate(sorted(self._autopilots.items())):
            policy.reset(seed * 1000 + i + 1 if seed is not None
                         else int(self._seed_stream.integers(2**63)))
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
                if policy.needs_truth:
                    policy.observe_truth(truth_tracks(self.env, a),
                                         signal_phase=truth_signal_phase(self.env))
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
        """The wrapped env's global state of every agent (marl_social/envs/spaces.py)."""
        return self.env.state()


def autopilot(env, controlled) -> AutopilotEnv:
    """Wrap a SocialDrivingEnv so only `controlled` agents are exposed (see AutopilotEnv)."""
    return AutopilotEnv(env, controlled)

"""Vectorized autopilot envs for RL: n copies stepped in parallel processes.

    venv = marl_social.vector_env(4, controlled=["robot_0"], scenario="occluded_crosswalk")
    obs, infos = venv.reset(seed=0)                   # obs (4, obs_dim) float32
    obs, rew, term, trunc, infos = venv.step(actions)  # actions (4, 2)

Each copy is an `AutopilotGymEnv`: a single-agent Gymnasium view of
`autopilot(parallel_env(...), controlled)`, in which every agent the user does not control is
driven by its built-in planner. The copies run in blocks, one per CPU core by default (a
`BatchedVectorEnv`, marl_social/envs/batched.py: this process steps the first block while
child processes step the others) or, with ``asynchronous=False``, all in a Gymnasium
`SyncVectorEnv` in this process; finished copies reset themselves on
the next step (Gymnasium's default next-step autoreset).

Determinism: ``reset(seed=s)`` seeds copy i with s + i; every later episode of a copy draws its
seed from that copy's own seeded stream, so the same seed and actions give bit-identical
observations, rewards and flags whether the copies run in processes or not.
"""

from __future__ import annotations

import functools
import os

import gymnasium
import numpy as np
from gymnasium import spaces

from marl_social.envs.autopilot import autopilot
from marl_social.envs.batched import BatchedVectorEnv
from marl_social.envs.parallel import SocialDrivingEnv
from marl_social.sim.seeds import checked_seed

_SEED_BOUND = 2**31 - 1  # episode seeds drawn from a copy's stream lie in [0, _SEED_BOUND)


class AutopilotGymEnv(gymnasium.Env):
    """Single-agent Gymnasium view of an autopilot env.

    With one controlled agent the spaces are that agent's Boxes; with several they are a Dict
    keyed by agent name (a controlled agent that has left the episode observes zeros and its
    actions are ignored). The reward is the sum of the live controlled agents' rewards; the
    episode ends when no controlled agent is left: `truncated` if the last of them was
    truncated (max_cycles), else `terminated`.

    Args:
        controlled: names of the agents the user acts for.
        **env_kwargs: arguments of `marl_social.parallel_env` (scenario, max_cycles, overrides).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}  # noqa: RUF012

    def __init__(self, controlled=("robot_0",), **env_kwargs):
        """Build the wrapped PettingZoo env and the spaces of the controlled agents."""
        controlled = [controlled] if isinstance(controlled, str) else list(controlled)
        self.render_mode = env_kwargs.get("render_mode")
        self.pz_env = autopilot(SocialDrivingEnv(**env_kwargs), controlled=controlled)
        self.controlled = list(self.pz_env.possible_agents)
        self._single = len(self.controlled) == 1
        if self._single:
            agent = self.controlled[0]
            self.observation_space = self.pz_env.observation_space(agent)
            self.action_space = self.pz_env.action_space(agent)
        else:
            self.observation_space = spaces.Dict(
                {a: self.pz_env.observation_space(a) for a in self.controlled})
            self.action_space = spaces.Dict(
                {a: self.pz_env.action_space(a) for a in self.controlled})
        self._episode_seeds: np.random.Generator | None = None
        self._last_episode_seed: int | None = None  # the seed of the wrapped env's episode
        self._obs = {}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode; returns (observation, info).

        Args:
            seed: seeds this episode and the stream of seeds of the later ones; None draws the
                next seed of that stream (a fresh stream if never seeded).
            options: unused.
        """
        seed = checked_seed(seed)
        super().reset(seed=seed)
        if seed is not None or self._episode_seeds is None:
            self._episode_seeds = np.random.default_rng(seed)
        self._last_episode_seed = int(self._episode_seeds.integers(_SEED_BOUND))
        obs, infos = self.pz_env.reset(seed=self._last_episode_seed)
        self._obs = {a: obs[a] for a in self.controlled if a in obs}
        return self._observation(), self._info(infos)

    def step(self, action):
        """Advance one step with the controlled agents' action(s).

        Args:
            action: (2,) action of the one controlled agent, or {agent: (2,) action} for
                several.

        Returns:
            (observation, reward, terminated, truncated, info).
        """
        if self._single:
            actions = {self.controlled[0]: action}
        else:
            if not isinstance(action, dict):
                raise ValueError(f"vector env: controlled agents {self.controlled} need a dict "
                                 f"{{agent: action}}, got {type(action).__name__}")
            actions = {a: action[a] for a in self.pz_env.agents if a in action}
            missing = [a for a in self.pz_env.agents if a not in action]
            if missing:
                raise ValueError(f"vector env: no action for controlled agent(s) {missing}")
        obs, rewards, _, truncs, infos = self.pz_env.step(actions)
        self._obs.update(obs)
        for a in self.controlled:
            if a not in self.pz_env.agents:
                self._obs.pop(a, None)
        over = not self.pz_env.agents
        truncated = over and any(truncs.values())
        terminated = over and not truncated
        reward = float(sum(rewards.values()))
        return self._observation(), reward, terminated, truncated, self._info(infos)

    def _observation(self):
        if self._single:
            obs = self._obs.get(self.controlled[0])
            return np.zeros(self.observation_space.shape, np.float32) if obs is None else obs
        return {a: self._obs[a] if a in self._obs
                else np.zeros(self.observation_space[a].shape, np.float32)
                for a in self.controlled}

    def _info(self, infos: dict) -> dict:
        if self._single:
            return dict(infos.get(self.controlled[0], {}))
        return {a: infos[a] for a in self.controlled if a in infos}

    def render(self):
        return self.pz_env.render()

    def close(self):
        self.pz_env.close()


def _make(controlled, env_kwargs):
    """An env factory that pickles (for the worker processes)."""
    return lambda: AutopilotGymEnv(controlled, **env_kwargs)


def usable_cores() -> int:
    """The CPU cores this process may run on (its affinity mask where the OS has one).

    `os.cpu_count()` counts the machine's cores; in a container or job pinned to fewer (docker
    --cpuset-cpus, taskset, Slurm) that many lock-step processes would share the few allowed
    ones, and 4 processes on 2 cores stepped slower than one env (docs/benchmarks.md).
    """
    if hasattr(os, "sched_getaffinity"):
        return max(len(os.sched_getaffinity(0)), 1)
    return os.cpu_count() or 1


def vector_env(n: int, controlled=("robot_0",), asynchronous: bool = True, context=None,
               workers: int | None = None, **env_kwargs) -> gymnasium.vector.VectorEnv:
    """N autopilot envs stepped together (see the module docstring).

    Args:
        n: number of env copies.
        controlled: names of the agents the user acts for.
        asynchronous: True to step the copies in worker processes, False for a
            SyncVectorEnv in this process (same results).
        context: multiprocessing start method of the workers ("fork", "spawn",
            "forkserver"); None for the platform default.
        workers: processes that step the copies, this one included (asynchronous only); None
            for min(n, usable_cores()). Each steps a contiguous block of copies: this process the
            first while workers - 1 child processes step theirs and answer for their block in
            one message (marl_social/envs/batched.py: less waiting for the slowest copy, one
            round trip per child, no process idling on the others; `marl-social bench env`
            measures it).
        **env_kwargs: arguments of `marl_social.parallel_env` (scenario, max_cycles, overrides).
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"vector_env: n must be a positive integer, got {n!r}")
    if workers is None:
        workers = min(int(n), usable_cores())
    if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) \
            or not 1 <= workers <= n:
        raise ValueError(f"vector_env: workers must be an integer in [1, n={n}], got {workers!r}")
    controlled = [controlled] if isinstance(controlled, str) else list(controlled)
    if asynchronous:
        return BatchedVectorEnv(int(n), int(workers),
                                functools.partial(AutopilotGymEnv, controlled, **env_kwargs),
                                context=context)
    AutopilotGymEnv(controlled, **env_kwargs).close()  # bad arguments fail here
    fns = [_make(controlled, env_kwargs) for _ in range(int(n))]
    return gymnasium.vector.SyncVectorEnv(fns)

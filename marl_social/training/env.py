"""The env RLlib trains on: the learners' agents of a scene, the others on their planners.

    env = SceneEnv({"scenario": "occluded_crosswalk", "learn": "robot"})

RLlib's `MultiAgentEnv` over `marl_social.parallel_env` inside `autopilot` (every agent that
does not learn runs its built-in planner). What RLlib needs and PettingZoo's stock adapters
(RLlib's `ParallelPettingZooEnv`) get wrong for this env:

* Spaces: `possible_agents` and every learner's observation and action space are declared at
  construction, from the scene's template episode (`possible_agents`), not from the agents
  present at the first reset: an agent that appears later is in the spaces from the start.
* Episode ends: an agent that ends (collision, arrival) gets its final observation, reward
  and termination in the step it ends, and no more observations after that; the episode is
  over ("__all__") when no learner is left; truncation (max_cycles) is reported as such.
* `render()` takes no argument (the stock adapter passes its render mode to PettingZoo's
  `render()`, which takes none) and returns the base env's frame with `render_mode="rgb_array"`.
* Observations are scaled to [-1, 1] by their space's bounds (`ObservationScaler`), actions
  are normalized, Box(-1, 1, (1,)) for the acceleration alone (the steering by pure pursuit,
  `control="accel"`) or (2,) with the steering, mapped to each agent's own units keeping 0 at
  0 (training/scene.py `Actuator`), rewards multiplied by `reward_scale` (the env's step costs
  sum to thousands per episode).

Each episode may draw the pedestrian variant and a randomization preset from the env's own
seeded stream (`variants`, `randomize`), so one run trains on crossing, waiting and absent
pedestrians. At the end of an episode every learner's last info holds "episode_metrics": the
robot's metrics of the episode so far (metrics/episode.py: collision, hard brake, time to pass,
yielded), the same code `run_episode` computes them with.
"""

from __future__ import annotations

import numpy as np

from marl_social.evaluation.rollout import TraceRecorder
from marl_social.metrics.episode import episode_metrics
from marl_social.training.scene import (
    METRIC_KEYS,
    ROBOT,
    SceneSettings,
    actuators,
    build_parallel,
    episode_overrides,
    observation_scalers,
    template_env,
)


def _multi_agent_env_class():
    from ray.rllib.env.multi_agent_env import MultiAgentEnv

    return MultiAgentEnv


class SceneEnv(_multi_agent_env_class()):
    """RLlib MultiAgentEnv of a scene's learners (see the module docstring).

    Args:
        config: RLlib's env_config: SceneSettings' fields as a dict (or a SceneSettings).
    """

    def __init__(self, config=None):
        super().__init__()
        self.settings = settings = SceneSettings.from_config(config or {})
        self._rng = np.random.default_rng()
        self.env = template_env(settings)
        self.possible_agents = list(self.env.possible_agents)
        self.agents = []
        self.scalers = observation_scalers(self.env)
        self.observation_spaces = {a: s.space for a, s in self.scalers.items()}
        self.actuators = actuators(self.env, settings.control)
        self.action_spaces = {a: act.space for a, act in self.actuators.items()}
        self._raw_obs: dict = {}
        self.render_mode = getattr(self.env, "render_mode", None)
        self._recorder: TraceRecorder | None = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new episode; a seed restarts the env's stream of episode seeds."""
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        episode_seed = int(self._rng.integers(2**31))
        if self.settings.variants or self.settings.randomize:
            self.env.close()
            self.env = build_parallel(self.settings,
                                      episode_overrides(self.settings, episode_seed))
            self._check_spaces()
            self.actuators = actuators(self.env, self.settings.control)
        obs, infos = self.env.reset(seed=episode_seed)
        self._raw_obs = obs
        self._recorder = TraceRecorder(self.env)
        self.agents = list(self.env.agents)
        return self._scaled(obs), infos

    def step(self, action_dict: dict):
        actions = {a: self.actuators[a](self._raw_obs[a], action_dict[a])
                   for a in self.env.agents if a in action_dict}
        obs, rewards, terminations, truncations, infos = self.env.step(actions)
        self._raw_obs = obs
        self._recorder.record_step(rewards, infos)  # collisions: the learners' own
        self.agents = list(self.env.agents)
        scale = self.settings.reward_scale
        rewards = {a: scale * r for a, r in rewards.items()}
        over = not self.agents
        truncated = over and any(truncations.values())
        terminations["__all__"] = over and not truncated
        truncations["__all__"] = truncated
        if over:
            metrics = self.episode_metrics()
            infos = {a: {**info, "episode_metrics": metrics} for a, info in infos.items()}
        return self._scaled(obs), rewards, terminations, truncations, infos

    def episode_metrics(self) -> dict:
        """The robot's metrics of the finished episode (NaN without a robot).

        Its collision is read from the learners' infos: with learn="humans", a collision of
        the robot with no learner is not counted.
        """
        trace = self._recorder.trace.finalize()
        if ROBOT not in trace.names:
            return dict.fromkeys(METRIC_KEYS, float("nan"))
        metrics = episode_metrics(trace, self.env.unwrapped.road_map, ROBOT)
        return {k: float(metrics[k]) for k in METRIC_KEYS}

    def _scaled(self, obs: dict) -> dict:
        return {a: self.scalers[a](o) for a, o in obs.items()}

    def _check_spaces(self) -> None:
        """This episode's learners must be among the declared ones, with the declared sizes.

        A declared learner may be absent from an episode (RLlib's possible_agents); one that
        was not declared cannot appear (e.g. a randomized number of humans beyond the first
        episode's: fix it with an override).
        """
        new = [a for a in self.env.possible_agents if a not in self.observation_spaces]
        if new:
            raise ValueError(f"an episode has learners {new} that the first episode did not "
                             f"have ({self.possible_agents}): fix their number with an override")
        for a in self.env.possible_agents:
            if self.env.observation_space(a).shape != self.observation_spaces[a].shape:
                raise ValueError(f"agent {a!r}: this episode's observation size differs from "
                                 "the first episode's")

    def render(self):
        """The base env's frame (build the scene with overrides={"render_mode": "rgb_array"})."""
        return self.env.render()

    def close(self):
        self.env.close()

"""PettingZoo environment: every agent acts on its own field of view.

    env = marl_social.parallel_env(scenario="occluded_crosswalk", max_cycles=200, **overrides)

* Agents: `robot_0`, `human_0...` (human drivers), `pedestrian_0...`.
* Observation: one float32 Box layout for all agents (marl_social/sim/observation.py), its
  bounds from the agents' physical limits (map extent and reach, speeds, sensor ranges).
* State: `state()` is every agent's true state over `possible_agents`, a fixed-size
  float32 vector in `state_space` (marl_social/envs/spaces.py), for centralized critics.
* Actions: vehicles Box [a m/s^2, delta rad] within [-brake_max, accel_max] x [-steer_max,
  steer_max]; pedestrians Box [vx, vy] m/s within [-v_max, v_max]^2. Values outside the physical
  limits saturate (marl_social/sim/dynamics.py); NaN/inf, a wrong shape or an unknown agent raise a
  ValueError naming the agent.
* Rewards: -(theta . phi) of the agent's own step cost (marl_social/sim/costs.py) minus the
  scenario's collision penalty when it collides (marl_social/envs/rewards.py).
* Terminations: collision (every agent if the scenario's terminate_on_collision, else those
  involved) or reaching the end of its route; truncation after max_cycles steps.
* infos[agent]: "visible" (names the agent truly sees), "collision" (bool), "collided_with"
  (names, "static" for a building or parked car), "arrived" (bool).
* AEC: `env()` is PettingZoo's parallel-to-AEC conversion with each action checked as it is
  given (a rejected one raises and is not stored) inside OrderEnforcingWrapper; `raw_env()`
  the same without OrderEnforcingWrapper.
* `parallel_env(homogeneous_spaces=True)`: one action space for all agents and padding for
  finished ones, for SuperSuit's vector envs (marl_social/envs/homogeneous.py).
"""

from __future__ import annotations

import math
import numbers
from typing import ClassVar

import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle, seeding
from pettingzoo import ParallelEnv
from pettingzoo.utils import wrappers
from pettingzoo.utils.conversions import parallel_to_aec_wrapper

from marl_social.envs.rewards import step_rewards
from marl_social.envs.spaces import encode_state, env_limits, state_space
from marl_social.envs.world import World
from marl_social.scenarios import make_scenario
from marl_social.scenarios.base import as_integer, short_repr
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.seeds import checked_seed
from marl_social.viz.style import RenderConfig

RENDER_MODES = ["human", "rgb_array"]
MAX_CYCLES = 10**9  # longest episode [steps]
FLOAT_MAX = float(np.finfo(np.float64).max)  # a Python float: compares exactly with any int


class SocialDrivingEnv(ParallelEnv, EzPickle):
    """Parallel multi-agent driving env; see the module docstring.

    Args:
        scenario: name of a registered scenario.
        render_mode: None, "human" (a window, where a display exists) or "rgb_array" (`render()`
            returns (H, W, 3) uint8 frames).
        max_cycles: steps before every agent is truncated.
        render_fov: draw every agent's field of view in the frames.
        render_config: how frames are drawn (size, view that follows the robot, ...); None for
            the default `RenderConfig()`.
        **overrides: scenario parameters (see the scenario's params dataclass).
    """

    metadata: ClassVar[dict] = {
        "name": "marl_social_v0",
        "render_modes": RENDER_MODES,
        "render_fps": 10,
        "is_parallelizable": True,
    }

    def __init__(self, scenario: str = "occluded_crosswalk", render_mode: str | None = None,
                 max_cycles: int = 200, render_fov: bool = True,
                 render_config: RenderConfig | None = None, **overrides):
        """Build the scenario's template episode to fix the agents and their spaces."""
        EzPickle.__init__(self, scenario=scenario, render_mode=render_mode,
                          max_cycles=max_cycles, render_fov=render_fov,
                          render_config=render_config, **overrides)
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode {render_mode!r}: must be None or one of {RENDER_MODES}")
        if render_config is not None and not isinstance(render_config, RenderConfig):
            raise TypeError(f"render_config must be a marl_social.viz.style.RenderConfig or None, "
                            f"got {type(render_config).__name__}")
        max_cycles = as_integer(max_cycles, "max_cycles")
        if not 1 <= max_cycles <= MAX_CYCLES:
            raise ValueError(f"max_cycles must be an integer in [1, {MAX_CYCLES}], got {max_cycles}")
        self.scenario_name = scenario
        self.scenario = make_scenario(scenario, **overrides)
        self.render_mode = render_mode
        if not isinstance(render_fov, (bool, np.bool_)):
            raise TypeError(f"render_fov must be a bool, got {short_repr(render_fov)}")
        self.render_fov = bool(render_fov)
        self.render_config = render_config if render_config is not None else RenderConfig()
        self.max_cycles = int(max_cycles)
        template = self.scenario.build(np.random.default_rng(0))
        self.road_map = template.road_map
        self.agent_specs = {s.name: s for s in template.agents}
        self.possible_agents = [s.name for s in template.agents]
        self.obs_layout = ObservationLayout(template.params.n_slots, template.params.n_rays,
                                            len(template.road_map.signal_heads))
        self.limits = env_limits(template, self.max_cycles)
        self.state_space = state_space(self.limits, template.agents,
                                       len(template.road_map.signal_heads))
        obs_space = self.obs_layout.space(self.limits)
        self.observation_spaces = {a: obs_space for a in self.possible_agents}
        self.action_spaces = {s.name: _action_space(s) for s in template.agents}
        self.agents: list[str] = []
        self.world: World | None = None
        self.last_fov = None
        self._np_random = None
        self._np_random_seed = None
        self._renderer = None
        self._cycles = 0

    # -- spaces ------------------------------------------------------------------------------
    def observation_space(self, agent: str) -> spaces.Box:
        """The float32 observation Box of an agent (one layout for all agents)."""
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        """The action Box of an agent: [a m/s^2, delta rad] or pedestrian [vx, vy] m/s."""
        return self.action_spaces[agent]

    # -- episode -----------------------------------------------------------------------------
    def reset(self, seed: int | None = None, options: dict | None = None):
        """Start an episode; returns (observations, infos) keyed by agent name.

        Args:
            seed: seeds the env's generator (layout and sensor noise); None keeps the stream.
            options: unused (PettingZoo signature).
        """
        seed = checked_seed(seed)
        if seed is not None or self._np_random is None:
            self._np_random, self._np_random_seed = seeding.np_random(seed)
        layout = self.scenario.build(self._np_random)
        self.world = World(layout, reuse=self.world)  # static geometry built once
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self.agents = list(self.possible_agents)
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        self._cycles = 0
        observations, infos = self._observe(
            collided_with={a: [] for a in self.agents}, arrived=np.zeros(self.world.n, bool)
        )
        if self.render_mode == "human":
            self.render()
        return observations, infos

    def step(self, actions: dict):
        """Advance one step; returns (observations, rewards, terminations, truncations, infos).

        Args:
            actions: {agent: (2,) action} for every live agent (see the module docstring).
        """
        if self.world is None:
            raise RuntimeError("step() called before reset()")
        raw = self._validate_actions(actions)
        if not self.agents:  # finished episode: nothing left to step (PettingZoo convention)
            return {}, {}, {}, {}, {}
        world = self.world
        events = world.step(raw)
        self._cycles += 1

        reward = step_rewards(world.theta, world.step_features(), events.collided,
                              self.scenario.params.collision_penalty)
        collided_with = {a: [] for a in self.agents}
        for a, b in events.contacts:
            for me, other in ((a, b), (b, a)):
                if me < world.n and self.possible_agents[me] in collided_with:
                    collided_with[self.possible_agents[me]].append(
                        self.possible_agents[other] if other < world.n else "static"
                    )
        any_collision = bool((events.collided & world.active).any())  # active: self.agents
        if any_collision and self.scenario.params.terminate_on_collision:
            terminated = np.ones(world.n, dtype=bool)
        else:
            terminated = events.collided | events.arrived
        truncated = self._cycles >= self.max_cycles

        observations, infos = self._observe(collided_with, events.arrived)
        index, reward, terminated = self._index, reward.tolist(), terminated.tolist()
        rewards = {a: reward[index[a]] for a in self.agents}
        terminations = {a: terminated[index[a]] for a in self.agents}
        truncations = {a: truncated for a in self.agents}

        done = np.zeros(world.n, dtype=bool)
        for a in self.agents:
            done[index[a]] = terminations[a] or truncations[a]
        self.agents = [a for a in self.agents if not (terminations[a] or truncated)]
        world.deactivate(done)
        if self.render_mode == "human":
            self.render()
        return observations, rewards, terminations, truncations, infos

    def _validate_actions(self, actions: dict) -> np.ndarray:
        """(n, 2) raw actions from {agent: action}, every live agent's checked (ValueError)."""
        if not isinstance(actions, dict):
            raise TypeError(f"actions must be a dict {{agent: action}}, got {type(actions).__name__}")
        raw = np.zeros((self.world.n, 2))
        for agent, action in actions.items():
            raw[self._index[agent]] = self.check_action(agent, action)  # checked before indexing
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"no action for live agent(s) {missing}")
        return raw

    def check_action(self, agent: str, action) -> np.ndarray:
        """One live agent's action as a finite (2,) float64 array, else a ValueError naming it.

        Accepted: a sequence or array of 2 real numbers (integer or floating dtype). Rejected:
        bool, string, complex, datetime or object dtypes, numbers beyond float range, NaN/inf,
        another shape, an unknown agent or one no longer in the episode.

        Args:
            agent: the agent's name.
            action: its (2,) action (see the module docstring for units).
        """
        if agent not in self._index:
            raise ValueError(f"action for unknown agent {agent!r}; agents: {self.possible_agents}")
        if agent not in self.agents:
            raise ValueError(f"action for agent {agent!r}, which is no longer in the episode "
                             f"(live agents: {self.agents})")
        if isinstance(action, (list, tuple)) and any(
                isinstance(v, (bool, np.bool_, str, bytes, complex)) for v in action):
            raise ValueError(f"agent {agent!r}: action {_short(action)} is not numeric (holds "
                             f"{sorted({type(v).__name__ for v in action})}, not real numbers)")
        try:
            arr = np.asarray(action)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"agent {agent!r}: action {_short(action)} is not numeric") from None
        if (isinstance(action, (list, tuple)) and arr.dtype == object
                and all(isinstance(v, numbers.Real) for v in arr.ravel())):
            # a list holding Python ints beyond int64 (e.g. 2**64): real numbers, as floats if
            # they fit (an array the caller made of dtype object is not numeric)
            if any(abs(v) > FLOAT_MAX for v in arr.ravel()):
                raise ValueError(f"agent {agent!r}: action {_short(action)} holds an integer "
                                 "beyond float range")
            arr = arr.astype(np.float64)
        if arr.dtype.kind not in "iuf":
            raise ValueError(f"agent {agent!r}: action {_short(action)} is not numeric (dtype "
                             f"{arr.dtype}, not a real integer or float)")
        if arr.shape != (2,):
            raise ValueError(f"agent {agent!r}: action must have shape (2,), got {arr.shape}")
        arr = arr.astype(np.float64)
        first, second = arr.tolist()
        if not (math.isfinite(first) and math.isfinite(second)):  # np.isfinite's answer
            raise ValueError(f"agent {agent!r}: action {arr.tolist()} has NaN or inf")
        return arr

    def _observe(self, collided_with: dict, arrived: np.ndarray):
        world = self.world
        fov, meas = world.perceive(self._np_random)
        self.last_fov = fov
        obs = self.obs_layout.encode(
            world.bodies(), meas, fov.depth_m,
            signals=world.perceive_signals() if self.obs_layout.n_signals else None,
        )
        names = self.possible_agents
        visible, arrived = fov.visible.tolist(), arrived.tolist()
        observations, infos = {}, {}
        for agent in self.agents:
            i = self._index[agent]
            observations[agent] = obs[i]
            infos[agent] = {
                "visible": [name for name, seen in zip(names, visible[i]) if seen],
                "collision": bool(collided_with[agent]),
                "collided_with": collided_with[agent],
                "arrived": arrived[i],
            }
        return observations, infos

    # -- rendering ---------------------------------------------------------------------------
    def render(self):
        """Draw the current step: an (H, W, 3) uint8 frame in "rgb_array" mode, else None."""
        if self.render_mode is None:
            import gymnasium

            gymnasium.logger.warn("render() called without a render_mode; nothing to draw")
            return None
        if self.world is None:
            raise RuntimeError("render() called before reset()")
        from marl_social.viz.frames import Renderer

        if self._renderer is None:  # one per episode: the map may change between episodes
            cfg = self.render_config
            road_map = self.world.road_map
            x0, x1, y0, y1 = road_map.extent
            follow = cfg.follow_agent if cfg.follow_agent in self.possible_agents else None
            fan_agents = None  # every agent's field of view ...
            if len(self.possible_agents) > cfg.max_agents_with_fans:  # ... or only the followed
                fan_agents = [follow] if follow is not None else []
            self._renderer = Renderer(
                road_map, show=self.render_mode == "human",
                size=cfg.frame_size,
                view=(x0, min(x1, x0 + cfg.view_width_m), y0, y1) if follow is not None else None,
                follow=follow, fan_agents=fan_agents,
            )
        frame = self._renderer.draw(self.world, self.last_fov if self.render_fov else None)
        return frame if self.render_mode == "rgb_array" else None

    def close(self):
        """Free the renderer (and its window). Idempotent."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def state(self) -> np.ndarray:
        """The true state: (n_agents * STATE_DIM [+ signal block],) float32 in `state_space`.

        Per agent in `possible_agents` order: [x m, y m, cos(psi), sin(psi), v m/s, active];
        agents no longer in the episode are all-zero rows; on a map with signals, then every
        head's state one-hot (marl_social/envs/spaces.py). For centralized critics; planners
        never receive it.

        Raises:
            RuntimeError: called before reset().
        """
        if self.world is None:
            raise RuntimeError("state() called before reset(): the env has no episode yet")
        live = np.zeros(self.world.n, dtype=bool)
        live[[self._index[a] for a in self.agents]] = True
        return encode_state(self.world.state, live, self.world.signal_states())


def _action_space(spec) -> spaces.Box:
    if spec.kind == "pedestrian":
        v = spec.pedestrian.speed_max_mps
        return spaces.Box(-v, v, shape=(2,), dtype=np.float32)
    veh = spec.vehicle
    return spaces.Box(
        low=np.array([-veh.brake_max_mps2, -veh.steer_max_rad], dtype=np.float32),
        high=np.array([veh.accel_max_mps2, veh.steer_max_rad], dtype=np.float32),
        dtype=np.float32,
    )


def parallel_env(scenario: str = "occluded_crosswalk", render_mode: str | None = None,
                 max_cycles: int = 200, homogeneous_spaces: bool = False,
                 observation: str = "ego", **overrides):
    """The PettingZoo ParallelEnv (see SocialDrivingEnv).

    Args:
        scenario: name of a registered scenario.
        render_mode: None, "human" or "rgb_array".
        max_cycles: steps before every agent is truncated.
        homogeneous_spaces: one Box(-1, 1, (2,)) action space for every agent and zero padding
            for agents that finish early, for SuperSuit's vector envs
            (marl_social/envs/homogeneous.py).
        observation: "ego" (the shared layout for every agent) or "ego+belief" (the robot's
            also holds its social belief: marl_social/envs/belief_observation.py).
        **overrides: scenario parameters and SocialDrivingEnv's other options.
    """
    env = SocialDrivingEnv(scenario=scenario, render_mode=render_mode, max_cycles=max_cycles,
                           **overrides)
    if not isinstance(homogeneous_spaces, (bool, np.bool_)):
        raise TypeError(f"homogeneous_spaces must be a bool, got {_short(homogeneous_spaces)}")
    if observation not in ("ego", "ego+belief"):
        raise ValueError(f"observation must be 'ego' or 'ego+belief', got {_short(observation)}")
    if observation == "ego+belief":
        if homogeneous_spaces:
            raise ValueError("observation='ego+belief' and homogeneous_spaces=True: the robot's "
                             "observation would differ from the others' (wrap it yourself)")
        from marl_social.envs.belief_observation import belief_observation

        return belief_observation(env)
    if homogeneous_spaces:
        from marl_social.envs.homogeneous import HomogeneousSpacesEnv

        return HomogeneousSpacesEnv(env)
    return env


def _short(value, limit: int = 80) -> str:
    """repr(value) cut to `limit` characters (a huge integer's repr is huge)."""
    text = repr(value)
    return text if len(text) <= limit else text[:limit] + "..."


_EPISODE_ATTRIBUTES = frozenset(("agents", "agent_selection", "rewards", "terminations",
                                 "truncations", "infos", "_cumulative_rewards"))


class CheckedAECWrapper(parallel_to_aec_wrapper):
    """PettingZoo's parallel-to-AEC conversion that checks each action when it is given.

    A rejected action raises a ValueError naming the agent and is not stored, so the next
    step() retries the same agent (the stock wrapper stores it and fails at the cycle's last
    agent on every later step). A non-None action for a done agent is a ValueError too (the
    stock wrapper asserts).

    Args:
        parallel_env: a SocialDrivingEnv (or its HomogeneousSpacesEnv).
    """

    def __getattr__(self, name):
        """The episode's bookkeeping before reset(): an AttributeError saying to reset."""
        if name in _EPISODE_ATTRIBUTES:
            raise AttributeError(f"{name} cannot be accessed before reset(): call reset() first")
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def last(self, observe: bool = True):
        """The selected agent's (observation, reward, termination, truncation, info).

        A RuntimeError after the episode's end (no agent is selected then) and before reset().
        """
        if hasattr(self, "agents") and not self.agents:
            raise RuntimeError("last() called after the episode ended: call reset() first")
        return super().last(observe)

    def observe(self, agent):
        """An agent's latest observation (what last() returns).

        A RuntimeError before reset() and in a copy taken mid-episode (see `step`).
        """
        if self.env.unwrapped.world is None:
            raise RuntimeError("observe()/last() called before reset() (or on a copy of an env "
                               "taken mid-episode, which starts unreset): call reset() first")
        return super().observe(agent)

    def step(self, action):
        """Store (after checking) the selected agent's action; the cycle's last one steps.

        Before reset(), after the episode's end and in a copy taken mid-episode (pickle or
        deepcopy rebuild the env from its arguments, not its state) a RuntimeError says to call
        reset().
        """
        if not hasattr(self, "agent_selection") or self.env.unwrapped.world is None:
            raise RuntimeError("step() called before reset() (or on a copy of an env taken "
                               "mid-episode, which starts unreset): call reset() first")
        if not self.agents:
            raise RuntimeError("step() called after the episode ended: call reset() first")
        agent = self.agent_selection
        if self.terminations[agent] or self.truncations[agent]:
            if action is not None:
                raise ValueError(f"agent {agent!r} is done (terminated or truncated): its step "
                                 f"action must be None, got {_short(action)}")
        else:
            self.env.check_action(agent, action)
        super().step(action)


def raw_env(**kwargs):
    """AEC version without PettingZoo's wrappers (actions still checked as they are given).

    Args:
        **kwargs: the arguments of parallel_env.
    """
    return CheckedAECWrapper(parallel_env(**kwargs))


def env(**kwargs):
    """AEC version: raw_env inside PettingZoo's OrderEnforcingWrapper (reset before step).

    No action clipping wrapper: out-of-range actions saturate in the dynamics as in the
    parallel env (a pedestrian's command by its norm, which per-axis clipping would change).

    Args:
        **kwargs: the arguments of parallel_env.
    """
    return _OrderEnforcing(raw_env(**kwargs))


class _OrderEnforcing(wrappers.OrderEnforcingWrapper):
    """PettingZoo's order enforcing, where a step after the episode's end is an error.

    The stock wrapper only warns and drops the action.
    """

    def last(self, observe: bool = True):
        if self._has_reset and not self.env.agents:
            raise RuntimeError("last() called after the episode ended: call reset() first")
        return super().last(observe)

    def step(self, action):
        if self._has_reset and not self.env.agents:
            raise RuntimeError("step() called after the episode ended: call reset() first")
        super().step(action)

"""Roll out one episode with a set of policies and record everything per step (the trace)."""

from __future__ import annotations

import numpy as np

from marl_social.sim.seeds import checked_seed
from marl_social.sim.trace import Trace


def record_episode(env, policies: dict, seed: int | None = None, render: bool = False,
                   render_every: int = 1, until=None) -> Trace:
    """Roll out policies in a SocialDrivingEnv from reset(seed) until every agent is done.

    Each policy sees only its own observation.

    Args:
        env: the SocialDrivingEnv (or a wrapper of it).
        policies: {agent name: policy}, a policy for every agent of the env.
        seed: the reset seed; agent i's policy is reset with seed + i (None: unseeded).
        render: also collect env.render() frames (env must have render_mode="rgb_array").
        render_every: keep one frame every this many steps.
        until: None, or a condition `until(env) -> bool` checked after every step: the
            recording ends at the first state where it holds (marl_social/evaluation/
            stopping.py: an episode cut short once what it measures is known).
    """
    seed = checked_seed(seed)
    base = getattr(env, "unwrapped", env)
    for name, policy in policies.items():
        policy.reset(None if seed is None else seed + base.possible_agents.index(name))
    obs, infos = env.reset(seed=seed)
    recorder = TraceRecorder(env, render, render_every)
    while env.agents:
        actions = {a: policies[a](obs[a]) for a in env.agents}
        obs, rewards, _, _, infos = env.step(actions)
        recorder.record_step(rewards, infos)
        if until is not None and until(env):
            break
    return recorder.trace.finalize()


class TraceRecorder:
    """Records a SocialDrivingEnv's episode into a Trace, one call per step.

    Build it right after `env.reset()` (it records the reset state), then call `record_step`
    after every `env.step()`; `trace.finalize()` once the episode is over.

    Args:
        env: the SocialDrivingEnv (or a wrapper of it), just reset.
        render: also collect env.render() frames (env must have render_mode="rgb_array").
        render_every: keep one frame every this many steps.
    """

    def __init__(self, env, render: bool = False, render_every: int = 1):
        self.env, self.render, self.render_every = env, render, render_every
        self.base = base = getattr(env, "unwrapped", env)
        self.names = list(base.possible_agents)
        self.trace = Trace(self.names, [base.agent_specs[a].role for a in self.names],
                           base.world.bounding_radius_m.copy())
        self.snapshot()

    def snapshot(self) -> None:
        """Append the current state (time, states, activity, visibility, signals[, frame])."""
        world, trace = self.base.world, self.trace
        trace.times_s.append(world.time_s)
        trace.states.append(world.state.copy())
        trace.active.append(world.active.copy())
        trace.visible.append(self.base.last_fov.visible.copy())
        trace.signal_states.append(world.signal_states())
        if self.render and (len(trace.times_s) - 1) % self.render_every == 0:
            trace.frames.append(self.env.render())

    def record_step(self, rewards: dict, infos: dict) -> None:
        """Append one step: its actions, accelerations, rewards, collisions, then the state.

        Args:
            rewards: {agent: reward} of the step (agents absent: 0).
            infos: {agent: info} of the step (each with "collision").
        """
        world, trace, names = self.base.world, self.trace, self.names
        reward_row = np.zeros(len(names))
        collided_row = np.zeros(len(names), dtype=bool)
        for a, r in rewards.items():
            reward_row[names.index(a)] = r
            collided_row[names.index(a)] = infos[a]["collision"]
        trace.actions.append(world.last_applied_action.copy())
        trace.accel_mps2.append(world.accel_mps2.copy())
        trace.rewards.append(reward_row)
        trace.collided.append(collided_row)
        self.snapshot()

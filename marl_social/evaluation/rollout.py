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
    names = list(base.possible_agents)
    trace = Trace(names, [base.agent_specs[a].role for a in names],
                  base.world.bounding_radius_m.copy())

    def snapshot():
        world = base.world
        trace.times_s.append(world.time_s)
        trace.states.append(world.state.copy())
        trace.active.append(world.active.copy())
        trace.visible.append(base.last_fov.visible.copy())
        trace.signal_states.append(world.signal_states())
        if render and (len(trace.times_s) - 1) % render_every == 0:
            trace.frames.append(env.render())

    snapshot()
    n = len(names)
    while env.agents:
        actions = {a: policies[a](obs[a]) for a in env.agents}
        obs, rewards, _, _, infos = env.step(actions)
        world = base.world
        reward_row = np.zeros(n)
        collided_row = np.zeros(n, dtype=bool)
        for a, r in rewards.items():
            reward_row[names.index(a)] = r
            collided_row[names.index(a)] = infos[a]["collision"]
        trace.actions.append(world.last_applied_action.copy())
        trace.accel_mps2.append(world.accel_mps2.copy())
        trace.rewards.append(reward_row)
        trace.collided.append(collided_row)
        snapshot()
        if until is not None and until(env):
            break
    return trace.finalize()

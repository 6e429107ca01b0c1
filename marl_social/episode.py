"""Run one episode with a set of policies and record everything per step (the trace)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Trace:
    """Per-step record of one episode (T steps, n agents, in env.possible_agents order).

    Attributes:
        names: (n,) agent names; roles: (n,) "robot" / "human" / "pedestrian".
        times_s: (T+1,) time of each recorded state [s] (index 0 = reset).
        states: (T+1, n, 4) true [x m, y m, heading rad, speed m/s].
        active: (T+1, n) bool, agent still in the episode.
        visible: (T+1, n, n) bool, visible[t, o, j]: agent o sees agent j.
        actions: (T, n, 2) applied (saturated) actions.
        accel_mps2: (T, n) longitudinal acceleration applied in each step [m/s^2].
        rewards: (T, n).
        collided: (T, n) bool.
        frames: rendered RGB frames, if requested.
        extras: free-form per-step series added by callers (e.g. beliefs), name -> (T+1,) array.
        bounding_radius_m: (n,) footprint bounding radii [m].
    """

    names: list
    roles: list
    bounding_radius_m: np.ndarray
    times_s: list = field(default_factory=list)
    states: list = field(default_factory=list)
    active: list = field(default_factory=list)
    visible: list = field(default_factory=list)
    actions: list = field(default_factory=list)
    accel_mps2: list = field(default_factory=list)
    rewards: list = field(default_factory=list)
    collided: list = field(default_factory=list)
    frames: list = field(default_factory=list)
    extras: dict = field(default_factory=dict)

    def index(self, name: str) -> int:
        return self.names.index(name)

    def finalize(self) -> Trace:
        """Stack the recorded lists into arrays (call once, after the episode)."""
        for key in ("times_s", "states", "active", "visible", "actions", "accel_mps2",
                    "rewards", "collided"):
            setattr(self, key, np.asarray(getattr(self, key)))
        return self


def record_episode(env, policies: dict, seed: int | None = None, render: bool = False,
                   render_every: int = 1) -> Trace:
    """Roll out `policies` ({agent: policy}) in a SocialDrivingEnv from reset(seed) until every
    agent is done. Each policy sees only its own observation.

    Args:
        render: also collect env.render() frames (env must have render_mode="rgb_array").
        render_every: keep one frame every this many steps.
    """
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
    return trace.finalize()

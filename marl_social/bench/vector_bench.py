"""Benchmark (never a timed unit test): vector_env throughput vs one autopilot env.

The single-agent autopilot env (`AutopilotGymEnv`: the robot is the user's, every other agent
runs its built-in planner) is stepped with seeded random robot actions, first alone in this
process, then as n copies in a Gymnasium AsyncVectorEnv (one worker process each). Both rates
count env steps (one copy advancing one step = one step) per wall-clock second, resets
included.
"""

from __future__ import annotations

import time

import numpy as np

from marl_social.envs.vector import AutopilotGymEnv, vector_env


def single_env_steps_per_s(n_steps: int, seed: int = 0, **env_kwargs) -> float:
    """Steps/s of one AutopilotGymEnv in this process, random controlled actions."""
    env = AutopilotGymEnv(**env_kwargs)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    for _ in range(5):  # warm-up
        env.step(env.action_space.sample())
    start = time.perf_counter()
    for _ in range(n_steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    seconds = time.perf_counter() - start
    env.close()
    return n_steps / seconds


def vector_env_steps_per_s(n_envs: int, n_steps: int, seed: int = 0, **env_kwargs) -> float:
    """Steps/s summed over n_envs copies of a vector_env (n_steps steps of every copy)."""
    venv = vector_env(n_envs, **env_kwargs)
    try:
        venv.action_space.seed(seed)
        venv.reset(seed=seed)
        for _ in range(5):  # warm-up
            venv.step(venv.action_space.sample())
        start = time.perf_counter()
        for _ in range(n_steps):
            venv.step(venv.action_space.sample())  # finished copies reset themselves
        seconds = time.perf_counter() - start
    finally:
        venv.close()
    return n_envs * n_steps / seconds


def bench_vector(n_envs: int = 2, n_steps: int = 300, echo=print, **env_kwargs) -> dict:
    """Single env vs vector_env(n_envs) steps/s on the paper scenario (or env_kwargs).

    Returns:
        {"single_steps_per_s", "vector_steps_per_s", "n_envs", "speedup"}.
    """
    env_kwargs.setdefault("scenario", "occluded_crosswalk")
    single = single_env_steps_per_s(n_steps, **env_kwargs)
    vector = vector_env_steps_per_s(n_envs, n_steps, **env_kwargs)
    row = {"configuration": f"vector_env({n_envs}) {env_kwargs['scenario']}",
           "n_envs": n_envs, "single_steps_per_s": single, "vector_steps_per_s": vector,
           "speedup": vector / single}
    echo(f"autopilot env ({env_kwargs['scenario']}, robot random, others on their planners): "
         f"1 env {single:.1f} steps/s; vector_env({n_envs}) {vector:.1f} steps/s = "
         f"{vector / single:.2f}x ({np.round(vector / single / n_envs, 2)} per process)")
    return row

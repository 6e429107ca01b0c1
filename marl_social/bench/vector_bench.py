"""Benchmark (never a timed unit test): vector_env throughput vs one autopilot env.

The single-agent autopilot env (`AutopilotGymEnv`: the robot is the user's, every other agent
runs its built-in planner) is stepped with seeded random robot actions, first alone in this
process, then as n copies of a vector_env on 2 processes (this one and a child,
marl_social/envs/batched.py): 2 copies (one per process) and 16 copies (blocks of 8 per process).
Every rate counts env steps (one copy advancing one step = one step) per wall-clock second,
resets included.
"""

from __future__ import annotations

import time

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


def vector_env_steps_per_s(n_envs: int, n_steps: int, seed: int = 0, workers: int | None = None,
                           **env_kwargs) -> float:
    """Steps/s summed over n_envs copies of a vector_env on `workers` processes.

    Every copy makes n_steps steps; workers None: vector_env's default.
    """
    venv = vector_env(n_envs, workers=workers, **env_kwargs)
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


def bench_vector(n_envs: int = 16, workers: int = 2, n_steps: int = 300, echo=print,
                 **env_kwargs) -> dict:
    """Single env vs vector_env steps/s on the paper scenario (or env_kwargs).

    vector_env(workers) (a copy per process) and vector_env(n_envs, workers=workers) (blocks
    of copies per process), both on `workers` processes.

    Returns:
        {"single_steps_per_s", "vector_steps_per_s", "n_envs", "workers", "speedup",
        "one_per_process_steps_per_s", "one_per_process_speedup"}.
    """
    env_kwargs.setdefault("scenario", "occluded_crosswalk")
    single = single_env_steps_per_s(n_steps, **env_kwargs)
    per_process = vector_env_steps_per_s(workers, n_steps, workers=workers, **env_kwargs)
    vector = vector_env_steps_per_s(n_envs, max(30, n_steps * workers // n_envs),
                                    workers=workers, **env_kwargs)
    row = {"configuration": f"vector_env({n_envs}, workers={workers}) {env_kwargs['scenario']}",
           "n_envs": n_envs, "workers": workers, "single_steps_per_s": single,
           "vector_steps_per_s": vector, "speedup": vector / single,
           "one_per_process_steps_per_s": per_process,
           "one_per_process_speedup": per_process / single}
    echo(f"autopilot env ({env_kwargs['scenario']}, robot random, others on their planners): "
         f"1 env {single:.1f} steps/s; on {workers} processes: vector_env({workers}) "
         f"{per_process:.1f} steps/s = {per_process / single:.2f}x, vector_env({n_envs}) "
         f"{vector:.1f} steps/s = {vector / single:.2f}x")
    return row

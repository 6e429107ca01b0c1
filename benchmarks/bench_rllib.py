"""Sampling throughput of RLlib's env runners against one runner and the project's vector_env.

    python benchmarks/bench_rllib.py [--steps N] [--reps R] [--envs E]

The same scene for all three: the occluded crosswalk, the robot acting (RLlib: its policy's
module, sampled; vector_env: a constant action), every other agent on its built-in planner,
200-step episodes. Each measurement samples N env steps per process, in alternation (A/B/C,
R rounds: the machine is shared, so its load drifts):

* rllib-1: one env runner stepping E env copies (`EnvRunner.sample(num_timesteps=N)`, in its
  own process; its module acts for the E copies in one forward pass);
* rllib-2: two env runners at once (N steps each);
* vector-2: `marl_social.vector_env(2 E, workers=2)` (2 E copies in two processes: this one and
  a child), 2 N steps in all.

Prints per setup the env steps per wall second and per CPU second of the sampling processes
(RLlib: the runners' own process time; vector_env: this process and its child), and the ratios
rllib-2 / rllib-1 and rllib-2 / vector-2, in wall time (what a user sees on this machine now)
and in CPU time (the ceiling when each process has a core to itself).
"""

from __future__ import annotations

import argparse
import os
import resource
import time

import numpy as np


def _runner_sample(runner, n_steps: int) -> tuple[float, int]:
    """(CPU seconds, env steps) of one runner's sample of n_steps (runs on the runner)."""
    start = time.process_time()
    episodes = runner.sample(num_timesteps=n_steps, random_actions=False)
    return time.process_time() - start, sum(len(e) for e in episodes)


def rllib_algo(env_runners: int, envs_per_runner: int):
    """A PPO algorithm of the robot on the crosswalk with `env_runners` runners of E envs."""
    from marl_social.training import PPOSettings, SceneSettings, TrainSettings
    from marl_social.training.trainer import build_config

    settings = TrainSettings(scene=SceneSettings(), ppo=PPOSettings(hidden=(64, 64)),
                             env_runners=env_runners, envs_per_runner=envs_per_runner,
                             seed=0, progress=False)
    return build_config(settings).build_algo()


def rllib_sample(algo, n_steps: int) -> dict:
    """Wall and runner CPU time of every runner sampling n_steps at once."""
    start = time.perf_counter()
    out = algo.env_runner_group.foreach_env_runner(
        lambda runner: _runner_sample(runner, n_steps), local_env_runner=False)
    wall = time.perf_counter() - start
    return {"steps": sum(s for _, s in out), "wall_s": wall, "cpu_s": sum(c for c, _ in out)}


def _cpu_now() -> float:
    me, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def _children_cpu_s(pid: int) -> float:
    """CPU seconds of the live child processes of `pid` (from /proc)."""
    total = 0.0
    tick = os.sysconf("SC_CLK_TCK")
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:  # ppid
            total += (int(fields[11]) + int(fields[12])) / tick
    return total


def vector_sample(venv, n_steps: int) -> dict:
    """Wall and CPU time (this process and its children) of n_steps of a vector env."""
    actions = np.tile(np.float32([0.5, 0.0]), (venv.num_envs, 1))
    cpu0, kids0 = _cpu_now(), _children_cpu_s(os.getpid())
    start = time.perf_counter()
    for _ in range(n_steps // venv.num_envs):
        venv.step(actions)
    wall = time.perf_counter() - start
    cpu = _cpu_now() - cpu0 + _children_cpu_s(os.getpid()) - kids0
    return {"steps": n_steps // venv.num_envs * venv.num_envs, "wall_s": wall, "cpu_s": cpu}


def main() -> None:
    """Measure and print the table (see the module docstring)."""
    import ray

    import marl_social

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=2000, help="env steps per process")
    parser.add_argument("--reps", type=int, default=3, help="A/B/C rounds")
    parser.add_argument("--envs", type=int, default=1, help="env copies per process")
    args = parser.parse_args()
    ray.init(address="local", num_cpus=3, include_dashboard=False, logging_level="ERROR")
    algos = {"rllib-1": rllib_algo(1, args.envs), "rllib-2": rllib_algo(2, args.envs)}
    venv = marl_social.vector_env(2 * args.envs, workers=2, scenario="occluded_crosswalk",
                                  max_cycles=200)
    venv.reset(seed=0)
    for name, algo in algos.items():  # warm up: first episodes, first forward passes
        rllib_sample(algo, 200)
    vector_sample(venv, 200)
    runs: dict[str, list[dict]] = {name: [] for name in ("rllib-1", "rllib-2", "vector-2")}
    for _ in range(args.reps):
        for name, algo in algos.items():
            runs[name].append(rllib_sample(algo, args.steps))
        runs["vector-2"].append(vector_sample(venv, 2 * args.steps))
    venv.close()
    for algo in algos.values():
        algo.stop()
    ray.shutdown()
    rates = {}
    print(f"{'setup':<10} {'steps/s wall':>13} {'steps/CPU-s':>12}   (median of {args.reps}, "
          f"{args.envs} env copies per process)")
    for name, measured in runs.items():
        wall = float(np.median([m["steps"] / m["wall_s"] for m in measured]))
        cpu = float(np.median([m["steps"] / m["cpu_s"] for m in measured]))
        rates[name] = (wall, cpu)
        print(f"{name:<10} {wall:>13.0f} {cpu:>12.0f}")
    w1, c1 = rates["rllib-1"]
    w2, c2 = rates["rllib-2"]
    wv, cv = rates["vector-2"]
    print(f"rllib-2 / rllib-1: {w2 / w1:.2f}x wall; CPU-bound ceiling {2 * c2 / c1:.2f}x "
          "(two runners, each on a core of its own)")
    print(f"rllib-2 / vector-2: {w2 / wv:.2f}x wall; {c2 / cv:.2f}x per CPU second")


if __name__ == "__main__":
    main()

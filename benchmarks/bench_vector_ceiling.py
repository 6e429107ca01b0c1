"""The speed-up a vector env of fixed blocks of copies can reach at best, from the step times.

    python benchmarks/bench_vector_ceiling.py [--steps N] [--scenario NAME]

A vector step ends when the slower process has stepped its block of copies, so two processes
gain at most 2 x mean / E[max(block A, block B)], not 2x, however little the hand-over costs.
This steps one autopilot env (`marl_social.envs.vector.AutopilotGymEnv`: robot_0 random, every
other agent on its built-in planner) N times in this process, timing each step and reset in
thread CPU, and resamples the measured step times (the first step, with its first-use costs,
left out) into blocks of 1 and 8 copies per process. Prints the step-time distribution, the
share of time in resets and the two ceilings (docs/benchmarks.md).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from marl_social.envs.vector import AutopilotGymEnv


def step_times(scenario: str, n_steps: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(n_steps,) thread-CPU times of the env's steps and (E,) of its resets [ms]."""
    env = AutopilotGymEnv(["robot_0"], scenario=scenario)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    steps, resets, episode = np.empty(n_steps), [], seed
    for k in range(n_steps):
        t0 = time.thread_time_ns()
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        steps[k] = (time.thread_time_ns() - t0) / 1e6
        if terminated or truncated:
            episode += 1
            t0 = time.thread_time_ns()
            env.reset(seed=episode)
            resets.append((time.thread_time_ns() - t0) / 1e6)
    env.close()
    return steps, np.array(resets)


def block_ceiling(steps_ms: np.ndarray, copies_per_block: int, samples: int = 200_000,
                  seed: int = 1) -> float:
    """The best speed-up of two processes stepping blocks of `copies_per_block` copies each.

    2 x mean / E[max of the two blocks' times], the step times drawn from `steps_ms` (N,) [ms].
    """
    rng = np.random.default_rng(seed)
    a = rng.choice(steps_ms, (samples, copies_per_block)).sum(axis=1)
    b = rng.choice(steps_ms, (samples, copies_per_block)).sum(axis=1)
    return float(2.0 * a.mean() / np.maximum(a, b).mean())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000, help="env steps to time")
    parser.add_argument("--scenario", default="occluded_crosswalk")
    args = parser.parse_args()
    if args.steps < 2:
        parser.error("--steps must be at least 2")
    steps, resets = step_times(args.scenario, args.steps)
    print(f"steps {len(steps)} median {np.median(steps):.3f} mean {steps.mean():.3f} "
          f"p90 {np.percentile(steps, 90):.3f} p99 {np.percentile(steps, 99):.3f} "
          f"max {steps.max():.2f} ms (thread CPU)")
    total = resets.sum() + steps.sum()
    print(f"resets {len(resets)} median {np.median(resets) if len(resets) else float('nan'):.2f}"
          f" ms; {100 * resets.sum() / total:.1f} % of the time")
    for copies in (1, 8):
        print(f"{copies} copies per process: at best {block_ceiling(steps[1:], copies):.3f}x "
              "on two processes (2 x mean / E[max of the two blocks])")


if __name__ == "__main__":
    main()

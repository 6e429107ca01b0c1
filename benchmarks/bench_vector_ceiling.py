"""The speed-up a vector env of fixed blocks of copies can reach at best, from the step times.

    python benchmarks/bench_vector_ceiling.py [--steps N] [--scenario NAME] [--copies C]

A vector step ends when the slower process has stepped its block of copies, so two processes
gain at most 2 x mean / E[max(block A, block B)], not 2x, however little the hand-over costs.
This steps one autopilot env (`marl_social.envs.vector.AutopilotGymEnv`: robot_0 random, every
other agent on its built-in planner) N times in this process, timing each step and reset in
thread CPU, and resamples the measured step times (the first step, with its first-use costs,
left out) into blocks of 1 and 8 copies per process. Prints the step-time distribution, the
share of time in resets and the two ceilings (docs/benchmarks.md).

With --copies C it also steps C copies in turn, as one process of a vector env would, for
--steps // C steps each, and replays their costs in time order as two blocks of C / 2: the
share of time the two processes would be busy with the blocks fixed, re-split every step by
each copy's cost in the step before (as if copies moved between processes for free) and split
perfectly evenly, each with the parent's own 0.23 ms per step; and how a copy's cost, and the
difference between the two blocks, correlate with the step before.
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


def copy_step_times(scenario: str, n_copies: int, n_steps: int, seed: int = 0) -> np.ndarray:
    """(n_steps, n_copies) thread-CPU times [ms] of n_copies envs stepped in turn.

    Copy i is seeded with seed + i; a finished copy resets on its next step, as in a vector env.
    """
    envs = [AutopilotGymEnv(["robot_0"], scenario=scenario) for _ in range(n_copies)]
    for i, env in enumerate(envs):
        env.action_space.seed(seed + i)
        env.reset(seed=seed + i)
    costs, done = np.empty((n_steps, n_copies)), np.zeros(n_copies, dtype=bool)
    for k in range(n_steps):
        for i, env in enumerate(envs):
            t0 = time.thread_time_ns()
            if done[i]:
                env.reset()
                done[i] = False
            else:
                _, _, terminated, truncated, _ = env.step(env.action_space.sample())
                done[i] = terminated or truncated
            costs[k, i] = (time.thread_time_ns() - t0) / 1e6
    for env in envs:
        env.close()
    return costs


def busy_shares(costs_ms: np.ndarray, serial_ms: float = 0.23) -> dict[str, float]:
    """Share of the time two processes are busy stepping the copies of `costs_ms` (T, C).

    Each step lasts as long as the slower of the two blocks plus `serial_ms`, the parent's
    own part of a step; "fixed": the first C / 2 copies and the rest; "re-split": each step
    the copies are dealt, costliest first, to the block with less of the step before's cost;
    "even": the step's cost split exactly in two.
    """
    n_steps, n_copies = costs_ms.shape
    total = costs_ms.sum(axis=1)  # (T,)
    half = n_copies // 2
    fixed = np.maximum(costs_ms[:, :half].sum(axis=1), costs_ms[:, half:].sum(axis=1))
    resplit = np.empty(n_steps - 1)
    for k in range(1, n_steps):  # a greedy deal, copy by copy (each to the lighter block)
        loads, blocks = [0.0, 0.0], [[], []]
        for i in np.argsort(-costs_ms[k - 1]):
            side = int(loads[1] < loads[0])
            loads[side] += costs_ms[k - 1, i]
            blocks[side].append(i)
        resplit[k - 1] = max(costs_ms[k, blocks[0]].sum(), costs_ms[k, blocks[1]].sum())
    return {"fixed": float(total.sum() / (2 * (fixed + serial_ms).sum())),
            "re-split": float(total[1:].sum() / (2 * (resplit + serial_ms).sum())),
            "even": float(total.sum() / (2 * (total / 2 + serial_ms).sum()))}


def _lag_correlation(x: np.ndarray, lag: int) -> float:
    """Correlation of x (T, ...) with itself `lag` steps before."""
    return float(np.corrcoef(x[lag:].ravel(), x[:-lag].ravel())[0, 1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=3000, help="env steps to time")
    parser.add_argument("--scenario", default="occluded_crosswalk")
    parser.add_argument("--copies", type=int, default=0,
                        help="also replay C copies stepped in turn as two blocks (even C >= 2)")
    args = parser.parse_args()
    if args.steps < 2:
        parser.error("--steps must be at least 2")
    if args.copies and (args.copies < 2 or args.copies % 2 or args.steps // args.copies < 12):
        parser.error("--copies must be even, at least 2, and at most --steps / 12")
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
    if args.copies:
        costs = copy_step_times(args.scenario, args.copies, args.steps // args.copies)[2:]
        half = args.copies // 2
        difference = costs[:, :half].sum(axis=1) - costs[:, half:].sum(axis=1)
        print(f"{args.copies} copies stepped in turn, {len(costs)} steps each: a copy's cost "
              f"correlates {_lag_correlation(costs, 1):.2f} with its step before; the two "
              f"blocks' difference (mean |d| {np.abs(difference).mean():.2f} ms, block "
              f"{costs[:, :half].sum(axis=1).mean():.2f} ms) {_lag_correlation(difference, 1):.2f} "
              f"(lag 1), {_lag_correlation(difference, 5):.2f} (lag 5)")
        shares = busy_shares(costs)
        print("busy share of two processes, blocks " + ", ".join(
            f"{name} {share:.3f}" for name, share in shares.items()))


if __name__ == "__main__":
    main()

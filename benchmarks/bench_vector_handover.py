"""The vector env's own cost per step, without the step-cost noise of the real env.

    python benchmarks/bench_vector_handover.py [--step-ms MS] [--copies C] [--steps N]

Each copy of a stand-in env burns exactly --step-ms of thread CPU per step and returns a small
observation and info. C copies step N times one after the other in this process, then as the
`vector_env`'s `BatchedVectorEnv` on 2 processes (blocks of C / 2). With equal blocks nothing
waits for a slower one, so what separates the speed-up from 2x is the hand-over: the actions
sent to the child, its wake-up, the answers read back and merged. Prints the speed-up and the
share of the wall time both processes were busy, per round (docs/benchmarks.md). Since the
stand-in burns thread CPU, not a fixed amount of work, a machine that slows a busy vCPU does
not show here.
"""

from __future__ import annotations

import argparse
import functools
import time

import gymnasium
import numpy as np
from gymnasium import spaces

from marl_social.bench.vector_bench import processes_cpu_s
from marl_social.envs.batched import BatchedVectorEnv


class BurnEnv(gymnasium.Env):
    """A stand-in env whose step burns `step_s` of thread CPU (40 floats observed, 2 actions)."""

    observation_space = spaces.Box(-1.0, 1.0, (40,), np.float32)
    action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)

    def __init__(self, step_s: float):
        self.step_s = step_s

    def reset(self, *, seed=None, options=None):
        """A zero observation and a one-entry info."""
        super().reset(seed=seed)
        return np.zeros(40, np.float32), {"collision": False}

    def step(self, action):
        """Burn step_s of this thread's CPU; never ends."""
        start = time.thread_time()
        while time.thread_time() - start < self.step_s:
            pass
        return np.zeros(40, np.float32), 0.0, False, False, {"collision": False}


def one_process_steps_per_s(step_s: float, n_copies: int, n_steps: int) -> float:
    """Env steps per second of n_copies stepped one after the other in this process."""
    env = BurnEnv(step_s)
    env.reset(seed=0)
    action = np.zeros(2, np.float32)
    start = time.perf_counter()
    for _ in range(n_steps * n_copies):
        env.step(action)
    return n_copies * n_steps / (time.perf_counter() - start)


def vector_steps_per_s(step_s: float, n_copies: int, n_steps: int) -> tuple[float, float]:
    """(env steps per second, busy share of the 2 processes) of BatchedVectorEnv(n_copies, 2)."""
    venv = BatchedVectorEnv(n_copies, 2, functools.partial(BurnEnv, step_s))
    try:
        venv.reset(seed=0)
        actions = np.zeros((n_copies, 2), np.float32)
        for _ in range(10):
            venv.step(actions)
        start, start_cpu = time.perf_counter(), processes_cpu_s(venv.worker_pids)
        for _ in range(n_steps):
            venv.step(actions)
        wall, cpu = time.perf_counter() - start, processes_cpu_s(venv.worker_pids) - start_cpu
    finally:
        venv.close()
    return n_copies * n_steps / wall, cpu / (2 * wall)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--step-ms", type=float, default=1.0, help="CPU per copy step [ms]")
    parser.add_argument("--copies", type=int, default=16, help="copies (even)")
    parser.add_argument("--steps", type=int, default=300, help="vector steps per round")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    if args.step_ms <= 0 or args.copies < 2 or args.copies % 2 or args.steps < 1:
        parser.error("--step-ms must be > 0, --copies even and >= 2, --steps >= 1")
    step_s = args.step_ms / 1e3
    for _ in range(args.rounds):
        one = one_process_steps_per_s(step_s, args.copies, args.steps)
        vector, busy = vector_steps_per_s(step_s, args.copies, args.steps)
        print(f"{args.copies} copies x {args.step_ms:.2f} ms (blocks of "
              f"{args.copies // 2 * args.step_ms:.1f} ms): one process {one:.0f} steps/s, "
              f"vector env {vector:.0f} steps/s = {vector / one:.3f}x, busy {busy:.3f}")


if __name__ == "__main__":
    main()

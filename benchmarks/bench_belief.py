"""The robot's belief updates in thread CPU time, in the episodes `marl-social bench planners` runs.

    python benchmarks/bench_belief.py [n_episodes]        # default 3 per scenario

For each scenario of `PLANNER_BENCH_SITUATIONS` (the situation its claims are about), the
median and p99 of the social robot's `HiddenAgentBelief.update` and, on the signalized
intersection, `SignalPhaseBelief.update`, in thread CPU time (`time.thread_time`: waiting to
be scheduled on a shared machine does not count). `bench planners` prints the belief's
wall-clock time only, and not the phase belief's.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from marl_social import parallel_env
from marl_social.bench.env_bench import PLANNER_BENCH_SITUATIONS, timed
from marl_social.envs.policies import policies


def belief_times(scenario: str, n_episodes: int) -> tuple[np.ndarray, np.ndarray]:
    """(update times (N,) [ms], phase update times (N,) [ms], empty without signals)."""
    hidden, phase = [], []
    for ep in range(n_episodes):  # the seeds and resets of bench_planners
        env = parallel_env(scenario=scenario, robot_planner="social",
                           **PLANNER_BENCH_SITUATIONS[scenario])
        pols = policies(env)
        for i, p in enumerate(pols.values()):
            p.reset(ep * 10 + i)
        robot = pols["robot_0"]
        robot.belief.update = timed(robot.belief.update, hidden, time.thread_time)
        if getattr(robot, "phase_belief", None) is not None:
            robot.phase_belief.update = timed(robot.phase_belief.update, phase, time.thread_time)
        obs, _ = env.reset(seed=ep)
        while env.agents:
            obs, *_ = env.step({a: pols[a](obs[a]) for a in env.agents})
    return 1e3 * np.array(hidden), 1e3 * np.array(phase)


if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 3
    for name in PLANNER_BENCH_SITUATIONS:
        hidden, phase = belief_times(name, n)
        line = (f"{name:24s} belief update  median {np.median(hidden):.3f} ms  "
                f"p99 {np.percentile(hidden, 99):.3f} ms  ({len(hidden)} calls)")
        if len(phase):
            line += (f" | phase belief  median {np.median(phase):.3f} ms  "
                     f"p99 {np.percentile(phase, 99):.3f} ms")
        print(line, flush=True)

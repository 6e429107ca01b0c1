"""Digests of seeded episodes with every agent on its built-in planner: a speed-up changes none.

Each episode (`marl_social.evaluation.run.run_episode`) is hashed over every agent's
observation and action at every step, the trace (states, activity, visibility, applied actions,
accelerations, rewards, collisions), its extras (the robot's beliefs), the metrics and, where
recorded, the human drivers' decisions. Run it before and after a change and compare:

    python benchmarks/episode_digests.py > before.txt   # then after the change:
    python benchmarks/episode_digests.py | diff before.txt -

(the CPU column differs; the digests must not). An argument keeps only the episodes whose label
contains it (e.g. ``t_int``).
"""

from __future__ import annotations

import hashlib
import sys
import time

import numpy as np

from marl_social.evaluation import run
from marl_social.evaluation.run import randomized_overrides, run_episode

_record_episode = run.record_episode


class _Hashing:
    """A policy wrapper feeding the observation and the action of every call into a hash."""

    def __init__(self, name: str, policy, digest):
        self.name, self.policy, self.digest = name, policy, digest

    def reset(self, seed=None):
        self.policy.reset(seed)

    def __call__(self, obs):
        self.digest.update(self.name.encode())
        self.digest.update(np.ascontiguousarray(obs).tobytes())
        action = self.policy(obs)
        self.digest.update(np.ascontiguousarray(action).tobytes())
        return action


def _update(digest, array) -> None:
    digest.update(np.ascontiguousarray(array).tobytes())


def episode_digest(scenario: str, seed: int, **kwargs) -> tuple[str, int]:
    """(sha256 hex digest, steps) of one run_episode(scenario, seed, **kwargs)."""
    digest = hashlib.sha256()
    run.record_episode = lambda env, pols, **kw: _record_episode(
        env, {a: _Hashing(a, p, digest) for a, p in pols.items()}, **kw)
    try:
        res = run_episode(scenario, seed=seed, **kwargs)
    finally:
        run.record_episode = _record_episode
    trace = res.trace
    for array in (trace.states, trace.active, trace.visible, trace.actions, trace.accel_mps2,
                  trace.rewards, trace.collided):
        _update(digest, array)
    for key in sorted(trace.extras):
        digest.update(key.encode())
        _update(digest, trace.extras[key])
    for key in sorted(res.metrics):
        digest.update(f"{key}={res.metrics[key]!r}".encode())
    for agent in sorted(res.decisions or {}):
        for features, allowed, chosen in res.decisions[agent]:
            _update(digest, features)
            _update(digest, allowed)
            digest.update(str(chosen).encode())
    return digest.hexdigest(), len(trace.times_s) - 1


def episodes() -> list[tuple[str, str, int, dict]]:
    """(label, scenario, seed, run_episode overrides) of every hashed episode."""
    jobs = []
    for planner in ("social", "aggressive", "conservative", "oracle"):
        for seed in (0, 1):
            jobs.append((f"occluded {planner} s{seed}", "occluded_crosswalk", seed,
                         dict(robot_planner=planner, **randomized_overrides(seed, "wide"))))
    for variant in ("near", "none"):
        for seed in (0, 1):
            jobs.append((f"t_int {variant} s{seed}", "t_intersection", seed,
                         dict(hidden_vehicle=variant, max_cycles=150,
                              **randomized_overrides(seed, "t_intersection"))))
    jobs.append(("t_int near s2 record_decisions", "t_intersection", 2,
                 dict(hidden_vehicle="near", max_cycles=150, record_human_decisions=True,
                      **randomized_overrides(2, "t_intersection"))))
    for variant in ("protected_left", "cross_green"):
        for seed in (0, 1):
            jobs.append((f"signal {variant} s{seed}", "signalized_intersection", seed,
                         dict(phase=variant, max_cycles=250,
                              **randomized_overrides(seed, "signalized_intersection"))))
    for seed in (0, 1):
        jobs.append((f"long_road n10 s{seed}", "long_road", seed, {"n_vehicles": 10}))
    jobs.append(("occluded social s3 record_decisions", "occluded_crosswalk", 3,
                 dict(robot_planner="social", record_human_decisions=True,
                      **randomized_overrides(3, "wide"))))
    return jobs


if __name__ == "__main__":
    only = sys.argv[1] if len(sys.argv) > 1 else ""
    for label, scenario, seed, overrides in episodes():
        if only in label:
            start = time.process_time()
            hexdigest, steps = episode_digest(scenario, seed, **overrides)
            print(f"{label:40s} {hexdigest[:16]}  steps={steps:4d}  "
                  f"cpu={time.process_time() - start:.1f}s", flush=True)

"""RSS growth over many env.reset() calls: native memory must stay flat.

    python benchmarks/bench_resets.py [--resets N] [--warmup W] [--scenario NAME]

Prints the resident set size after `warmup` resets and after `resets` more, the growth and the
growth per reset. RSS is read from /proc/self/statm (Linux).
"""

from __future__ import annotations

import argparse
import gc
import os
import time

import marl_social

PAGE_BYTES = os.sysconf("SC_PAGE_SIZE")


def rss_mb() -> float:
    """Resident set size of this process [MB] (Linux /proc/self/statm)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * PAGE_BYTES / 1e6


def measure(scenario: str, resets: int, warmup: int) -> dict:
    """RSS before and after `resets` seeded resets that follow `warmup` ones.

    Args:
        scenario: registered scenario name.
        resets: measured resets.
        warmup: resets before the first reading (allocator pools, caches).
    """
    env = marl_social.parallel_env(scenario)
    for seed in range(warmup):
        env.reset(seed=seed)
    gc.collect()
    before = rss_mb()
    start = time.perf_counter()
    for seed in range(resets):
        env.reset(seed=seed)
    elapsed = time.perf_counter() - start
    gc.collect()
    after = rss_mb()
    env.close()
    return {"scenario": scenario, "warmup": warmup, "resets": resets,
            "rss_before_mb": round(before, 2), "rss_after_mb": round(after, 2),
            "growth_mb": round(after - before, 3),
            "growth_per_reset_kb": round((after - before) * 1e3 / max(resets, 1), 4),
            "reset_ms": round(elapsed * 1e3 / max(resets, 1), 3)}


def main() -> None:
    """Command line: print one line of key=value."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--resets", type=int, default=10_000)
    parser.add_argument("--warmup", type=int, default=1_000)
    parser.add_argument("--scenario", default="occluded_crosswalk")
    args = parser.parse_args()
    print(" ".join(f"{k}={v}" for k, v in measure(args.scenario, args.resets,
                                                  args.warmup).items()))


if __name__ == "__main__":
    main()

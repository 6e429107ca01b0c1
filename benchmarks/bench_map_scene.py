"""A karlsruhe map scene with 10 agents vs highway-env at 10 agents, in CPU time (same run).

Env steps per CPU second (time.process_time, resets included) of random-action rollouts
(marl_social/bench/env_bench.bench_env: every agent's field of view every step) of
map_scene on karlsruhe with the situation's agents plus `n_traffic` traffic cars (10 agents
in all), and of highway-env's intersection-multi-agent-v2 with 10 controlled vehicles
(marl_social/bench/highway.py), alternated ROUNDS times (the machine may be shared: CPU time,
A/B alternation, the median ratio). Also the CPU time to build each scene (MapScene and its
first layout; the map loaded and the kernels compiled beforehand).

    python benchmarks/bench_map_scene.py [--steps 300] [--rounds 3]
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings

from marl_social.bench.env_bench import bench_env

AGENTS = 10
SCENES = {  # label: map_scene overrides giving AGENTS agents
    "crosswalk 44986 + 7 traffic": {"element": 44986, "n_traffic": 7},
    "signal 45218 + 5 traffic": {"situation": "signal", "element": 45218, "n_traffic": 5},
}
ROUNDS = 3


def build_cpu_s(overrides: dict, repeats: int = 3) -> float:
    """The fastest of `repeats` CPU times to build the scene and its layout [s]."""
    from marl_social.scenarios.map_scene import MapScene

    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        MapScene(map="karlsruhe", **overrides).build(None)
        best = min(best, time.process_time() - start)
    return best


def main() -> None:
    warnings.simplefilter("ignore")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--rounds", type=int, default=ROUNDS)
    args = parser.parse_args()
    from marl_social.bench.highway import highway_env_available, highway_env_steps_per_second
    from marl_social.maps import load_map

    start = time.process_time()
    load_map("karlsruhe")
    print(f"load karlsruhe: {time.process_time() - start:.2f} CPU-s")
    for label, overrides in SCENES.items():
        bench_env("map_scene", 20, map="karlsruhe", **overrides)  # kernels compiled
        print(f"build {label}: {build_cpu_s(overrides):.3f} CPU-s (fastest of 3)")
    if not highway_env_available():
        raise SystemExit("highway-env is not installed (pip install 'marl-social[bench]')")
    ratios = {label: [] for label in SCENES}
    for k in range(args.rounds):
        peer = highway_env_steps_per_second(AGENTS, n_steps=max(30, args.steps // 4),
                                            clock=time.process_time)["steps_per_s"]
        for label, overrides in SCENES.items():
            res = bench_env("map_scene", args.steps, seed=k, label=label,
                            clock=time.process_time, map="karlsruhe", **overrides)
            assert res.n_agents == AGENTS, res.n_agents
            ratios[label].append(res.steps_per_s / peer)
            print(f"round {k}: {label}: {res.steps_per_s:.0f} steps/CPU-s "
                  f"(live {res.mean_live_agents:.1f}); highway-env {AGENTS} agents "
                  f"{peer:.1f} steps/CPU-s; ratio {res.steps_per_s / peer:.1f}x")
    for label, values in ratios.items():
        print(f"{label}: median ratio {statistics.median(values):.1f}x highway-env "
              f"at {AGENTS} agents (rounds: {', '.join(f'{v:.1f}' for v in values)})")


if __name__ == "__main__":
    main()

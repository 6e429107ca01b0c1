"""Planner decision times and all-planner env speed: see benchmarks/README.md."""

from marl_social.bench.env_bench import bench_planners

if __name__ == "__main__":
    bench_planners()

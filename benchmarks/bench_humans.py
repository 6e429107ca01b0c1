"""Human planner decision times and all-planner env speed: see benchmarks/README.md."""

from marl_social.bench import bench_humans

if __name__ == "__main__":
    bench_humans()

"""Env steps/s vs number of agents, with highway-env side by side: see benchmarks/README.md."""

from marl_social.bench.env_bench import run_env_benchmark

if __name__ == "__main__":
    run_env_benchmark(profile=True)

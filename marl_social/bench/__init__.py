"""Benchmarks: env and planner throughput, side by side with highway-env measured in the same
run.
"""

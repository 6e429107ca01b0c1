"""Benchmarks: env and planner throughput.

Side by side with highway-env measured in the same run.
"""

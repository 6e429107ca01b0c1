"""Evaluation: episodes with every agent on its built-in planner.

Seeded episodes with their metrics and traces (run, rollout), the paper's figures and table
(reproduce), and demonstrations and decisions recorded from simulated episodes (record).
"""

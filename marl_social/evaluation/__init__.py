"""Evaluation: roll out episodes with every agent on its built-in planner, their metrics and
traces, and the paper's figures and table (reproduce); recording demonstrations from episodes.
"""

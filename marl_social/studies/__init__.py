"""Sensitivity studies: specs, execution, results and their analysis.

TOML specs (spec), execution on a process pool or Ray (runner), the results folder (results) and
its analysis (analysis).
"""

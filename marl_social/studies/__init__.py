"""Sensitivity studies: specs, execution, results and their analysis.

TOML specs (spec), execution on a process pool or Ray (runner), the results folder (results),
its typed table (table: results.parquet; `load(folder)` gives a pandas DataFrame) and its
analysis (analysis).
"""

from marl_social.studies.table import load

__all__ = ["load"]

"""Analysis of a study: summary tables with 95 % confidence intervals and plots.

They are written next to the study's results.csv (`marl_social/studies/results.py`); the
statistics are in `marl_social/studies/stats.py`, the figures in `marl_social/studies/plots.py`.

* Rates (true/false metrics, e.g. robot_collision): the share of the finished runs with its
  Wilson interval.
* Other metrics (e.g. time_to_pass_s [s]): the mean over the runs with a finite value, with its
  Student-t interval, and how many runs that is of the runs that finished: "passed k/n" for
  time_to_pass_s (NaN: the robot did not pass), "k/n with a value" for the others. A mean over
  1 of 5 runs is never shown as if it were over 5.
* Failed runs (error column set) count in n_errors and in no metric; every cell says how many.

Outputs:
    summary.csv: one row per (planner, pedestrian, point of the swept parameters): n_runs,
        n_errors and per metric <m>_n (runs with a value), <m>_n_nan (finished runs without
        one, e.g. did not pass), <m>_mean, <m>_ci_low, <m>_ci_high.
    summary.md: the same as one table per metric (planners as columns), the parameters held
        fixed, and the errors with their counts.
    plots/<metric>_vs_<param>.png: the metric against each swept parameter with its 95 %
        interval, one line per planner and one panel per pedestrian variant (pooled over the
        other swept parameters), with the runs behind each point.
    plots/heatmap_<metric>_<a>_x_<b>[_<pedestrian>].png: for each pair of swept parameters,
        one panel per planner, for the collision rate and the time to pass.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from marl_social.studies.plots import plot_1d, plot_heatmaps
from marl_social.studies.results import (
    META_FILE,
    PLOTS_DIR,
    RESULTS_FILE,
    SUMMARY_CSV,
    SUMMARY_MD,
    read_meta,
    read_results,
)
from marl_social.studies.runs import format_value
from marl_social.studies.spec import SPEC_PACKAGE_DIR
from marl_social.studies.stats import (
    CONFIDENCE,
    GroupStats,
    StudyTable,
    count_text,
    display,
    fmt,
    group_stats,
    t_interval,
    wilson_interval,
)

__all__ = ["AnalysisOutputs", "GroupStats", "StudyTable", "analyze", "group_stats",
           "load_table", "t_interval", "wilson_interval", "write_summary_csv",
           "write_summary_md"]


# --------------------------------------------------------------------------------- summary


def write_summary_csv(gs: GroupStats, metrics: list[str], path: Path) -> Path:
    """summary.csv: one row per group; floats in repr precision."""
    import csv

    columns = [*gs.by, "n_runs", "n_errors",
               *(f"{m}_{s}" for m in metrics
                 for s in ("n", "n_nan", "mean", "ci_low", "ci_high"))]
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(columns)
        for i, group in enumerate(gs.groups):
            cells = [*group, str(gs.n_runs[i]), str(gs.n_errors[i])]
            for m in metrics:
                st = gs.stats[m]
                cells += [str(st["n"][i]), str(st["n_nan"][i]), *(format_value(float(st[s][i]))
                                             for s in ("mean", "ci_low", "ci_high"))]
            writer.writerow(cells)
    return path


def _metric_table(table: StudyTable, gs: GroupStats, metric: str) -> list[str]:
    """Markdown table of one metric: rows (pedestrian, swept point), columns planners.

    The pedestrian column is left out for a scenario without pedestrian variants (every
    run's pedestrian is "").
    """
    planners = table.order("planner")
    rows = list(dict.fromkeys(g[1:] for g in gs.groups))
    with_pedestrian = any(row[0] != "" for row in rows)
    row_cols = ["pedestrian", *table.swept] if with_pedestrian else list(table.swept)
    index = gs.index()
    rate, st = table.is_rate[metric], gs.stats[metric]
    lines = ["| " + " | ".join([*row_cols, *planners]) + " |",
             "|" + "---|" * (len(row_cols) + len(planners))]
    for row in rows:
        cells = [display(c) for c in (row if with_pedestrian else row[1:])]
        for p in planners:
            i = index.get((p, *row))
            if i is None:
                cells.append("–")
                continue
            counts = count_text(metric, st["n"][i], gs.n_finished[i], gs.n_errors[i])
            if st["n"][i] == 0:
                cells.append(f"– {counts}")
                continue
            cells.append(f"{fmt(st['mean'][i], rate)} [{fmt(st['ci_low'][i], rate)}, "
                         f"{fmt(st['ci_high'][i], rate)}] {counts}")
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _error_lines(table: StudyTable) -> list[str]:
    failed = table.errors[table.errors != ""]
    if not len(failed):
        return ["No run failed."]
    messages, counts = np.unique(failed.astype(str), return_counts=True)
    lines = ["| runs | error |", "|---|---|"]
    for i in np.argsort(-counts, kind="stable"):
        lines.append(f"| {counts[i]} | {messages[i].replace('|', '/')} |")
    return lines


def _spec_label(source: str) -> str:
    """A built-in spec by its name (`marl-social study NAME`), not by this machine's path."""
    source_path = Path(source)
    if source_path.parent.name == SPEC_PACKAGE_DIR and source_path.parent.parent.name == "studies":
        return f"built-in `{source_path.stem}` (`marl-social study {source_path.stem}`)"
    return f"`{source}`"


def write_summary_md(table: StudyTable, gs: GroupStats, path: Path,
                     figures: list[Path]) -> Path:
    """summary.md: the study's settings, one table per metric, errors and plots."""
    meta = table.meta
    n_err = int((table.errors != "").sum())
    settings = (f"Scenario `{meta['scenario']}`, {len(table)} runs ({n_err} failed), "
                f"max_cycles {meta['max_cycles']}, randomize "
                f"{str(meta['randomize']).lower()}; spec: {_spec_label(meta['source'])}.")
    lines = [f"# Study `{meta['name']}`", ""]
    if meta.get("description"):
        lines += [meta["description"], ""]
    lines += [settings, ""]
    if table.fixed:
        held = ", ".join(f"{k} = {v}" for k, v in table.fixed.items())
        lines += [f"Held fixed: {held}", ""]
    if table.swept:
        lines += ["Swept: " + ", ".join(f"{p} ({len(table.order(p))} values)"
                                        for p in table.swept), ""]
    legend = (f"Rates (true/false metrics): share of the finished runs [{CONFIDENCE:.0%} "
              f"Wilson interval]. Other metrics: mean over the runs that have a value only "
              f"[{CONFIDENCE:.0%} Student-t interval]. In parentheses, the runs a value rests "
              "on: (5) = all 5 finished runs; (passed 1/5) = time_to_pass_s over the 1 of 5 "
              "finished runs in which the robot passed (the other 4 did not pass); (3/5 with a "
              "value) = the same for other metrics (nan: e.g. never saw a pedestrian); "
              "\"N failed\" = runs that raised an error and have no value.")
    lines += [legend, ""]
    for m in table.metrics:
        lines += [f"## {m}" + (" (rate)" if table.is_rate[m] else ""), "",
                  *_metric_table(table, gs, m), ""]
    lines += ["## Errors", "", *_error_lines(table), ""]
    if figures:
        lines += ["## Plots", "", *(f"- [{f.name}]({PLOTS_DIR}/{f.name})" for f in figures), ""]
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


# -------------------------------------------------------------------------------- analyze


@dataclass
class AnalysisOutputs:
    """Files written by `analyze`."""

    summary_md: Path
    summary_csv: Path
    figures: list[Path]


def load_table(out_dir: str | Path) -> StudyTable:
    """A study's results.csv (and study.json) as a StudyTable."""
    out_dir = Path(out_dir)
    meta = read_meta(out_dir / META_FILE)
    results = out_dir / RESULTS_FILE
    if not results.is_file():
        raise FileNotFoundError(f"{results} not found: the study has no results (run it first)")
    header, rows = read_results(results)
    missing = [c for c in ("planner", "pedestrian", "error", *meta["params"], *meta["metrics"])
               if c not in header]
    if missing:
        raise ValueError(f"{results}: missing column(s) {missing} named by {META_FILE}")
    try:
        return StudyTable.from_rows(rows, meta)
    except ValueError as err:  # a metric cell that is not a number
        raise ValueError(f"{results}: {err}") from None


def analyze(out_dir: str | Path, plots: bool = True) -> AnalysisOutputs:
    """Write summary.md, summary.csv and (if plots) the figures of the study in out_dir."""
    out_dir = Path(out_dir)
    table = load_table(out_dir)
    if len(table) == 0:
        raise ValueError(f"{out_dir / RESULTS_FILE}: no result rows (only a header): nothing "
                         "to analyze; run the study first")
    gs = group_stats(table, ["planner", "pedestrian", *table.swept])
    figures: list[Path] = []
    if plots and len(table):
        plot_dir = out_dir / PLOTS_DIR
        plot_dir.mkdir(exist_ok=True)
        for stale in plot_dir.glob("*.png"):  # figures of an earlier analysis
            stale.unlink()
        for param in table.swept:
            figures += plot_1d(table, param, plot_dir)
        for a, b in itertools.combinations(table.swept, 2):
            figures += plot_heatmaps(table, a, b, plot_dir)
    summary_csv = write_summary_csv(gs, table.metrics, out_dir / SUMMARY_CSV)
    summary_md = write_summary_md(table, gs, out_dir / SUMMARY_MD, figures)
    return AnalysisOutputs(summary_md, summary_csv, figures)

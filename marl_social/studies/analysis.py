"""Analysis of a study: summary tables with 95 % confidence intervals and plots.

They are written next to the study's results.csv (`marl_social/studies/results.py`).

* Rates (metrics that are true/false, e.g. robot_collision): the share of runs, with the Wilson
  score interval of the binomial proportion (no continuity correction, as
  `scipy.stats.binomtest(k, n).proportion_ci(method="wilson")`).
* Other metrics (e.g. time_to_pass_s [s]): the mean over the runs with a finite value (a run
  whose robot never passes has time_to_pass_s = nan) with the Student-t interval
  mean +- t(0.975, n-1) s / sqrt(n); no interval for n < 2.
* Failed runs (error column set) count in n_errors and in no metric.

Outputs:
    summary.csv: one row per (planner, pedestrian, point of the swept parameters): n_runs,
        n_errors and per metric <m>_n, <m>_mean, <m>_ci_low, <m>_ci_high.
    summary.md: the same as one table per metric (planners as columns), the parameters held
        fixed, and the errors with their counts.
    plots/<metric>_vs_<param>.png: the metric against each swept parameter with its 95 %
        interval, one line per planner and one panel per pedestrian variant (pooled over the
        other swept parameters).
    plots/heatmap_<metric>_<a>_x_<b>[_<pedestrian>].png: for each pair of swept parameters,
        one panel per planner, for the collision rate and the time to pass.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats

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

CONFIDENCE = 0.95
HEATMAP_METRICS = ("robot_collision", "time_to_pass_s")
_BOOL_TEXT = {"true": 1.0, "false": 0.0}


# ------------------------------------------------------------------------------- intervals


def wilson_interval(successes, trials, confidence: float = CONFIDENCE):
    """Wilson score interval of a binomial proportion, vectorized.

    Newcombe 1998, without continuity correction: arrays of successes k and trials n ->
    (low, high); nan where n = 0. Equal to
    scipy.stats.binomtest(k, n).proportion_ci(method="wilson").
    """
    k = np.asarray(successes, dtype=float)
    n = np.asarray(trials, dtype=float)
    z = stats.norm.ppf(0.5 + 0.5 * confidence)
    with np.errstate(invalid="ignore", divide="ignore"):
        p = k / n
        denom = 2.0 * (n + z**2)
        centre = (2.0 * n * p + z**2) / denom
        delta = z / denom * np.sqrt(4.0 * n * p * (1.0 - p) + z**2)
        low = np.where(k == 0, 0.0, centre - delta)
        high = np.where(k == n, 1.0, centre + delta)
    empty = n == 0
    return np.where(empty, np.nan, low), np.where(empty, np.nan, high)


def t_interval(mean, std, n, confidence: float = CONFIDENCE):
    """Student-t interval of a mean, vectorized.

    mean +- t(1/2 + c/2, n - 1) std / sqrt(n) with std the sample standard deviation (ddof 1);
    nan where n < 2.
    """
    mean, std = np.asarray(mean, dtype=float), np.asarray(std, dtype=float)
    n = np.asarray(n, dtype=float)
    ok = n >= 2
    dof = np.where(ok, n - 1.0, 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        half = stats.t.ppf(0.5 + 0.5 * confidence, dof) * std / np.sqrt(n)
    return np.where(ok, mean - half, np.nan), np.where(ok, mean + half, np.nan)


# ----------------------------------------------------------------------------------- table


def _value_order(label: str):
    """Sort key of a parameter's text value: bools, then numbers, then other text."""
    if label in _BOOL_TEXT:
        return (0, _BOOL_TEXT[label], "")
    try:
        return (1, float(label), "")
    except ValueError:
        return (2, 0.0, label)


@dataclass
class StudyTable:
    """results.csv as arrays.

    Attributes:
        meta: study.json.
        labels: column -> (N,) texts, for planner, pedestrian and every parameter.
        values: metric -> (N,) floats (true = 1, false = 0; nan = missing or failed run).
        is_rate: metric -> True if its values are true/false.
        errors: (N,) error texts ("" = success).
        swept: parameters with more than one value in the table; fixed: the others -> value.
    """

    meta: dict
    labels: dict[str, np.ndarray]
    values: dict[str, np.ndarray]
    is_rate: dict[str, bool]
    errors: np.ndarray
    swept: list[str] = field(default_factory=list)
    fixed: dict[str, str] = field(default_factory=dict)

    @property
    def metrics(self) -> list[str]:
        return list(self.meta["metrics"])

    def __len__(self) -> int:
        return len(self.errors)

    @classmethod
    def from_rows(cls, rows: list[dict], meta: dict) -> StudyTable:
        label_columns = ["planner", "pedestrian", *meta["params"]]
        labels = {c: np.array([r[c] for r in rows], dtype=object) for c in label_columns}
        values, is_rate = {}, {}
        for m in meta["metrics"]:
            texts = [r[m] for r in rows]
            present = [t for t in texts if t != ""]
            is_rate[m] = bool(present) and all(t in _BOOL_TEXT for t in present)
            values[m] = np.array([_BOOL_TEXT[t] if t in _BOOL_TEXT else float(t) if t else np.nan
                                  for t in texts], dtype=float)
        table = cls(meta, labels, values, is_rate,
                    np.array([r["error"] for r in rows], dtype=object))
        for p in meta["params"]:
            distinct = set(labels[p])
            if len(distinct) > 1:
                table.swept.append(p)
            elif distinct:
                table.fixed[p] = next(iter(distinct))
        return table

    def order(self, column: str) -> list[str]:
        """Distinct values of a column.

        Planners and pedestrians in table order, parameter values sorted (bools, numbers, text).
        """
        first = list(dict.fromkeys(self.labels[column]))
        if column in ("planner", "pedestrian"):
            return first
        return sorted(first, key=_value_order)


@dataclass
class GroupStats:
    """Per-group statistics of every metric.

    Attributes:
        by: the grouping columns; groups: one tuple of their values per group.
        n_runs, n_errors: (G,) counts.
        stats: metric -> {"n", "mean", "ci_low", "ci_high"} (G,) arrays.
    """

    by: list[str]
    groups: list[tuple[str, ...]]
    n_runs: np.ndarray
    n_errors: np.ndarray
    stats: dict[str, dict[str, np.ndarray]]

    def index(self) -> dict[tuple[str, ...], int]:
        return {g: i for i, g in enumerate(self.groups)}


def group_stats(table: StudyTable, by: list[str], confidence: float = CONFIDENCE) -> GroupStats:
    """Counts, means and confidence intervals of every metric per group of `by` columns.

    Vectorized with bincount; groups ordered as StudyTable.order.
    """
    orders = [table.order(c) for c in by]
    if len(table) == 0:
        return GroupStats(by, [], np.zeros(0, int), np.zeros(0, int), {})
    codes = np.array([[{v: i for i, v in enumerate(o)}[v] for v in table.labels[c]]
                      for c, o in zip(by, orders)]).T
    unique, inverse = np.unique(codes, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    n_groups = len(unique)
    groups = [tuple(orders[j][c] for j, c in enumerate(row)) for row in unique]
    failed = (table.errors != "").astype(float)
    out = {}
    for m in table.metrics:
        v = table.values[m]
        ok = np.isfinite(v)
        idx = inverse[ok]
        n = np.bincount(idx, minlength=n_groups).astype(float)
        total = np.bincount(idx, weights=v[ok], minlength=n_groups)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = total / n
            squares = np.bincount(idx, weights=(v[ok] - mean[idx]) ** 2, minlength=n_groups)
            std = np.sqrt(squares / (n - 1.0))
        if table.is_rate[m]:
            low, high = wilson_interval(total, n, confidence)
        else:
            low, high = t_interval(mean, std, n, confidence)
        out[m] = {"n": n.astype(int), "mean": mean, "ci_low": low, "ci_high": high}
    return GroupStats(by, groups, np.bincount(inverse, minlength=n_groups),
                      np.bincount(inverse, weights=failed, minlength=n_groups).astype(int), out)


# --------------------------------------------------------------------------------- summary


def display(label: str) -> str:
    """A parameter value for tables and axes: numbers with 4 significant digits."""
    kind, number, _ = _value_order(label)
    return f"{number:.4g}" if kind == 1 else label or "–"


def _fmt(x: float, rate: bool) -> str:
    if not np.isfinite(x):
        return "–"
    return f"{x:.2f}" if rate else f"{x:.3g}"


def write_summary_csv(gs: GroupStats, metrics: list[str], path: Path) -> Path:
    """summary.csv: one row per group; floats in repr precision."""
    import csv

    columns = [*gs.by, "n_runs", "n_errors",
               *(f"{m}_{s}" for m in metrics for s in ("n", "mean", "ci_low", "ci_high"))]
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f, lineterminator="\n")
        writer.writerow(columns)
        for i, group in enumerate(gs.groups):
            cells = [*group, str(gs.n_runs[i]), str(gs.n_errors[i])]
            for m in metrics:
                st = gs.stats[m]
                cells += [str(st["n"][i]), *(format_value(float(st[s][i]))
                                             for s in ("mean", "ci_low", "ci_high"))]
            writer.writerow(cells)
    return path


def _metric_table(table: StudyTable, gs: GroupStats, metric: str) -> list[str]:
    """Markdown table of one metric: rows (pedestrian, swept point), columns planners."""
    planners = table.order("planner")
    row_cols = ["pedestrian", *table.swept]
    index = gs.index()
    rows = list(dict.fromkeys(g[1:] for g in gs.groups))
    rate, st = table.is_rate[metric], gs.stats[metric]
    lines = ["| " + " | ".join([*row_cols, *planners]) + " |",
             "|" + "---|" * (len(row_cols) + len(planners))]
    for row in rows:
        cells = [display(c) for c in row]
        for p in planners:
            i = index.get((p, *row))
            if i is None or st["n"][i] == 0:
                cells.append("–")
                continue
            cells.append(f"{_fmt(st['mean'][i], rate)} [{_fmt(st['ci_low'][i], rate)}, "
                         f"{_fmt(st['ci_high'][i], rate)}] ({st['n'][i]})")
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
    legend = (f"Rates (true/false metrics): share of runs [{CONFIDENCE:.0%} Wilson interval]; "
              f"other metrics: mean over the runs with a finite value [{CONFIDENCE:.0%} "
              "Student-t interval]; (n) = runs counted.")
    lines += [legend, ""]
    for m in table.metrics:
        lines += [f"## {m}" + (" (rate)" if table.is_rate[m] else ""), "",
                  *_metric_table(table, gs, m), ""]
    lines += ["## Errors", "", *_error_lines(table), ""]
    if figures:
        lines += ["## Plots", "", *(f"- [{f.name}]({PLOTS_DIR}/{f.name})" for f in figures), ""]
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


# ----------------------------------------------------------------------------------- plots


def _ylabel(table: StudyTable, metric: str) -> str:
    return f"{metric} (rate)" if table.is_rate[metric] else metric


def _series(values: np.ndarray, ids: list[int | None]) -> np.ndarray:
    """values[ids] with nan where a group is missing (None)."""
    return np.array([values[i] if i is not None else np.nan for i in ids])


def plot_1d(table: StudyTable, param: str, out_dir: Path) -> list[Path]:
    """For every metric, a figure of it against `param` with its interval.

    One line per planner, one panel per pedestrian variant, pooled over the other swept
    parameters.
    """
    from matplotlib.figure import Figure

    gs = group_stats(table, ["planner", "pedestrian", param])
    index, planners = gs.index(), table.order("planner")
    pedestrians, xs = table.order("pedestrian"), table.order(param)
    pooled = [p for p in table.swept if p != param]
    offsets = (np.arange(len(planners)) - (len(planners) - 1) / 2) * 0.08
    paths = []
    for m in table.metrics:
        st = gs.stats[m]
        if not np.isfinite(st["mean"]).any():
            continue  # no run has a value (e.g. a belief metric of the oracle only)
        fig = Figure(figsize=(max(6.4, 1.0 + 4.2 * len(pedestrians)), 4.0),
                     layout="constrained")
        axs = fig.subplots(1, len(pedestrians), squeeze=False, sharey=True)[0]
        for ax, ped in zip(axs, pedestrians):
            for j, planner in enumerate(planners):
                ids = [index.get((planner, ped, x)) for x in xs]
                mean, low, high = (_series(st[s], ids) for s in ("mean", "ci_low", "ci_high"))
                if not np.isfinite(mean).any():
                    continue
                err = np.vstack([mean - low, high - mean])
                ax.errorbar(np.arange(len(xs)) + offsets[j], mean,
                            yerr=np.where(np.isfinite(err), err, 0.0), marker="o",
                            capsize=3, label=planner)
            ax.set_xticks(np.arange(len(xs)), [display(x) for x in xs],
                          rotation=30 if len(xs) > 6 else 0)
            ax.set_xlabel(param)
            ax.set_title(f"pedestrian: {ped}" if ped else "")
            ax.grid(alpha=0.3)
        axs[0].set_ylabel(_ylabel(table, m))
        if table.is_rate[m]:
            axs[0].set_ylim(-0.03, 1.03)
        axs[0].legend(fontsize="small")
        fig.suptitle(f"{m} vs {param}, mean and {CONFIDENCE:.0%} CI"
                     + (f"\n(pooled over {', '.join(pooled)})" if pooled else ""))
        path = out_dir / f"{m}_vs_{param}.png"
        fig.savefig(path, dpi=100)
        paths.append(path)
    return paths


def _color_range(values: np.ndarray, rate: bool) -> tuple[float, float]:
    """Colour scale of a heatmap: [0, 1] for rates, else the values' range.

    The range is widened if the values are all equal, so every panel maps a value to the same
    colour.
    """
    if rate:
        return 0.0, 1.0
    low, high = float(values.min()), float(values.max())
    if high - low <= 1e-12 * max(1.0, abs(high)):
        low, high = low - 0.5, high + 0.5
    return low, high


def plot_heatmaps(table: StudyTable, a: str, b: str, out_dir: Path) -> list[Path]:
    """Heatmaps of the collision rate and the time to pass over swept parameters a and b.

    Parameter a on x, b on y; one figure per metric and pedestrian variant, one panel per
    planner.
    """
    from matplotlib.figure import Figure

    gs = group_stats(table, ["planner", "pedestrian", a, b])
    index, planners = gs.index(), table.order("planner")
    xs, ys = table.order(a), table.order(b)
    metrics = [m for m in HEATMAP_METRICS if m in table.metrics] or table.metrics[:1]
    paths = []
    for m, ped in itertools.product(metrics, table.order("pedestrian")):
        grids = np.full((len(planners), len(ys), len(xs)), np.nan)
        for (p, y, x), _ in np.ndenumerate(grids):
            i = index.get((planners[p], ped, xs[x], ys[y]))
            if i is not None:
                grids[p, y, x] = gs.stats[m]["mean"][i]
        finite = grids[np.isfinite(grids)]
        if not len(finite):
            continue
        vmin, vmax = _color_range(finite, table.is_rate[m])
        fig = Figure(figsize=(1.5 + 3.4 * len(planners), 3.4), layout="constrained")
        axs = fig.subplots(1, len(planners), squeeze=False)[0]
        for ax, planner, grid in zip(axs, planners, grids):
            image = ax.imshow(grid, origin="lower", cmap="viridis", vmin=vmin, vmax=vmax,
                              aspect="auto")
            for (y, x), value in np.ndenumerate(grid):
                if np.isfinite(value):
                    ax.text(x, y, _fmt(value, table.is_rate[m]), ha="center", va="center",
                            fontsize=7, color="w" if value < (vmin + vmax) / 2 else "k")
            ax.set_xticks(np.arange(len(xs)), [display(x) for x in xs])
            ax.set_yticks(np.arange(len(ys)), [display(y) for y in ys])
            ax.set_xlabel(a)
            ax.set_title(planner)
        axs[0].set_ylabel(b)
        fig.colorbar(image, ax=list(axs), label=_ylabel(table, m))
        fig.suptitle(f"{m}" + (f", pedestrian: {ped}" if ped else ""))
        path = out_dir / (f"heatmap_{m}_{a}_x_{b}" + (f"_{ped}" if ped else "") + ".png")
        fig.savefig(path, dpi=100)
        paths.append(path)
    return paths


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

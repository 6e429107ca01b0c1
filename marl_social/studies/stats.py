"""Statistics of a study's results: the table as arrays, per-group counts, means and intervals.

* Rates (metrics that are true/false, e.g. robot_collision): the share of runs, with the Wilson
  score interval of the binomial proportion (no continuity correction, as
  `scipy.stats.binomtest(k, n).proportion_ci(method="wilson")`).
* Other metrics (e.g. time_to_pass_s [s]): the mean over the runs with a finite value (a run
  whose robot never passes has time_to_pass_s = nan) with the Student-t interval
  mean +- t(0.975, n-1) s / sqrt(n); no interval for n < 2. How many runs that is out of the
  runs that finished (`n` and `n_nan` per group: "passed k/n" for time_to_pass_s) is reported
  beside every such value.
* Failed runs (error column set) count in n_errors and in no metric.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CONFIDENCE = 0.95
HEATMAP_METRICS = ("robot_collision", "time_to_pass_s")
_BOOL_TEXT = {"true": 1.0, "false": 0.0}
# what a finite value of a metric means, for "passed k/n" (other metrics: "k/n with a value")
VALUE_WORDS = {"time_to_pass_s": "passed"}


# ------------------------------------------------------------------------------- intervals


def wilson_interval(successes, trials, confidence: float = CONFIDENCE):
    """Wilson score interval of a binomial proportion, vectorized.

    Newcombe 1998, without continuity correction: arrays of successes k and trials n ->
    (low, high); nan where n = 0. Equal to
    scipy.stats.binomtest(k, n).proportion_ci(method="wilson").
    """
    from scipy import stats  # here: scipy.stats takes ~1 s to import

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
    from scipy import stats  # here: scipy.stats takes ~1 s to import

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
        n_runs, n_errors: (G,) counts of runs and of failed runs.
        stats: metric -> {"n", "n_nan", "mean", "ci_low", "ci_high"} (G,) arrays: n runs with
            a finite value (the mean rests on them), n_nan finished runs without one (e.g.
            time_to_pass_s: the robot did not pass).
    """

    by: list[str]
    groups: list[tuple[str, ...]]
    n_runs: np.ndarray
    n_errors: np.ndarray
    stats: dict[str, dict[str, np.ndarray]]

    def index(self) -> dict[tuple[str, ...], int]:
        return {g: i for i, g in enumerate(self.groups)}

    @property
    def n_finished(self) -> np.ndarray:
        """(G,) runs that finished without an error."""
        return self.n_runs - self.n_errors


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
    n_runs = np.bincount(inverse, minlength=n_groups)
    n_errors = np.bincount(inverse, weights=failed, minlength=n_groups).astype(int)
    for st in out.values():
        st["n_nan"] = n_runs - n_errors - st["n"]
    return GroupStats(by, groups, n_runs, n_errors, out)


def display(label: str) -> str:
    """A parameter value for tables and axes: numbers with 4 significant digits."""
    kind, number, _ = _value_order(label)
    return f"{number:.4g}" if kind == 1 else label or "–"


def fmt(x: float, rate: bool) -> str:
    """A mean or bound: rates with 2 decimals, others with 3 significant digits; nan "–"."""
    if not np.isfinite(x):
        return "–"
    return f"{x:.2f}" if rate else f"{x:.3g}"


def count_text(metric: str, k: int, n_finished: int, n_errors: int) -> str:
    """How many runs a value rests on, e.g. "(5)", "(passed 1/5)", "(3/5 with a value, 1 failed)".

    Args:
        metric: the metric's name (VALUE_WORDS names what a value means).
        k: runs with a finite value (the mean rests on them).
        n_finished: runs that finished without an error.
        n_errors: runs that failed (no value).
    """
    if k == n_finished:
        text = str(k)
    elif metric in VALUE_WORDS:
        text = f"{VALUE_WORDS[metric]} {k}/{n_finished}"
    else:
        text = f"{k}/{n_finished} with a value"
    return f"({text}, {n_errors} failed)" if n_errors else f"({text})"

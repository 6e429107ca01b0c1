"""Plots of a study: each metric against each swept parameter, and heatmaps of two parameters.

Every figure says how many runs its values rest on: the title gives the usual number of runs
per point, and a point or cell that rests on fewer is marked "k/n" (k runs with a value, e.g.
in which the robot passed, of its n finished runs); failed runs are counted in the title.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from marl_social.studies.stats import (
    CONFIDENCE,
    HEATMAP_METRICS,
    VALUE_WORDS,
    StudyTable,
    display,
    fmt,
    group_stats,
)

# ----------------------------------------------------------------------------------- plots


def _ylabel(table: StudyTable, metric: str) -> str:
    return f"{metric} (rate)" if table.is_rate[metric] else metric


def _series(values: np.ndarray, ids: list[int | None]) -> np.ndarray:
    """values[ids] with nan where a group is missing (None)."""
    return np.array([values[i] if i is not None else np.nan for i in ids])


def _count_note(gs, m: str, ids: list[int]) -> tuple[int, str]:
    """(the usual number of finished runs per point, the title's note on counts) of groups ids.

    Points that rest on fewer runs than that (k of their n finished runs have a value, or n
    differs) are marked "k/n" (`_marked`). Failed runs are counted in the title.
    """
    n = gs.n_finished[ids]
    usual = int(np.bincount(n).argmax()) if len(n) else 0
    errors = int(gs.n_errors[ids].sum())
    note = f"{usual} runs per point; k/n marks k {_words(m)} of n finished"
    return usual, note + (f"; {errors} failed runs not counted" if errors else "")


def _marked(gs, m: str, i: int, usual: int) -> str:
    """"k/n" of group i if it rests on other than `usual` runs, else ""."""
    k, n = gs.stats[m]["n"][i], gs.n_finished[i]
    return f"{k}/{n}" if k != usual or n != usual else ""


def _words(metric: str) -> str:
    return f"runs that {VALUE_WORDS[metric]}" if metric in VALUE_WORDS else "runs with a value"


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
        usual, note = _count_note(gs, m, list(range(len(gs.groups))))
        fig = Figure(figsize=(max(6.4, 1.0 + 4.2 * len(pedestrians)), 4.0),
                     layout="constrained")
        axs = fig.subplots(1, len(pedestrians), squeeze=False, sharey=True)[0]
        for ax, ped in zip(axs, pedestrians):
            for j, planner in enumerate(planners):
                ids = [index.get((planner, ped, x)) for x in xs]
                mean, low, high = (_series(st[s], ids) for s in ("mean", "ci_low", "ci_high"))
                if np.isfinite(mean).any():
                    err = np.vstack([mean - low, high - mean])
                    ax.errorbar(np.arange(len(xs)) + offsets[j], mean,
                                yerr=np.where(np.isfinite(err), err, 0.0), marker="o",
                                capsize=3, label=planner, color=f"C{j}")
                _annotate_counts(ax, gs, m, ids, mean, offsets[j], j, usual)
            ax.set_xticks(np.arange(len(xs)), [display(x) for x in xs],
                          rotation=30 if len(xs) > 6 else 0)
            ax.set_xlabel(param)
            ax.set_title(f"pedestrian: {ped}" if ped else "")
            ax.grid(alpha=0.3)
        axs[0].set_ylabel(_ylabel(table, m))
        if table.is_rate[m]:
            axs[0].set_ylim(-0.03, 1.03)
        axs[0].legend(fontsize="small")
        fig.suptitle(f"{m} vs {param}, mean and {CONFIDENCE:.0%} CI\n{note}"
                     + (f"; pooled over {', '.join(pooled)}" if pooled else ""))
        path = out_dir / f"{m}_vs_{param}.png"
        fig.savefig(path, dpi=100)
        paths.append(path)
    return paths


def _annotate_counts(ax, gs, m: str, ids: list[int | None], mean: np.ndarray, offset: float,
                     j: int, usual: int) -> None:
    """Mark "k/n" beside the points of line j that rest on fewer runs than `usual`.

    A point where no run has a value is marked at the bottom of the panel.
    """
    for x, (i, y) in enumerate(zip(ids, mean)):
        text = _marked(gs, m, i, usual) if i is not None else ""
        if not text:
            continue
        if np.isfinite(y):
            ax.annotate(text, (x + offset, y), textcoords="offset points", xytext=(3, 3),
                        fontsize=6, color=f"C{j}")
        else:
            ax.annotate(text, (x + offset, 0.02 + 0.05 * j), xycoords=ax.get_xaxis_transform(),
                        fontsize=6, color=f"C{j}", ha="center")


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
        ids = [i for i, g in enumerate(gs.groups) if g[1] == ped]
        usual, note = _count_note(gs, m, ids)
        vmin, vmax = _color_range(finite, table.is_rate[m])
        fig = Figure(figsize=(1.5 + 3.4 * len(planners), 3.4), layout="constrained")
        axs = fig.subplots(1, len(planners), squeeze=False)[0]
        for ax, planner, grid in zip(axs, planners, grids):
            image = ax.imshow(grid, origin="lower", cmap="viridis", vmin=vmin, vmax=vmax,
                              aspect="auto")
            for (y, x), value in np.ndenumerate(grid):
                i = index.get((planner, ped, xs[x], ys[y]))
                if i is None:
                    continue
                text = fmt(value, table.is_rate[m])
                if _marked(gs, m, i, usual):
                    text += "\n" + _marked(gs, m, i, usual)
                dark = np.isfinite(value) and value < (vmin + vmax) / 2
                ax.text(x, y, text, ha="center", va="center", fontsize=7,
                        color="w" if dark else "k")
            ax.set_xticks(np.arange(len(xs)), [display(x) for x in xs])
            ax.set_yticks(np.arange(len(ys)), [display(y) for y in ys])
            ax.set_xlabel(a)
            ax.set_title(planner)
        axs[0].set_ylabel(b)
        fig.colorbar(image, ax=list(axs), label=_ylabel(table, m))
        fig.suptitle(f"{m}" + (f", pedestrian: {ped}" if ped else "") + f"\n{note}")
        path = out_dir / (f"heatmap_{m}_{a}_x_{b}" + (f"_{ped}" if ped else "") + ".png")
        fig.savefig(path, dpi=100)
        paths.append(path)
    return paths



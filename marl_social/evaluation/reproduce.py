"""`marl-social reproduce`: the paper's Figs. 3-6 and a table over randomized seeds.

Figures (section V): aggressive and social planners with a crossing pedestrian (Figs. 3, 4);
conservative and social planners with a non-crossing (waiting) pedestrian (Figs. 5, 6). Each
shows (a) trajectory snapshots, (b) robot and human speeds, (c) the perceived (robot sees it) and
inferred (belief) probability of a pedestrian.

Table: every robot planner x pedestrian variant over N seeds of `run.randomized_overrides` ("wide")
(pedestrian timing and speed, the human's lead, speed and rationality): collision rate, yield
rate, hard-brake rate (> 5 m/s^2), mean time to pass the crosswalk and mean speed.
"""

from __future__ import annotations

import multiprocessing as mp
from pathlib import Path

import numpy as np

PAPER_PLANNERS = ("social", "aggressive", "conservative", "oracle")  # the paper's four
VARIANTS = ("crossing", "waiting", "none")
FIGURES = (
    ("fig3_aggressive_crossing", "aggressive", "crossing"),
    ("fig4_social_crossing", "social", "crossing"),
    ("fig5_conservative_waiting", "conservative", "waiting"),
    ("fig6_social_waiting", "social", "waiting"),
)


def _one(job):
    from marl_social.evaluation.run import randomized_overrides, run_episode

    planner, variant, seed, max_cycles, extra = job
    try:
        res = run_episode("occluded_crosswalk", seed=seed, robot_planner=planner,
                          pedestrian=variant, max_cycles=max_cycles,
                          **{**randomized_overrides(seed, "wide"), **extra})
        return planner, variant, seed, res.metrics, None
    except Exception as err:  # noqa: BLE001  (a failed run is recorded, the table goes on)
        return planner, variant, seed, None, f"{type(err).__name__}: {err}"


def run_episodes(jobs, workers: int = 2, max_cycles: int = 200, progress: bool = False):
    """Run jobs of randomized occluded_crosswalk episodes on a process pool.

    A job is (planner, variant, seed) or (planner, variant, seed, overrides), the overrides on
    top of the randomization. Returns (planner, variant, seed, metrics or None, error or None) in
    job order.
    """
    jobs = [(*job[:3], max_cycles, dict(job[3]) if len(job) > 3 else {}) for job in jobs]
    return map_jobs(_one, jobs, workers, progress)


def map_jobs(function, jobs: list, workers: int, progress: bool = True) -> list:
    """function(job) for every job, in order: on a spawn pool of `workers` processes if > 1.

    Args:
        function: a picklable module-level function of one job.
        jobs: the jobs (picklable).
        workers: processes (1: in this process).
        progress: show a tqdm progress bar.
    """
    if workers > 1:
        with mp.get_context("spawn").Pool(workers) as pool:
            return list(_progress(pool.imap(function, jobs), len(jobs), progress))
    return list(_progress(map(function, jobs), len(jobs), progress))


def run_table(n_seeds: int, workers: int = 2, planners=PAPER_PLANNERS, variants=VARIANTS,
              progress=True, overrides: dict | None = None) -> list[dict]:
    """One row per (planner, variant): rates and means over n_seeds randomized episodes.

    `overrides` (scenario parameters) go on top of each episode's randomization.
    """
    jobs = [(p, v, s, overrides or {}) for p in planners for v in variants for s in range(n_seeds)]
    results = run_episodes(jobs, workers, progress=progress)
    return table_rows(results, planners, variants, summarize)


def summarize(runs: list[dict]) -> dict:
    """The table's values of one row's episodes (their `episode_metrics`, >= 1)."""
    return {
        "collision_rate": float(np.mean([m["robot_collision"] for m in runs])),
        "yield_rate": float(np.mean([m["yielded"] for m in runs])),
        "hard_brake_rate": float(np.mean([m["hard_brake"] for m in runs])),
        "time_to_pass_s": float(np.nanmean([m["time_to_pass_s"] for m in runs])),
        "mean_speed_mps": float(np.mean([m["mean_speed_mps"] for m in runs])),
    }


def table_rows(results: list[tuple], planners, variants, summarize) -> list[dict]:
    """One table row per (planner, variant) of a table's episodes.

    Args:
        results: (planner, variant, seed, summary or None, error or None) per episode.
        planners: the rows' planners, in order.
        variants: the rows' variants, in order (inner loop).
        summarize: runs (list of summaries, >= 1) -> the row's values (dict).

    Returns:
        dicts with "planner", "variant", "n" (episodes that ran), "errors" (their messages)
        and, where n > 0, summarize's values.
    """
    rows = []
    for p in planners:
        for v in variants:
            runs = [m for pp, vv, _, m, _ in results if pp == p and vv == v and m is not None]
            errors = [err for pp, vv, _, _, err in results if pp == p and vv == v and err]
            row = {"planner": p, "variant": v, "n": len(runs), "errors": errors}
            if runs:
                row.update(summarize(runs))
            rows.append(row)
    return rows


def _progress(iterable, total, enabled):
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc="episodes")


def markdown_table(rows: list[dict], variant_title: str, columns: list[tuple]) -> str:
    """The rows of a reproduce table (`table_rows`) as a Markdown table.

    Columns: planner, the variant (titled variant_title), n, then one per (title, render)
    of `columns`, render(row) -> the cell's text. A row without episodes shows its first error.
    """
    titles = ["planner", variant_title, "n"] + [title for title, _ in columns]
    lines = ["| " + " | ".join(titles) + " |", "|" + "---|" * len(titles)]
    for r in rows:
        if r["n"] == 0:
            lines.append(f"| {r['planner']} | {r['variant']} | 0 | errors: {r['errors'][:1]} "
                         + "| " * (len(columns) - 1) + "|")
            continue
        cells = [r["planner"], r["variant"], str(r["n"])] + [render(r) for _, render in columns]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


# the reproduce tables' common columns (markdown_table's (title, render))
COLLISION = ("collision", lambda r: f"{r['collision_rate']:.0%}")
YIELDED = ("yielded", lambda r: f"{r['yield_rate']:.0%}")
HARD_BRAKE = ("hard brake", lambda r: f"{r['hard_brake_rate']:.0%}")
TIME_TO_PASS = ("time to pass [s]", lambda r: f"{r['time_to_pass_s']:.2f}")
MEAN_SPEED = ("mean speed [m/s]", lambda r: f"{r['mean_speed_mps']:.2f}")
FORCED_BRAKING = ("forced braking [m/s^2]", lambda r: f"{r['others_max_decel_mps2']:.2f}")


def format_table(rows: list[dict]) -> str:
    """The rows of run_table as a Markdown table."""
    return markdown_table(rows, "pedestrian",
                          [COLLISION, YIELDED, HARD_BRAKE, TIME_TO_PASS, MEAN_SPEED])


def write_figures(out: Path, seed: int = 0) -> list[Path]:
    from marl_social.evaluation.run import run_episode
    from marl_social.viz.figures import EpisodeArrays, plot_episode

    paths = []
    for stem, planner, variant in FIGURES:
        res = run_episode("occluded_crosswalk", seed=seed, robot_planner=planner,
                          pedestrian=variant)
        tr = res.trace
        beliefs = {}
        if "p_pedestrian" in tr.extras and planner == "social":
            beliefs["inferred P(pedestrian) (robot belief)"] = tr.extras["p_pedestrian"]
        paths.append(plot_episode(
            res.road_map, EpisodeArrays.from_trace(tr),
            out / f"{stem}.png", title=f"{planner} planner, pedestrian {variant}",
            beliefs=beliefs or None))
    return paths

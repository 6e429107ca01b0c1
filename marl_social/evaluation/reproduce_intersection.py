"""`marl-social reproduce --scenario t_intersection`: the T-intersection (paper Fig. 1 b).

Figures: trajectory snapshots, speeds and who sees the hidden car V3 (the robot; the first
left-turner) for the social planner with V3 near and far, the aggressive planner with V3 near
(it should not pull out) and the conservative planner with V3 far (it need not wait).

Table: every robot planner x hidden_vehicle variant over N seeds of `randomized_overrides`
(run.RANDOMIZATIONS["t_intersection"]: the left-turners' number, start, speed and rationality,
V3's speed and start distance, the gap between the parked cars): collision, yield and hard-brake rates of the robot, its mean time to pass its
conflict zone and mean speed, the mean hardest braking it forced on a human, and how often the
first left-turner let V3 pass before turning.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from marl_social.evaluation.reproduce import (
    COLLISION,
    FORCED_BRAKING,
    HARD_BRAKE,
    MEAN_SPEED,
    TIME_TO_PASS,
    YIELDED,
    map_jobs,
    markdown_table,
    table_rows,
)

SCENARIO = "t_intersection"
PLANNERS = ("social", "aggressive", "conservative", "oracle")
VARIANTS = ("near", "far", "none")
FIGURES = (
    ("t_social_near", "social", "near"),
    ("t_social_far", "social", "far"),
    ("t_aggressive_near", "aggressive", "near"),
    ("t_conservative_far", "conservative", "far"),
)
MAX_CYCLES = 150  # 15 s: every planner that goes has left the junction by then


def randomized_overrides(seed: int) -> dict:
    """Overrides of one randomized episode: run.randomized_overrides(seed, "t_intersection").

    V3's speed and start distances, the left-turners' start, speed, rationality and number,
    the gap between the parked cars (run.RANDOMIZATIONS["t_intersection"]).
    """
    from marl_social.evaluation.run import randomized_overrides as draw

    return draw(seed, SCENARIO)


def first_left_turner_waited(result, hidden: str) -> float:
    """Whether human_0 let V3 pass.

    1.0 if it entered the left-turn crossing only after V3 had left it, 0.0 if before (or if V3
    never came); nan without human_0 or V3.

    Args:
        result: an EpisodeResult of the t_intersection scenario.
        hidden: V3's name (human_<n_humans>).
    """
    trace, road_map = result.trace, result.road_map
    if "human_0" not in trace.names or hidden not in trace.names or hidden == "human_0":
        return float("nan")
    zone = next(z for z in road_map.conflict_zones if z.name == "left_turn_crossing")

    def inside(name):
        i = trace.index(name)
        return np.flatnonzero(zone.contains(trace.states[:, i, :2]) & trace.active[:, i])

    turner, car = inside("human_0"), inside(hidden)
    if not len(car):
        return 0.0
    return float(len(turner) == 0 or turner[0] > car[-1])


def hidden_vehicle_timings(result) -> dict:
    """When the robot first sees V3, and when its belief in a hidden vehicle first exceeds 0.9.

    Args:
        result: an EpisodeResult of the t_intersection scenario (V3 is the last human).

    Returns:
        robot_first_sees_v3_s: the first time V3 is visible to the robot (nan: never) [s];
        belief_09_s: the first time the trace extra "p_vehicle" (the robot's belief in a
            hidden vehicle; 1 once it sees one) exceeds 0.9 (nan: never, or no belief) [s].
    """
    trace = result.trace
    times = np.asarray(trace.times_s)
    hidden = trace.index(f"human_{trace.roles.count('human') - 1}")
    seen = np.flatnonzero(trace.visible[:, trace.index("robot_0"), hidden])
    p = trace.extras.get("p_vehicle")
    high = np.flatnonzero(np.nan_to_num(p, nan=0.0) > 0.9) if p is not None else []
    return {"robot_first_sees_v3_s": float(times[seen[0]]) if len(seen) else float("nan"),
            "belief_09_s": float(times[high[0]]) if len(high) else float("nan")}


def claim_episode(job: tuple) -> tuple:
    """One episode for the claims tests: (planner, variant, seed, summary, error).

    The summary: the episode's metrics, human_0_waited and hidden_vehicle_timings.

    Args:
        job: (planner, variant, seed, max_cycles); the episode runs with
            randomized_overrides(seed).
    """
    from marl_social.evaluation.run import run_episode

    planner, variant, seed, max_cycles = job
    try:
        res = run_episode(SCENARIO, seed=seed, robot_planner=planner, hidden_vehicle=variant,
                          max_cycles=max_cycles, **randomized_overrides(seed))
        summary = dict(res.metrics)
        hidden = f"human_{res.trace.roles.count('human') - 1}"  # V3 is the last human
        summary["human_0_waited"] = first_left_turner_waited(res, hidden)
        summary.update(hidden_vehicle_timings(res))
        return planner, variant, seed, summary, None
    except Exception as err:  # noqa: BLE001  (reported by the caller)
        return planner, variant, seed, None, f"{type(err).__name__}: {err}"


def run_table(n_seeds: int, workers: int = 2, planners=PLANNERS, variants=VARIANTS,
              progress: bool = True) -> list[dict]:
    """One row per (planner, variant): rates and means over n_seeds randomized episodes."""
    jobs = [(p, v, s, MAX_CYCLES) for p in planners for v in variants for s in range(n_seeds)]
    results = map_jobs(claim_episode, jobs, workers, progress)

    def summarize(runs: list[dict]) -> dict:
        def mean(key):
            return float(np.nanmean([float(m[key]) for m in runs]))

        return {
            "collision_rate": mean("robot_collision"), "yield_rate": mean("yielded"),
            "hard_brake_rate": mean("hard_brake"), "time_to_pass_s": mean("time_to_pass_s"),
            "mean_speed_mps": mean("mean_speed_mps"),
            "others_max_decel_mps2": mean("others_max_decel_mps2"),
            "human_0_waited_rate": mean("human_0_waited"),
        }

    rows = table_rows(results, planners, variants, summarize)
    for row in rows:  # without V3 there is nothing to let pass
        if row["variant"] == "none" and row["n"]:
            row["human_0_waited_rate"] = float("nan")
    return rows


def format_table(rows: list[dict]) -> str:
    """The rows of run_table as a Markdown table."""
    def waited(r):
        return "-" if np.isnan(r["human_0_waited_rate"]) else f"{r['human_0_waited_rate']:.0%}"

    return markdown_table(rows, "V3", [COLLISION, YIELDED, HARD_BRAKE, TIME_TO_PASS, MEAN_SPEED,
                                       FORCED_BRAKING, ("human_0 let V3 pass", waited)])


def write_figures(out: Path, seed: int = 0) -> list[Path]:
    """The FIGURES as PNGs in `out`.

    Panel (c) shows who sees V3 (1) or not (0), and the robot's belief in a hidden car
    (trace extra "p_vehicle"; 1 while it sees one) for a belief-based planner.
    """
    from marl_social.evaluation.run import run_episode
    from marl_social.viz.figures import plot_episode

    paths = []
    for stem, planner, variant in FIGURES:
        res = run_episode(SCENARIO, seed=seed, robot_planner=planner, hidden_vehicle=variant,
                          max_cycles=MAX_CYCLES)
        tr = res.trace
        hidden = tr.index(f"human_{tr.roles.count('human') - 1}")  # V3 is the last human
        seen = {f"{observer} sees V3 ({tr.names[hidden]})":
                tr.visible[:, tr.index(observer), hidden].astype(float)
                for observer in ("robot_0", "human_0") if observer in tr.names}
        if "p_vehicle" in tr.extras:
            seen["robot_0's belief in a hidden car"] = tr.extras["p_vehicle"]
        paths.append(plot_episode(
            res.road_map, tr.names, tr.roles, tr.times_s, tr.states, tr.active, tr.visible,
            out / f"{stem}.png", title=f"T-intersection: {planner} planner, V3 {variant}",
            beliefs=seen, belief_title="who sees the hidden car V3, the robot's belief in it"))
    return paths

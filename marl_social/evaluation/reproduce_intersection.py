"""`marl-social reproduce --scenario t_intersection`: the T-intersection (paper Fig. 1 b).

Figures: trajectory snapshots, speeds and who sees the hidden car V3 (the robot; the first
left-turner) for the social planner with V3 near and far, the aggressive planner with V3 near
(it should not pull out) and the conservative planner with V3 far (it need not wait).

Table: every robot planner x hidden_vehicle variant over N seeds of `randomized_overrides`
(run.RANDOMIZATIONS["t_intersection"]: the left-turners' number, start, speed and rationality,
V3's speed and start distance, the gap between the parked cars): collision, yield and hard-brake rates of the robot, its mean time to pass its
conflict zone and mean speed, the mean hardest braking it forced on a human, how often the
first left-turner let V3 pass before turning, and how often it waited for V3 (V3 held it back:
left_turner_held_back, against the same seed without V3).
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
PLANNERS = ("social", "aggressive", "conservative", "oracle", "social-no-hold")
# a table row that is a robot planner with scenario overrides: its name -> (planner, overrides)
# "social-no-hold": the social robot without the sight hold (agents/robot/sight_hold.py)
ROW_PLANNERS = {"social-no-hold": ("social", {"robot_sight_hold": False})}
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


HELD_BACK_BELOW_MPS = 3.5  # a left-turner held back is slower than this (its curve speed ~4.4)
HELD_BACK_DEFICIT_MPS = 0.3  # ...and this much slower than in the same seed without V3 [m/s]


def _steps_in_left_turn_crossing(result, name: str) -> np.ndarray:
    """(k,) the steps at which agent `name` is active inside the left-turn crossing."""
    trace, road_map = result.trace, result.road_map
    zone = next(z for z in road_map.conflict_zones if z.name == "left_turn_crossing")
    i = trace.index(name)
    return np.flatnonzero(zone.contains(trace.states[:, i, :2]) & trace.active[:, i])


def first_left_turner_waited(result, hidden: str) -> float:
    """Whether human_0 let V3 pass.

    1.0 if it entered the left-turn crossing only after V3 had left it, 0.0 if before (or if V3
    never came); nan without human_0 or V3. This counts a left-turner that V3 had passed
    before it got there too: left_turner_held_back tells whether it waited for V3.

    Args:
        result: an EpisodeResult of the t_intersection scenario.
        hidden: V3's name (human_<n_humans>).
    """
    trace = result.trace
    if "human_0" not in trace.names or hidden not in trace.names or hidden == "human_0":
        return float("nan")
    turner = _steps_in_left_turn_crossing(result, "human_0")
    car = _steps_in_left_turn_crossing(result, hidden)
    if not len(car):
        return 0.0
    return float(len(turner) == 0 or turner[0] > car[-1])


def left_turner_record(result, hidden: str) -> dict:
    """What left_turner_held_back needs of one episode.

    Returns:
        human_0_speed_mps: (T,) human_0's speed per step [m/s] (nan while inactive; all nan
            without human_0);
        v3_left_crossing_step: the last step V3 is in the left-turn crossing (-1: never, or no V3).
    """
    trace = result.trace
    speed = np.full(len(trace.times_s), np.nan)
    if "human_0" in trace.names:
        i = trace.index("human_0")
        speed = np.where(trace.active[:, i], trace.states[:, i, 3], np.nan)
    car = (_steps_in_left_turn_crossing(result, hidden)
           if hidden in trace.names and hidden != "human_0" else np.zeros(0, dtype=int))
    return {"human_0_speed_mps": speed, "v3_left_crossing_step": int(car[-1]) if len(car) else -1}


def left_turner_held_back(near: dict, without_v3: dict) -> float:
    """Whether the first left-turner waited for V3: it let V3 pass *and* V3 held it back.

    Held back at a step before V3 left the left-turn crossing: human_0 drove slower than
    HELD_BACK_BELOW_MPS and more than HELD_BACK_DEFICIT_MPS slower than at the same step of the
    same seed without V3 (the counterfactual: what it did because of V3, not its curve speed).
    A left-turner that V3 passes before it arrives lets V3 pass without waiting for it.

    Args:
        near: claim_episode's summary with V3 (human_0_waited, human_0_speed_mps,
            v3_left_crossing_step).
        without_v3: the summary of the same seed and robot planner without V3.

    Returns:
        1.0 or 0.0; nan without human_0 or V3.
    """
    if np.isnan(near["human_0_waited"]):
        return float("nan")
    if near["human_0_waited"] != 1.0:
        return 0.0
    with_car, without = near["human_0_speed_mps"], without_v3["human_0_speed_mps"]
    n = min(near["v3_left_crossing_step"] + 1, len(with_car), len(without))
    with_car, without = with_car[:max(n, 0)], without[:max(n, 0)]
    held = (with_car < HELD_BACK_BELOW_MPS) & (without - with_car > HELD_BACK_DEFICIT_MPS)
    return float(np.any(held))


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

    The summary: the episode's metrics, human_0_waited, left_turner_record and
    hidden_vehicle_timings (left_turner_held_back pairs it with the same seed without V3);
    with counterfactual, the humans' warning (run_episode's counterfactual: warning_lead_s,
    ...).

    Args:
        job: (planner, variant, seed, max_cycles[, extra overrides: dict[, counterfactual]]);
            the episode runs with randomized_overrides(seed), updated by the extra overrides.
    """
    from marl_social.evaluation.run import run_episode

    planner, variant, seed, max_cycles, *extra = job
    try:
        overrides = {**randomized_overrides(seed), **(extra[0] if extra else {})}
        res = run_episode(SCENARIO, seed=seed, robot_planner=planner, hidden_vehicle=variant,
                          max_cycles=max_cycles,
                          counterfactual=bool(extra[1]) if len(extra) > 1 else False,
                          **overrides)
        summary = dict(res.metrics)
        hidden = f"human_{res.trace.roles.count('human') - 1}"  # V3 is the last human
        summary["human_0_waited"] = first_left_turner_waited(res, hidden)
        summary.update(left_turner_record(res, hidden))
        summary.update(hidden_vehicle_timings(res))
        return planner, variant, seed, summary, None
    except Exception as err:  # noqa: BLE001  (reported by the caller)
        return planner, variant, seed, None, f"{type(err).__name__}: {err}"


def run_table(n_seeds: int, workers: int = 2, planners=PLANNERS, variants=VARIANTS,
              progress: bool = True) -> list[dict]:
    """One row per (planner, variant): rates and means over n_seeds randomized episodes.

    A planner may be a robot planner's name or a key of ROW_PLANNERS (a planner with
    scenario overrides, e.g. "social-no-hold": the social robot without robot_sight_hold).
    """
    cells = [(p, v, s) for p in planners for v in variants for s in range(n_seeds)]
    jobs = [(planner, v, s, MAX_CYCLES, overrides) for p, v, s in cells
            for planner, overrides in [ROW_PLANNERS.get(p, (p, {}))]]
    # each result under its row's name (a ROW_PLANNERS row ran as its robot planner)
    results = [(p, *result[1:]) for (p, _, _), result
               in zip(cells, map_jobs(claim_episode, jobs, workers, progress))]
    add_held_back(results)

    def summarize(runs: list[dict]) -> dict:
        def mean(key):  # nan where no run has a value
            values = np.array([float(m.get(key, np.nan)) for m in runs])
            return float(np.mean(values[~np.isnan(values)])) if np.any(~np.isnan(values)) \
                else float("nan")

        return {
            "collision_rate": mean("robot_collision"), "yield_rate": mean("yielded"),
            "hard_brake_rate": mean("hard_brake"), "time_to_pass_s": mean("time_to_pass_s"),
            "mean_speed_mps": mean("mean_speed_mps"),
            "others_max_decel_mps2": mean("others_max_decel_mps2"),
            "human_0_waited_rate": mean("human_0_waited"),
            "human_0_held_back_rate": mean("human_0_held_back"),
        }

    rows = table_rows(results, planners, variants, summarize)
    for row in rows:  # without V3 there is nothing to let pass
        if row["variant"] == "none" and row["n"]:
            row["human_0_waited_rate"] = float("nan")
    return rows


def add_held_back(results: list[tuple]) -> None:
    """Add "human_0_held_back" (left_turner_held_back) to the summaries with V3, in place.

    Args:
        results: claim_episode's (planner, variant, seed, summary, error) tuples; a summary
            with V3 gets the entry where the same planner and seed ran without V3 ("none").
    """
    without_v3 = {(p, s): m for p, v, s, m, _ in results if v == "none" and m is not None}
    for p, v, s, m, _ in results:
        if v != "none" and m is not None and (p, s) in without_v3:
            m["human_0_held_back"] = left_turner_held_back(m, without_v3[(p, s)])


def format_table(rows: list[dict]) -> str:
    """The rows of run_table as a Markdown table."""
    def rate(key):
        return lambda r: "-" if np.isnan(r[key]) else f"{r[key]:.0%}"

    return markdown_table(rows, "V3", [COLLISION, YIELDED, HARD_BRAKE, TIME_TO_PASS, MEAN_SPEED,
                                       FORCED_BRAKING,
                                       ("human_0 let V3 pass", rate("human_0_waited_rate")),
                                       ("human_0 waited for V3",
                                        rate("human_0_held_back_rate"))])


def write_figures(out: Path, seed: int = 0) -> list[Path]:
    """The FIGURES as PNGs in `out`.

    Panel (c) shows who sees V3 (1) or not (0), and the robot's belief in a hidden car
    (trace extra "p_vehicle"; 1 while it sees one) for a belief-based planner.
    """
    from marl_social.evaluation.run import run_episode
    from marl_social.viz.figures import EpisodeArrays, plot_episode

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
            res.road_map, EpisodeArrays.from_trace(tr),
            out / f"{stem}.png", title=f"T-intersection: {planner} planner, V3 {variant}",
            beliefs=seen, belief_title="who sees the hidden car V3, the robot's belief in it"))
    return paths

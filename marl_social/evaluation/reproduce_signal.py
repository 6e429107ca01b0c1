"""`marl-social reproduce --scenario signalized_intersection`: right turn on red (paper Fig. 1 c).

Figures: trajectory snapshots, speeds and the robot's belief in the two phases (protected
left, cross traffic green; trace extras "phase_<name>") for the social planner in both
variants, the aggressive planner with the cross traffic on green (it assumes the favourable
phase) and the conservative one on the protected left (it waits for the cross traffic to stop
or pass).

Table: every robot planner x phase variant over N seeds of `randomized_overrides`
(run.RANDOMIZATIONS["signalized_intersection"]: the cross traffic's number, start, gap and
speed, the left-turners' number, start and rationality, the time already spent in the phase,
the robot's start): collision rate, the rate of episodes in which the robot forced a human to
brake harder than FORCED_BRAKE_MPS2, the mean time at which the robot's front enters the merge
zone (`turn_s`: it pulls out; an episode in which it never does is left out of the mean and
counted in "never"), its mean time to pass the merge zone and mean speed, and the mean
hardest braking it forced on a human. The episodes run through reproduce.map_jobs (the same
pool and progress bar as the other tables).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from marl_social.evaluation.reproduce import (
    COLLISION,
    FORCED_BRAKING,
    MEAN_SPEED,
    TIME_TO_PASS,
    map_jobs,
    markdown_table,
    table_rows,
)
from marl_social.sim.route_rules import route_conflicts
from marl_social.sim.signal_rules import route_signal_lines

SCENARIO = "signalized_intersection"
PLANNERS = ("social", "aggressive", "conservative", "oracle")
VARIANTS = ("protected_left", "cross_green")
FIGURES = (
    ("sig_social_protected_left", "social", "protected_left"),
    ("sig_social_cross_green", "social", "cross_green"),
    ("sig_aggressive_cross_green", "aggressive", "cross_green"),
    ("sig_conservative_protected_left", "conservative", "protected_left"),
)
MAX_CYCLES = 250  # 25 s: the conservative robot goes at the latest on its own green (~15 s)
FORCED_BRAKE_MPS2 = 3.0  # forcing a human to brake harder than this counts [m/s^2]


def randomized_overrides(seed: int) -> dict:
    """Overrides of one randomized episode: run.randomized_overrides(seed, SCENARIO)."""
    from marl_social.evaluation.run import randomized_overrides as draw

    return draw(seed, SCENARIO)


def turn_time_s(result, robot: str = "robot_0") -> float:
    """When the robot pulls out: its front bumper enters the merge zone [s] (nan: never).

    The first conflict zone on its route where it yields (sim/route_rules.route_conflicts);
    its signal stop line if there is none.

    Args:
        result: an EpisodeResult of the signalized intersection.
        robot: the robot's name.
    """
    trace, road_map = result.trace, result.road_map
    route = road_map.routes[robot]
    yields = [c.s_enter_m for c in route_conflicts(route, road_map) if c.yields]
    mark = yields[0] if yields else float(route_signal_lines(route, road_map)[0][0])
    i = trace.index(robot)
    s, _, _ = route.project(np.asarray(trace.states)[:, i, :2])
    front = s + 0.5 * result.specs[robot].vehicle.length_m
    past = np.flatnonzero((front > mark) & np.asarray(trace.active)[:, i])
    return float(np.asarray(trace.times_s)[past[0]]) if len(past) else float("nan")


def _nanmean(values) -> float:
    """Mean of the finite values (nan if there is none)."""
    x = np.asarray(values, dtype=np.float64)
    return float(np.mean(x[np.isfinite(x)])) if np.isfinite(x).any() else float("nan")


def claim_episode(job: tuple) -> tuple:
    """One episode: (planner, variant, seed, summary, error).

    The summary: the episode's metrics and turn_s (`turn_time_s`); with counterfactual, the
    humans' warning against the same seed in the other phase (run_episode's counterfactual),
    first_warned_s, and belief_09_s: when the robot's belief in the phase running first
    exceeds 0.9 (nan: never).

    Args:
        job: (planner, variant, seed, max_cycles[, counterfactual]); the episode runs with
            randomized_overrides(seed).
    """
    from marl_social.evaluation.run import run_episode

    planner, variant, seed, max_cycles, *counterfactual = job
    try:
        res = run_episode(SCENARIO, seed=seed, robot_planner=planner, phase=variant,
                          max_cycles=max_cycles, counterfactual=bool(counterfactual and
                                                                     counterfactual[0]),
                          **randomized_overrides(seed))
        summary = dict(res.metrics)
        summary["turn_s"] = turn_time_s(res)
        belief = res.trace.extras.get(f"phase_{variant}")
        high = np.flatnonzero(np.nan_to_num(belief, nan=0.0) > 0.9) if belief is not None \
            else []
        summary["belief_09_s"] = (float(res.trace.times_s[high[0]]) if len(high)
                                  else float("nan"))
        return planner, variant, seed, summary, None
    except Exception as err:  # noqa: BLE001  (a failed run is recorded, the table goes on)
        return planner, variant, seed, None, f"{type(err).__name__}: {err}"


def run_table(n_seeds: int, workers: int = 2, planners=PLANNERS, variants=VARIANTS,
              progress: bool = True, max_cycles: int = MAX_CYCLES) -> list[dict]:
    """One row per (planner, variant): rates and means over n_seeds randomized episodes."""
    jobs = [(p, v, s, max_cycles) for p in planners for v in variants for s in range(n_seeds)]
    results = map_jobs(claim_episode, jobs, workers, progress)

    def summarize(runs: list[dict]) -> dict:
        def mean(key):
            return _nanmean([float(m[key]) for m in runs])

        forced = [float(m["others_max_decel_mps2"]) > FORCED_BRAKE_MPS2 for m in runs]
        return {
            "collision_rate": mean("collision"), "forced_brake_rate": float(np.mean(forced)),
            "turn_s": mean("turn_s"),
            "never_turned": int(sum(not np.isfinite(m["turn_s"]) for m in runs)),
            "time_to_pass_s": mean("time_to_pass_s"),
            "mean_speed_mps": mean("mean_speed_mps"),
            "others_max_decel_mps2": mean("others_max_decel_mps2"),
        }

    return table_rows(results, planners, variants, summarize)


def format_table(rows: list[dict]) -> str:
    """The rows of run_table as a Markdown table."""
    return markdown_table(rows, "phase", [
        COLLISION,
        ("forced braking > 3 m/s^2", lambda r: f"{r['forced_brake_rate']:.0%}"),
        ("pulls out at [s] (never)", lambda r: f"{r['turn_s']:.2f} ({r['never_turned']})"),
        TIME_TO_PASS, MEAN_SPEED, FORCED_BRAKING])


def write_figures(out: Path, seed: int = 0) -> list[Path]:
    """The FIGURES as PNGs in `out`; panel (c): the robot's belief in each of the two phases."""
    from marl_social.evaluation.run import run_episode
    from marl_social.viz.figures import EpisodeArrays, plot_episode

    paths = []
    for stem, planner, variant in FIGURES:
        res = run_episode(SCENARIO, seed=seed, robot_planner=planner, phase=variant,
                          max_cycles=MAX_CYCLES)
        tr = res.trace
        beliefs = {f"robot_0's belief: {name}": tr.extras[f"phase_{name}"]
                   for name in VARIANTS if f"phase_{name}" in tr.extras}
        paths.append(plot_episode(
            res.road_map, EpisodeArrays.from_trace(tr),
            out / f"{stem}.png", title=f"Signalized intersection: {planner} planner, {variant}",
            beliefs=beliefs, belief_title="the robot's belief in the signal phase",
            signal_states=tr.signal_states))
    return paths

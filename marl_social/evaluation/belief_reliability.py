"""How reliably the robot's belief reads the humans: per episode, per population, a diagram.

Per episode (`reliability_episode`, one job of benchmarks/belief_reliability.py): the robot's
belief in what its scene hides (the trace extra `Scenario.hidden_agent().belief`) up to its
reference time, the robot's first sight of the hidden agent (at the signalized intersection,
where the hidden thing is the cross traffic's phase and nothing is out of sight, the time the
robot pulls out), and the humans' counterfactual warning (evaluation/counterfactual.py) before
it. Per population (`reliability_bins`, `brier_score`): the belief at fixed times before that
reference against how often the hidden agent was there (a reliability diagram).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CONFIDENT = 0.9  # a belief above this is confident
DOUBT = 0.5  # a confident belief must not fall below this before the reference
LEAD_S = 0.5  # a warning this long before the reference counts [s]
BEFORE_SIGHT_S = (0.5, 1.0, 1.5, 2.0)  # the reliability view's times before the reference [s]
N_BINS = 10  # the reliability diagram's belief bins over [0, 1]


@dataclass(frozen=True)
class Cell:
    """A population of episodes: one scene, robot planner and variant over seeds.

    Attributes:
        scene: a registered scenario name.
        planner: the robot's planner.
        overrides: scenario overrides on top of each seed's randomization (the variant).
        max_cycles: the episodes' step limit.
        counterfactual: also run each seed without the hidden agent (the warning).
        preset: the randomization (run.RANDOMIZATIONS) drawn per seed.
    """

    scene: str
    planner: str
    overrides: dict = field(default_factory=dict)
    max_cycles: int = 200
    counterfactual: bool = False
    preset: str = "wide"


def belief_key(scene: str) -> str:
    """The trace extra of the robot's belief in what `scene` hides (its first variant's)."""
    from marl_social.scenarios import SCENARIOS, make_scenario

    hidden = make_scenario(scene, **SCENARIOS[scene].variants[0]).hidden_agent()
    if hidden is None:
        raise ValueError(f"scenario {scene!r} hides nothing from the robot")
    return hidden.belief


def crossings(belief: np.ndarray, level: float = DOUBT) -> int:
    """How often a belief series crosses `level` (either way; nan steps left out)."""
    above = np.asarray(belief)[np.isfinite(belief)] > level
    return int(np.count_nonzero(above[1:] != above[:-1]))


def holds_once_confident(belief: np.ndarray) -> bool:
    """Once above CONFIDENT, never below DOUBT (False: never confident)."""
    belief = np.nan_to_num(np.asarray(belief), nan=1.0)
    above = np.flatnonzero(belief > CONFIDENT)
    return bool(len(above) and belief[above[0]:].min() >= DOUBT)


def reference_time_s(result, hidden) -> float:
    """The robot's first sight of the hidden agent [s].

    Where the scene hides no agent (a signal phase): the time the robot pulls out into its
    first yield zone; nan: neither, or nothing hidden (`hidden` None).

    Args:
        result: an EpisodeResult.
        hidden: its scenario's HiddenAgent (Scenario.hidden_agent), or None.
    """
    from marl_social.evaluation.counterfactual import robot_first_sight_s
    from marl_social.evaluation.reproduce_signal import turn_time_s

    if hidden is None:
        return float("nan")
    if hidden.names:
        return robot_first_sight_s(result.trace, hidden.names)
    return turn_time_s(result) if result.road_map.conflict_zones else float("nan")


def episode_summary(result, hidden, key: str) -> dict:
    """One episode's numbers for the reliability claims.

    Args:
        result: an EpisodeResult (with counterfactual=True where a warning is wanted).
        hidden: its scenario's HiddenAgent, or None (nothing hidden: no reference time).
        key: the trace extra of the robot's belief in the hidden thing (belief_key).

    Returns:
        max_decel_mps2, robot_collision, collision, yielded, time_to_pass_s: the metrics;
        mpc_infeasible_steps: steps the robot's MPC found no feasible plan;
        surprise_infeasible_steps: of them, those a comfortable stop one step earlier would
        have met; contingency_given_way_steps: steps feasible only with a hidden car's bound
        given way to a comfortable stop (run.infeasible_steps);
        reference_s: reference_time_s (nan: none); lead_s: the reference minus the earliest
        warning before it (nan: no counterfactual; 0: no warning before it);
        confident, holds, crossings: the belief before the reference (all of it without a
        reference) exceeded CONFIDENT / holds_once_confident / crossings of DOUBT;
        max_belief: the largest belief over the episode (where the robot does not see the
        hidden agent: a seen agent's belief is 1); belief: the series (T+1,); dt_s: the step.
    """
    from marl_social.evaluation.run import infeasible_steps

    trace, m = result.trace, result.metrics
    times = np.asarray(trace.times_s)
    belief = np.asarray(trace.extras.get(key, np.full(len(times), np.nan)), dtype=np.float64)
    ref = reference_time_s(result, hidden)
    end = int(np.searchsorted(times, ref - 1e-9)) if np.isfinite(ref) else len(times)
    before = belief[:end]
    lead = float("nan")
    if result.warning is not None:
        warned = [t for t in result.warning.human_warned_s.values()
                  if np.isfinite(t) and (not np.isfinite(ref) or t <= ref)]
        lead = (round(float(ref - min(warned)), 9) if warned and np.isfinite(ref)
                else (float("inf") if warned else 0.0))
    return {
        "max_decel_mps2": float(m["max_decel_mps2"]), "robot_collision": bool(m["robot_collision"]),
        "collision": bool(m["collision"]), "yielded": bool(m["yielded"]),
        "time_to_pass_s": float(m["time_to_pass_s"]),
        **infeasible_steps(trace),
        "reference_s": ref, "lead_s": lead,
        "confident": bool(np.any(before > CONFIDENT)), "holds": holds_once_confident(before),
        "crossings": crossings(before),
        "max_belief": float(np.nanmax(before)) if np.isfinite(before).any() else float("nan"),
        "belief": belief, "dt_s": float(times[1] - times[0]) if len(times) > 1 else 0.1,
    }


def reliability_episode(job: tuple) -> tuple:
    """One episode of a Cell: (cell name, seed, episode_summary or None, error or None).

    Args:
        job: (cell name, Cell, seed); the episode runs with the cell's preset randomization of
            the seed, updated by the cell's overrides.
    """
    from marl_social.evaluation.run import randomized_overrides, run_episode
    from marl_social.evaluation.stopping import PassedCrosswalk
    from marl_social.scenarios import make_scenario

    name, cell, seed = job
    try:
        overrides = {**randomized_overrides(seed, cell.preset), **cell.overrides}
        until = (PassedCrosswalk() if cell.scene == "occluded_crosswalk"
                 and overrides.get("pedestrian") in ("none", "waiting")
                 and "robot_pos_noise_m" not in cell.overrides else None)
        res = run_episode(cell.scene, seed=seed, robot_planner=cell.planner,
                          max_cycles=cell.max_cycles, until=until,
                          counterfactual=cell.counterfactual, **overrides)
        hidden = make_scenario(cell.scene, **overrides).hidden_agent()
        return name, seed, episode_summary(res, hidden, belief_key(cell.scene)), None
    except Exception as err:  # noqa: BLE001  (reported by the caller)
        return name, seed, None, f"{type(err).__name__}: {err}"


def belief_before_reference(summary: dict, before_s: float) -> float:
    """The belief `before_s` before an episode's reference (nan: before its start, or none)."""
    ref = summary["reference_s"]
    if not np.isfinite(ref):
        return float("nan")
    k = round((ref - before_s) / summary["dt_s"])
    belief = summary["belief"]
    return float(belief[k]) if 0 <= k < len(belief) else float("nan")


def reliability_bins(predicted, happened, n_bins: int = N_BINS) -> list[dict]:
    """The reliability diagram's bins: the mean belief against how often the thing was there.

    Args:
        predicted: (N,) beliefs in [0, 1] (nan left out).
        happened: (N,) 1 where the hidden agent was there, 0 where not.
        n_bins: equal bins over [0, 1].

    Returns:
        One dict per non-empty bin: lo, hi (its edges), n, mean_belief, frequency.
    """
    p = np.asarray(predicted, dtype=np.float64)
    y = np.asarray(happened, dtype=np.float64)
    keep = np.isfinite(p)
    p, y = p[keep], y[keep]
    index = np.minimum(np.floor(p * n_bins), n_bins - 1)
    out = []
    for b in range(n_bins):
        inside = index == b
        if inside.any():
            out.append({"lo": b / n_bins, "hi": (b + 1) / n_bins, "n": int(inside.sum()),
                        "mean_belief": float(p[inside].mean()),
                        "frequency": float(y[inside].mean())})
    return out


def brier_score(predicted, happened) -> float:
    """Mean squared difference of belief and outcome (nan beliefs left out; nan: none)."""
    p = np.asarray(predicted, dtype=np.float64)
    y = np.asarray(happened, dtype=np.float64)
    keep = np.isfinite(p)
    return float(np.mean((p[keep] - y[keep]) ** 2)) if keep.any() else float("nan")


def reliability_points(present: list[dict], absent: list[dict],
                       before_s: tuple = BEFORE_SIGHT_S) -> tuple[np.ndarray, np.ndarray]:
    """(beliefs, outcomes) at fixed times before the reference, over paired populations.

    Args:
        present: episode summaries with the hidden agent, seed by seed.
        absent: the same seeds without it; each is read at its partner's reference time (it
            has none of its own).
        before_s: the times before the reference [s].
    """
    beliefs, outcomes = [], []
    for with_it, without in zip(present, absent):
        for t in before_s:
            partner = {**without, "reference_s": with_it["reference_s"]}
            beliefs += [belief_before_reference(with_it, t), belief_before_reference(partner, t)]
            outcomes += [1.0, 0.0]
    return np.array(beliefs), np.array(outcomes)


def plot_reliability(panels: dict, path) -> None:
    """A reliability diagram per scene: {title: (beliefs, outcomes)} -> a PNG at `path`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 4.0), squeeze=False)
    for ax, (title, (p, y)) in zip(axes[0], panels.items()):
        bins = reliability_bins(p, y)
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="perfectly reliable")
        ax.plot([b["mean_belief"] for b in bins], [b["frequency"] for b in bins], "o-",
                label="the robot's belief")
        for b in bins:
            ax.annotate(str(b["n"]), (b["mean_belief"], b["frequency"]), fontsize=7,
                        xytext=(3, -9), textcoords="offset points")
        ax.set(xlim=(0, 1), ylim=(-0.03, 1.03), xlabel="belief before the robot's sight",
               ylabel="frequency of the hidden agent",
               title=f"{title}\nBrier {brier_score(p, y):.3f}")
        ax.legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# each scene's populations with and without what it hides (the same seeds), for the diagram
SCENE_PAIRS = {
    "occluded_crosswalk": (Cell("occluded_crosswalk", "social", {"pedestrian": "crossing"}, 200,
                                True),
                           Cell("occluded_crosswalk", "social", {"pedestrian": "none"}, 100)),
    "t_intersection": (Cell("t_intersection", "social", {"hidden_vehicle": "near"}, 150, True,
                            "t_intersection"),
                       Cell("t_intersection", "social", {"hidden_vehicle": "none"}, 120, False,
                            "t_intersection")),
    "signalized_intersection": (
        Cell("signalized_intersection", "social", {"phase": "protected_left"}, 250, True,
             "signalized_intersection"),
        Cell("signalized_intersection", "social", {"phase": "cross_green"}, 250, False,
             "signalized_intersection")),
}


def write_reliability_figure(scene: str, out, seeds, workers: int = 2,
                             progress: bool = True) -> tuple:
    """The scene's reliability diagram over `seeds` as out/reliability.png, and its Brier score.

    Args:
        scene: a key of SCENE_PAIRS.
        out: the folder to write to.
        seeds: the seeds (each runs with and without what the scene hides).
        workers: processes.
        progress: show a progress bar.

    Returns:
        (the PNG's path, the Brier score).
    """
    from pathlib import Path

    from marl_social.evaluation.reproduce import map_jobs

    present, absent = SCENE_PAIRS[scene]
    jobs = [(name, cell, seed) for seed in seeds
            for name, cell in (("present", present), ("absent", absent))]
    runs: dict = {"present": [], "absent": []}
    for name, seed, summary, error in map_jobs(reliability_episode, jobs, workers, progress):
        if error is not None:
            raise RuntimeError(f"{scene} {name} / seed {seed}: {error}")
        runs[name].append(summary)
    p, y = reliability_points(runs["present"], runs["absent"])
    path = Path(out) / "reliability.png"
    plot_reliability({scene: (p, y)}, path)
    return path, brier_score(p, y)

"""`marl-social record`: demonstrations or decisions of the simulated human drivers.

Demonstrations (marl_social/data/demonstrations.py) are for inverse optimal control
(agents/irl/laplace.py), decisions (marl_social/data/decisions.py, `record_decisions`) for
discrete-choice IRL (agents/irl/choice.py).

Every human driver of every episode is cut into segments of `segment_steps` simulator steps
(every `stride_steps`). A segment holds the human's executed accelerations along its route, its
state at the start, its desired speed (the v_ref of its speed feature), the other agents it saw
at the segment start (their true positions over the segment: what it reacted to, as logged
trajectories are used with real data), the map's crosswalks, and its true theta and beta.
Segments in which the human nearly stops (speed below `min_speed_mps`) are skipped: the IRL
model has no v >= 0 limit, and a stopped car's zero acceleration is the limit, not a choice.
"""

from __future__ import annotations

import multiprocessing as mp
from dataclasses import dataclass

import numpy as np

from marl_social.agents.registry import DEFAULT_PLANNER, planner_params
from marl_social.data.decisions import DecisionSet
from marl_social.data.demonstrations import Demonstration
from marl_social.models.driver import DriverModel


def episode_demonstrations(result, segment_steps: int = 30, stride_steps: int = 10,
                           min_speed_mps: float = 1.0, source: str = "") -> list[Demonstration]:
    """Cut every human driver of one `run_episode` result into demonstrations."""
    trace, road_map, specs = result.trace, result.road_map, result.specs
    states, active = np.asarray(trace.states), np.asarray(trace.active)
    visible, accel = np.asarray(trace.visible), np.asarray(trace.accel_mps2)
    n_steps = len(accel)
    out = []
    for i, name in enumerate(trace.names):
        if trace.roles[i] != "human":
            continue
        spec = specs[name]
        route = road_map.routes[name]
        v_ref = min(spec.v_desired_mps, road_map.speed_limit_mps)
        for t0 in range(0, n_steps - segment_steps + 1, stride_steps):
            window = slice(t0, t0 + segment_steps + 1)
            if not active[window, i].all():
                continue
            if states[window, i, 3].min() < min_speed_mps:
                continue
            s0, _ = route.project_point(*states[t0, i, :2])
            others = [j for j in range(len(trace.names)) if j != i and visible[t0, i, j]
                      and active[window, j].all()]
            future = slice(t0 + 1, t0 + segment_steps + 1)
            other_specs = [specs[trace.names[j]] for j in others]
            is_ped = np.array([s.kind == "pedestrian" for s in other_specs], dtype=bool)
            size = lambda s, attr: (2.0 * s.pedestrian.radius_m if s.kind == "pedestrian"
                                    else getattr(s.vehicle, attr))
            out.append(Demonstration(
                controls_mps2=accel[t0:t0 + segment_steps, i], dt_s=float(
                    trace.times_s[1] - trace.times_s[0]),
                s0_m=s0, v0_mps=float(states[t0, i, 3]),
                prev_accel_mps2=float(accel[t0 - 1, i]) if t0 > 0 else 0.0,
                v_ref_mps=v_ref, path_xy=route.points, length_m=spec.vehicle.length_m,
                width_m=spec.vehicle.width_m,
                others_xy=np.moveaxis(states[future][:, others, :2], 0, 1),
                others_heading=np.moveaxis(states[future][:, others, 2], 0, 1),
                others_length_m=[size(s, "length_m") for s in other_specs],
                others_width_m=[size(s, "width_m") for s in other_specs],
                others_is_pedestrian=is_ped, crosswalks=road_map.crosswalks,
                theta_true=spec.cost_weights.as_array(),
                beta_true=_driver_beta(spec), agent=name, source=source,
                t0_s=float(trace.times_s[t0]),
            ))
    return out


def _driver_beta(spec) -> float:
    """The true rationality a human driver's built-in planner uses (its typed parameters)."""
    return float(planner_params(DEFAULT_PLANNER["human"], spec).beta)


def episode_decisions(result, source: str = "") -> DecisionSet | None:
    """Every human driver's recorded decisions of one episode as a DecisionSet.

    The episode is a `run_episode(..., record_human_decisions=True)` result; None if there were
    no decisions.
    """
    if result.decisions is None:
        raise ValueError("episode_decisions: run the episode with record_human_decisions=True")
    parts = []
    for name, rows in result.decisions.items():
        if not rows:
            continue
        spec = result.specs[name]
        n = len(rows)
        first = np.asarray(DriverModel().first_actions_mps2)  # BoltzmannDriver's candidate set
        parts.append(DecisionSet(
            features=np.stack([r[0] for r in rows]), allowed=np.stack([r[1] for r in rows]),
            chosen=np.array([r[2] for r in rows]), first_actions_mps2=first,
            theta_true=np.tile(spec.cost_weights.as_array(), (n, 1)),
            beta_true=np.full(n, _driver_beta(spec)),
            agent=np.full(n, name), source=np.full(n, source),
            t_s=np.asarray(result.trace.times_s[:n], dtype=np.float64)))
    return DecisionSet.concatenate(parts) if parts else None


def _record_one(job):
    from marl_social.evaluation.run import run_episode, scenario_randomized_overrides

    scenario, seed, max_cycles, overrides, randomize, segment_steps, stride_steps = job
    params = {**(scenario_randomized_overrides(seed, scenario) if randomize else {}),
              **overrides}
    decisions = segment_steps is None
    result = run_episode(scenario, seed=seed, max_cycles=max_cycles,
                         record_human_decisions=decisions, **params)
    if decisions:
        return episode_decisions(result, source=f"{scenario} seed={seed}")
    return episode_demonstrations(result, segment_steps, stride_steps,
                                  source=f"{scenario} seed={seed}")


@dataclass(frozen=True)
class Segments:
    """How a human's drive is cut into demonstrations: `steps` controls each, every `stride`."""

    steps: int = 30
    stride: int = 10


def record_demonstrations(scenario: str = "occluded_crosswalk", seeds=range(20),
                          overrides: dict | None = None, randomize: bool = True,
                          max_cycles: int = 150, segments: Segments = Segments(),
                          workers: int = 1, progress: bool = False) -> list[Demonstration]:
    """Run one episode per seed and cut the humans into demonstrations (`segments`).

    Each episode runs its built-in planners, with `overrides` on top of
    run.scenario_randomized_overrides(seed, scenario) when randomize (the scenario's own
    randomization: the occluded crosswalk's "paper" preset, each intersection's own range).
    """
    overrides = dict(overrides or {})
    jobs = [(scenario, int(s), max_cycles, overrides, randomize, segments.steps, segments.stride)
            for s in seeds]
    return [d for chunk in _run_jobs(jobs, workers, progress) for d in chunk]


def record_decisions(scenario: str = "occluded_crosswalk", seeds=range(20),
                     overrides: dict | None = None, randomize: bool = True,
                     max_cycles: int = 150, workers: int = 1,
                     progress: bool = False) -> DecisionSet | None:
    """Run one episode per seed (as record_demonstrations) and keep the humans' decisions.

    Every human driver's decisions (marl_social/data/decisions.py); None if no human decided.
    """
    overrides = dict(overrides or {})
    jobs = [(scenario, int(s), max_cycles, overrides, randomize, None, None) for s in seeds]
    parts = [p for p in _run_jobs(jobs, workers, progress) if p is not None]
    return DecisionSet.concatenate(parts) if parts else None


def _run_jobs(jobs, workers, progress) -> list:
    if workers > 1:
        with mp.get_context("spawn").Pool(workers) as pool:
            return list(_progress(pool.imap(_record_one, jobs), len(jobs), progress))
    return list(_progress(map(_record_one, jobs), len(jobs), progress))


def _progress(iterable, total, enabled):
    if not enabled:
        return iterable
    from tqdm import tqdm

    return tqdm(iterable, total=total, desc="episodes")

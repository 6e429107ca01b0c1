"""Run a recorded scene on its map: the recording's vehicles replayed, the robot planning.

    result = run_replay(ReplayRun("DR_USA_Intersection_GL.osm", "vehicle_tracks_000.csv"))

The scene is the `map_replay` scenario (scenarios/map_replay.py); the replayed vehicles drive
agents/log_replay.py, the robot its planner (`robot_planner`, "social" by default), so its belief
runs on recorded human behaviour.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from marl_social.agents.log_replay import LogReplayPolicy
from marl_social.envs.parallel import parallel_env
from marl_social.envs.policies import make_policy
from marl_social.evaluation.run import record_robot_episode
from marl_social.metrics.episode import belief_metrics, episode_metrics
from marl_social.sim.dynamics import DT_S

MAX_REPLAY_STEPS = 600  # the default step limit (60 s at 10 Hz)


@dataclass(frozen=True)
class ReplayRun:
    """What to replay.

    Attributes:
        map: a built-in map's name or a Lanelet2 .osm path (INTERACTION's maps: local x/y).
        tracks: the recording's vehicle_tracks_*.csv.
        max_steps: the episode's step limit (it also ends when every agent has left).
        seed: the env's and the robot's seed.
        overrides: further map_replay parameters (element, start_frame, robot_planner, ...).
    """

    map: str
    tracks: str
    max_steps: int = MAX_REPLAY_STEPS
    seed: int = 0
    overrides: dict = field(default_factory=dict)


@dataclass(frozen=True)
class ReplayResult:
    """One replayed episode.

    Attributes:
        metrics: the episode's and the belief's metrics (metrics/episode.py).
        trace: the episode's trace (belief in trace.extras).
        road_map: the scene's map.
        track_ids: {agent name: the recording's track id} of the replayed vehicles.
        late_vehicles: vehicles of the recording that enter after the replay's start.
        max_tracking_error_m: the largest distance of a replayed vehicle from its recorded
            position while it was in the episode [m].
        max_belief: the robot's largest belief in a hidden pedestrian (nan: none recorded).
    """

    metrics: dict
    trace: object
    road_map: object
    track_ids: dict
    late_vehicles: int
    max_tracking_error_m: float
    max_belief: float


def _tracking_error_m(trace, scene) -> float:
    """Largest distance [m] of a replayed vehicle from where the recording has it, while both are."""
    states = np.asarray(trace.states)
    active = np.asarray(trace.active)
    times = np.asarray(trace.times_s) - trace.times_s[0]
    worst = 0.0
    for spec, route, motion, _ in scene.replays:
        i = trace.names.index(spec.name)
        rows = active[:, i] & (times <= motion.t_s[-1])
        if not rows.any():
            continue
        s_rec = np.interp(times[rows], motion.t_s, motion.s_m)
        recorded = np.array([route.point_at_float(float(s)) for s in s_rec])
        worst = max(worst, float(np.max(np.hypot(*(states[rows, i, :2] - recorded).T))))
    return worst


def run_replay(run: ReplayRun) -> ReplayResult:
    """Replay `run`'s recording on its map with the robot planning (module docstring)."""
    env = parallel_env(scenario="map_replay", max_cycles=run.max_steps, map=run.map,
                       tracks=run.tracks, **run.overrides)
    scene = env.scenario
    mode = scene.params.robot_planner
    motions = scene.motions()
    pols = {}
    for name, spec in env.agent_specs.items():
        if name in motions:
            pols[name] = LogReplayPolicy(spec, env.obs_layout, env.road_map.for_agent(name),
                                         motions[name])
        else:
            pols[name] = make_policy(spec, env.obs_layout, env.road_map, env.possible_agents,
                                     mode)
    trace = record_robot_episode(env, pols, run.seed)
    metrics = episode_metrics(trace, env.road_map)
    metrics.update(belief_metrics(trace, env.road_map))
    env.close()
    belief = trace.extras.get("p_pedestrian")
    max_belief = float(np.nanmax(belief)) if belief is not None and np.isfinite(belief).any() \
        else float("nan")
    return ReplayResult(metrics, trace, env.road_map, scene.track_ids(), scene.late_vehicles,
                        _tracking_error_m(trace, scene), max_belief)


def replay_summary(run: ReplayRun, result: ReplayResult) -> str:
    """The few lines `marl-social replay` prints."""
    m = result.metrics
    steps = len(result.trace.times_s) - 1
    lines = [
        f"replay {run.tracks} on {run.map}",
        (f"  replayed:  {len(result.track_ids)} vehicles (tracks "
         + ", ".join(result.track_ids.values())
         + f"); {result.late_vehicles} enter later (not replayed)"),
        (f"  steps:     {steps} ({steps * DT_S:.1f} s); largest tracking error "
         f"{result.max_tracking_error_m:.2f} m"),
        "  robot:     " + ", ".join(f"{k}={_fmt(m[k])}" for k in (
            "robot_collision", "collision", "mean_speed_mps", "min_speed_mps",
            "max_decel_mps2", "yielded", "others_max_decel_mps2") if k in m),
        f"  belief:    max p_pedestrian {_fmt(result.max_belief)}",
    ]
    return "\n".join(lines)


def _fmt(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    return f"{float(value):.3g}"

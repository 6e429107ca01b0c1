"""`run_episode`: one seeded episode with every agent on its built-in planner.

It returns the episode's metrics and its per-step trace (states, actions, visibility, the
robot's beliefs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.agents.human import BoltzmannDriver
from marl_social.envs.parallel import parallel_env
from marl_social.envs.policies import policies, truth_tracks
from marl_social.evaluation.rollout import record_episode
from marl_social.metrics.episode import belief_metrics, episode_metrics
from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace


@dataclass
class EpisodeResult:
    """One episode's outcome.

    Attributes:
        metrics: dict of floats / bools (marl_social/metrics/).
        trace: the Trace, with extras "p_pedestrian", "perceived" and "p_<hypothesis>" for a
            belief-based robot.
        road_map: the episode's static map.
        specs: {agent: AgentSpec}, every agent's own parameters, incl. its true cost weights
            and rationality.
        decisions: {human: [(features, allowed, chosen), ...]}
            (agents/human.BoltzmannDriver.decisions) with record_human_decisions.
    """

    metrics: dict
    trace: Trace
    road_map: RoadMap
    specs: dict | None = None
    decisions: dict | None = None


class _RecordingRobot:
    """Wraps the robot's policy: feeds a `needs_truth` planner its truth, records the belief."""

    def __init__(self, env, name, policy, trace_extras: dict):
        self.env, self.name, self.policy, self.extras = env, name, policy, trace_extras

    def reset(self, seed=None):
        self.policy.reset(seed)
        self.extras.clear()

    def __call__(self, obs):
        if self.policy.needs_truth:
            self.policy.observe_truth(truth_tracks(self.env, self.name))
        action = self.policy(obs)
        belief = getattr(self.policy, "belief", None)
        if belief is not None and not self.policy.needs_truth:
            self.extras.setdefault("p_pedestrian", []).append(float(belief.p_pedestrian))
            self.extras.setdefault("perceived", []).append(float(belief.perceived))
            for h, p in zip(belief.hypotheses, belief.probabilities):
                self.extras.setdefault(f"p_{h.name}", []).append(float(p))
        return action


def run_episode(scenario: str = "occluded_crosswalk", seed: int = 0, render: bool = False,
                max_cycles: int = 200, record_human_decisions: bool = False,
                **overrides) -> EpisodeResult:
    """Run one episode with `marl_social.policies` and return its metrics and trace.

    The robot's planner comes from the `robot_planner` override.

    Args:
        scenario: a registered scenario name.
        seed: seeds the env (sensor noise) and every policy (Boltzmann sampling).
        render: also keep rgb frames in trace.frames.
        max_cycles: the episode's step limit.
        record_human_decisions: also keep every human driver's decisions (what its choice
            depends on, for agents/irl/choice.py; the episode itself is unchanged).
        overrides: scenario parameters (e.g. pedestrian="none", robot_planner="aggressive").
    """
    env = parallel_env(scenario=scenario, max_cycles=max_cycles,
                                   render_mode="rgb_array" if render else None, **overrides)
    pols = policies(env)
    humans = {a: p for a, p in pols.items() if isinstance(p, BoltzmannDriver)}
    for policy in humans.values():
        policy.record_decisions = record_human_decisions
    extras: dict = {}
    if "robot_0" in pols:
        pols["robot_0"] = _RecordingRobot(env, "robot_0", pols["robot_0"], extras)
    trace = record_episode(env, pols, seed=seed, render=render)
    # beliefs are recorded once per robot decision; align them with the T+1 states: the first
    # decision's value also stands at reset time, NaN once the robot has left the episode
    n_states = len(trace.times_s)
    trace.extras = {}
    for key, values in extras.items():
        if values:
            series = np.full(n_states, np.nan)
            aligned = [values[0], *values][:n_states]
            series[: len(aligned)] = aligned
            trace.extras[key] = series
    metrics = episode_metrics(trace, env.road_map)
    metrics.update(belief_metrics(trace, env.road_map))
    env.close()
    decisions = ({a: list(p.decisions) for a, p in humans.items()}
                 if record_human_decisions else None)
    return EpisodeResult(metrics, trace, env.road_map, dict(env.agent_specs), decisions)


def randomized_overrides(seed: int) -> dict:
    """The randomization of the paper's scenario used by `reproduce` and the claims tests.

    Pedestrian timing and speed, the human's lead and speed, and its rationality, drawn from
    a generator seeded with 10_000 + `seed`.
    """
    rng = np.random.default_rng(10_000 + seed)
    return {
        "pedestrian_start_delay_s": float(rng.uniform(0.5, 1.5)),
        "pedestrian_speed_mps": float(rng.uniform(1.1, 1.5)),
        "human_lead_m": float(rng.uniform(17.0, 23.0)),
        "human_speed_mps": float(rng.uniform(10.5, 12.5)),
        "human_beta": float(rng.uniform(3.0, 20.0)),
    }

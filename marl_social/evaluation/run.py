"""`run_episode`: one seeded episode with every agent on its built-in planner.

It returns the episode's metrics and its per-step trace (states, actions, visibility, the
robot's beliefs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.agents.human import BoltzmannDriver
from marl_social.envs.parallel import parallel_env
from marl_social.envs.policies import policies, truth_signal_phase, truth_tracks
from marl_social.evaluation.counterfactual import CounterfactualWarning, counterfactual_warning
from marl_social.evaluation.rollout import record_episode
from marl_social.metrics.episode import belief_metrics, episode_metrics
from marl_social.sim.road_map import RoadMap
from marl_social.sim.trace import Trace


@dataclass
class EpisodeResult:
    """One episode's outcome.

    Attributes:
        metrics: dict of floats / bools (marl_social/metrics/).
        trace: the Trace, with extras "mpc_infeasible" (1.0 where the robot's MPC found no
            feasible plan and braked as hard as it can), "mpc_surprise_infeasible" (1.0 where,
            besides, a comfortable stop one step earlier would have met the plan's bounds:
            MpcResult.surprise_infeasible) and "mpc_contingency_given_way" (1.0 where its plan
            was feasible only with a hidden car's bound given way to a comfortable stop:
            MpcResult.contingency_given_way) for an MPC robot, and "p_pedestrian",
            "p_vehicle" (belief in a hidden vehicle, `p_hidden("vehicle")`), "perceived" and
            "p_<hypothesis>" for a belief-based robot, and "phase_<phase>" (its belief in each
            signal phase; the oracle: the true phase) at a signalized junction.
        road_map: the episode's static map.
        specs: {agent: AgentSpec}, every agent's own parameters, incl. its true cost weights
            and rationality.
        decisions: {human: [(features, allowed, chosen), ...]}
            (agents/human.BoltzmannDriver.decisions) with record_human_decisions.
        warning: with counterfactual=True, the humans' warnings of the hidden agent against
            the same seed without it (evaluation/counterfactual.py; None: not asked for, or
            a scene that hides nothing); its numbers are also in metrics.
    """

    metrics: dict
    trace: Trace
    road_map: RoadMap
    specs: dict | None = None
    decisions: dict | None = None
    warning: CounterfactualWarning | None = None


class _RecordingRobot:
    """Wraps the robot's policy: feeds a `needs_truth` planner its truth, records the belief."""

    def __init__(self, env, name, policy, trace_extras: dict):
        self.env, self.name, self.policy, self.extras = env, name, policy, trace_extras

    def reset(self, seed=None):
        self.policy.reset(seed)
        self.extras.clear()

    def __call__(self, obs):
        if self.policy.needs_truth:
            self.policy.observe_truth(truth_tracks(self.env, self.name),
                                      signal_phase=truth_signal_phase(self.env))
        action = self.policy(obs)
        result = getattr(self.policy, "last_result", None)
        if result is not None:
            self.extras.setdefault("mpc_infeasible", []).append(float(not result.feasible))
            self.extras.setdefault("mpc_surprise_infeasible", []).append(
                float(result.surprise_infeasible))
            self.extras.setdefault("mpc_contingency_given_way", []).append(
                float(result.contingency_given_way))
        belief = getattr(self.policy, "belief", None)
        if belief is not None and not self.policy.needs_truth:
            self.extras.setdefault("p_pedestrian", []).append(float(belief.p_pedestrian))
            self.extras.setdefault("p_vehicle", []).append(float(belief.p_hidden("vehicle")))
            self.extras.setdefault("perceived", []).append(float(belief.perceived))
            for h, p in zip(belief.hypotheses, belief.probabilities):
                self.extras.setdefault(f"p_{h.name}", []).append(float(p))
        phase = getattr(self.policy, "phase_belief", None)
        if phase is not None:
            for name, p in zip(phase.phase_names, phase.probabilities):
                self.extras.setdefault(f"phase_{name}", []).append(float(p))
        return action


def record_robot_episode(env, pols: dict, seed: int, render: bool = False, until=None):
    """`record_episode` with robot_0's beliefs and MPC feasibility in the trace's extras.

    robot_0's policy (if any) is wrapped to record them (a `needs_truth` planner is fed its
    truth); they are recorded once per robot decision and aligned with the T+1 states: the
    first decision's value also stands at reset time, NaN once the robot has left the episode.

    Args:
        env: the parallel env.
        pols: {agent: policy} (robot_0's entry is replaced by its recording wrapper).
        seed: the episode's seed.
        render: as record_episode.
        until: as record_episode.
    """
    extras: dict = {}
    if "robot_0" in pols:
        pols["robot_0"] = _RecordingRobot(env, "robot_0", pols["robot_0"], extras)
    trace = record_episode(env, pols, seed=seed, render=render, until=until)
    n_states = len(trace.times_s)
    trace.extras = {}
    for key, values in extras.items():
        if values:
            series = np.full(n_states, np.nan)
            aligned = [values[0], *values][:n_states]
            series[: len(aligned)] = aligned
            trace.extras[key] = series
    return trace


def infeasible_steps(trace: Trace) -> dict[str, int]:
    """The robot's MPC's infeasible steps, the surprises among them, and its given-way steps.

    0 each without an MPC robot. mpc_infeasible_steps: steps its MPC found no feasible plan;
    surprise_infeasible_steps: of them, those where a comfortable stop one step earlier would
    have met the bounds that made the plan infeasible (MpcResult.surprise_infeasible);
    contingency_given_way_steps: steps whose plan was feasible only with a hidden car's bound
    given way to a comfortable stop (MpcResult.contingency_given_way).
    """
    return {name: int(np.nansum(trace.extras.get(key, 0.0)))
            for name, key in (("mpc_infeasible_steps", "mpc_infeasible"),
                              ("surprise_infeasible_steps", "mpc_surprise_infeasible"),
                              ("contingency_given_way_steps", "mpc_contingency_given_way"))}


def run_episode(scenario: str = "occluded_crosswalk", seed: int = 0, render: bool = False,
                max_cycles: int = 200, record_human_decisions: bool = False, until=None,
                counterfactual: bool = False, **overrides) -> EpisodeResult:
    """Run one episode with `marl_social.policies` and return its metrics and trace.

    The robot's planner comes from the `robot_planner` override.

    Args:
        scenario: a registered scenario name.
        seed: seeds the env (sensor noise) and every policy (Boltzmann sampling).
        render: also keep rgb frames in trace.frames.
        max_cycles: the episode's step limit.
        record_human_decisions: also keep every human driver's decisions (what its choice
            depends on, for agents/irl/choice.py; the episode itself is unchanged).
        until: None, or a condition `until(env) -> bool` that ends the episode at the first
            state where it holds (marl_social/evaluation/stopping.py); the trace and metrics
            are then those of the steps so far.
        counterfactual: also run the same seed, for as many steps, with the scenario's hidden
            agent removed (`Scenario.hidden_agent().absent`) and report when each human's
            speed first departed from that run's (EpisodeResult.warning and the metrics
            warning_lead_s, first_warned_s, robot_first_sees_hidden_s, human_warned_s_<name>;
            evaluation/counterfactual.py). The episode itself is unchanged.
        overrides: scenario parameters (e.g. pedestrian="none", robot_planner="aggressive").
    """
    env = parallel_env(scenario=scenario, max_cycles=max_cycles,
                                   render_mode="rgb_array" if render else None, **overrides)
    pols = policies(env)
    humans = {a: p for a, p in pols.items() if isinstance(p, BoltzmannDriver)}
    for policy in humans.values():
        policy.record_decisions = record_human_decisions
    trace = record_robot_episode(env, pols, seed, render=render, until=until)
    metrics = episode_metrics(trace, env.road_map)
    metrics.update(belief_metrics(trace, env.road_map))
    hidden = env.scenario.hidden_agent() if counterfactual else None
    env.close()
    decisions = ({a: list(p.decisions) for a, p in humans.items()}
                 if record_human_decisions else None)
    warning = None
    if hidden is not None:
        without = run_episode(scenario, seed=seed, max_cycles=max(len(trace.times_s) - 1, 1),
                              **{**overrides, **hidden.absent})
        warning = counterfactual_warning(trace, without.trace, hidden)
        metrics.update(warning.as_metrics())
    return EpisodeResult(metrics, trace, env.road_map, dict(env.agent_specs), decisions,
                         warning)


RANDOMIZATIONS: dict[str, dict[str, tuple[float, float]]] = {
    # the occluded crosswalk (occluded_crosswalk, paper Fig. 2):
    # the whole plausible range: slow to brisk walkers, hesitant to prompt starts, a human
    # close or far ahead, slow or fast, erratic or near-rational
    "wide": {
        "pedestrian_start_delay_s": (0.0, 3.0),
        "pedestrian_speed_mps": (0.5, 2.0),
        "human_lead_m": (10.0, 30.0),
        "human_speed_mps": (8.0, 14.0),
        "human_beta": (2.0, 30.0),
    },
    # close to the paper's Fig. 2 numbers (the randomization before "wide"; the default)
    "paper": {
        "pedestrian_start_delay_s": (0.5, 1.5),
        "pedestrian_speed_mps": (1.1, 1.5),
        "human_lead_m": (17.0, 23.0),
        "human_speed_mps": (10.5, 12.5),
        "human_beta": (3.0, 20.0),
    },
    # the T-intersection (t_intersection, paper Fig. 1 b) over its whole plausible range: the
    # hidden car V3 slow to brisk, starting near (the left-turners must wait for it) or far
    # (they need not); one to three left-turners, starting close to or far from their turn,
    # slow or prompt, erratic or near-rational; narrow to wide gaps between the parked cars
    "t_intersection": {
        "hidden_speed_mps": (9.0, 14.0),
        "hidden_near_m": (30.0, 45.0),
        "hidden_far_m": (110.0, 160.0),
        "human_start_m": (6.0, 20.0),
        "human_speed_mps": (3.0, 8.0),
        "human_beta": (2.0, 30.0),
        "parked_gap_m": (0.5, 2.0),
        "n_humans": (1, 3),
    },
    # the signalized intersection (signalized_intersection, paper Fig. 1 c) over its whole
    # plausible range: one or two cross cars, close to or far from their line, slow to fast,
    # short or long gaps; one to three left-turners a little or well behind their line, erratic
    # or near-rational; the phase just begun or running for a while; the robot at its line or
    # a few metres back
    "signalized_intersection": {
        "cross_speed_mps": (9.0, 14.0),
        "cross_start_m": (30.0, 60.0),
        "cross_gap_m": (12.0, 25.0),
        "human_start_m": (2.0, 8.0),
        "human_beta": (2.0, 30.0),
        "phase_elapsed_s": (0.0, 2.0),
        "robot_start_back_m": (0.0, 3.0),
        "n_humans": (1, 3),
        "n_cross": (1, 2),
    },
}
INTEGER_KNOBS = frozenset({"n_humans", "n_cross"})  # drawn uniformly from the integers lo..hi
# the preset recordings and studies randomize a scenario with (scenarios not listed: none)
SCENARIO_PRESETS = {"occluded_crosswalk": "paper", "t_intersection": "t_intersection",
                    "signalized_intersection": "signalized_intersection"}


def randomized_overrides(seed: int, preset: str = "paper") -> dict:
    """A randomization of a scenario ("wide": `reproduce` and the claims tests).

    Each knob uniform over the preset's range (RANDOMIZATIONS; the integers of INTEGER_KNOBS
    uniform over lo..hi), drawn in that order from a generator seeded with 10_000 + `seed`.
    The occluded crosswalk's presets: pedestrian timing [s] and speed [m/s], the human's lead
    [m] and speed [m/s], and its rationality. "t_intersection": V3's speed [m/s] and start
    distances [m], the left-turners' start [m], speed [m/s], rationality and number, the gap
    between the parked cars [m]. "signalized_intersection": the cross traffic's speed [m/s],
    start and gap [m] and number, the left-turners' start [m], rationality and number, the
    time spent in the phase [s], the robot's start [m].

    Args:
        seed: the episode's seed.
        preset: a key of RANDOMIZATIONS ("wide": the whole plausible range; "paper", the
            default for the studies and recordings that used it before "wide" existed: narrow,
            around the paper's numbers).

    Raises:
        ValueError: an unknown preset.
    """
    if preset not in RANDOMIZATIONS:
        raise ValueError(f"randomization preset {preset!r}: must be one of "
                         f"{tuple(RANDOMIZATIONS)}")
    rng = np.random.default_rng(10_000 + seed)
    return {key: (int(rng.integers(lo, hi + 1)) if key in INTEGER_KNOBS
                  else float(rng.uniform(lo, hi)))
            for key, (lo, hi) in RANDOMIZATIONS[preset].items()}



def scenario_randomized_overrides(seed: int, scenario: str) -> dict:
    """The randomization recordings and studies start from: the scenario's own preset.

    `randomized_overrides(seed, SCENARIO_PRESETS[scenario])` (the occluded crosswalk's
    "paper", each intersection's own range); {} for a scenario without a preset (long_road).

    Args:
        seed: the episode's seed.
        scenario: a scenario name.
    """
    preset = SCENARIO_PRESETS.get(scenario)
    return randomized_overrides(seed, preset) if preset is not None else {}

def interaction_timings(result: EpisodeResult, robot: str = "robot_0", human: str = "human_0",
                        pedestrian: str = "pedestrian_0", brake_mps2: float = 1.0) -> dict:
    """When the human brakes, the pedestrian leaves the robot's lane and the robot goes again.

    Args:
        result: an occluded_crosswalk episode.
        robot: the robot's name.
        human: the human driver's name.
        pedestrian: the pedestrian's name.
        brake_mps2: a deceleration at least this strong counts as braking [m/s^2].

    Returns:
        human_sees_pedestrian_s: first time the human sees the pedestrian (nan: never) [s];
        human_brakes_s: first time the human brakes for the pedestrian: at or after it first
            sees it, and below its own cruise speed (`AgentSpec.v_desired_mps`: a human
            starting faster than that first slows down to it, which tells the robot nothing of
            the pedestrian; nan: never) [s];
        pedestrian_clears_lane_s: first time the pedestrian, having been in the robot's lane
            (within half a lane width plus its radius of the robot's route), is out of it and
            walking away (nan: never) [s];
        robot_moves_again_s: first time at or after pedestrian_clears_lane_s at which the robot
            accelerates by at least 0.3 m/s^2 or is above 95 % of its speed at that moment
            when that speed is above 2 m/s (nan: never, or no clearing) [s].
    """
    trace, road_map = result.trace, result.road_map
    times = np.asarray(trace.times_s)
    states = np.asarray(trace.states)
    accel = np.asarray(trace.accel_mps2)
    out = {"human_sees_pedestrian_s": np.nan, "human_brakes_s": np.nan,
           "pedestrian_clears_lane_s": np.nan, "robot_moves_again_s": np.nan}
    if pedestrian not in trace.names:
        return out
    if human in trace.names:
        h = trace.index(human)
        seen = np.flatnonzero(np.asarray(trace.visible)[:, h, trace.index(pedestrian)])
        if len(seen):
            out["human_sees_pedestrian_s"] = float(times[seen[0]])
            cruise = (result.specs[human].v_desired_mps
                      if result.specs and human in result.specs else np.inf)
            # accel[k] is applied from state k to k + 1: braking at k is seen at time k + 1
            braking = np.flatnonzero((accel[seen[0]:, h] <= -brake_mps2)
                                     & (states[seen[0]:-1, h, 3] < cruise))
            if len(braking):
                out["human_brakes_s"] = float(times[seen[0] + braking[0] + 1])
    route = road_map.routes[robot]
    p = trace.index(pedestrian)
    _, lateral, _ = route.project(states[:, p, :2])
    lane_width = min((lane.width_m for lane in road_map.lanes), default=3.5)
    in_lane = np.abs(lateral) <= 0.5 * lane_width + float(trace.bounding_radius_m[p])
    entered = np.flatnonzero(in_lane)
    if not len(entered):
        return out
    after = np.flatnonzero(~in_lane[entered[0]:])
    if not len(after):
        return out
    k = entered[0] + after[0]
    out["pedestrian_clears_lane_s"] = float(times[k])
    r = trace.index(robot)
    v_clear = states[k, r, 3]
    for j in range(k, len(accel)):
        if accel[j, r] >= 0.3 or (v_clear > 2.0 and states[j, r, 3] >= 0.95 * v_clear):
            out["robot_moves_again_s"] = float(times[j])
            break
    return out


def claim_episode(job: tuple) -> tuple:
    """One episode for the claims tests: (planner, variant, seed, metrics + timings, error).

    Args:
        job: (planner, variant, seed, max_cycles, overrides[, until[, counterfactual]]); the
            overrides go on top of randomized_overrides(seed) (the "wide" preset); until: a
            class of marl_social/evaluation/stopping.py (or any zero-argument factory of a
            condition), built afresh for the episode, which ends it once the condition holds;
            counterfactual: also the humans' warning (run_episode's counterfactual: the
            metrics warning_lead_s, ...).
    """
    planner, variant, seed, max_cycles, extra, *rest = job
    try:
        until = rest[0]() if rest and rest[0] is not None else None
        counterfactual = bool(rest[1]) if len(rest) > 1 else False
        res = run_episode("occluded_crosswalk", seed=seed, robot_planner=planner,
                          pedestrian=variant, max_cycles=max_cycles, until=until,
                          counterfactual=counterfactual,
                          **{**randomized_overrides(seed, "wide"), **extra})
        summary = {**res.metrics, **interaction_timings(res)}
        summary.update(infeasible_steps(res.trace))
        return planner, variant, seed, summary, None
    except Exception as err:  # noqa: BLE001  (reported by the caller)
        return planner, variant, seed, None, f"{type(err).__name__}: {err}"

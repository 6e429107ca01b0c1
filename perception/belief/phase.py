"""The signal phase as a discrete social variable: b(phase) from the robot's own head and the humans.

The robot knows the junction's signal plan (sim/signals.SignalPlan: the phases, the state of
every head in each, their durations) from the static map, but not where in the cycle the
controller is. Its belief over the P phases is a hidden Markov model (Algorithm 1's order):

* prediction: a phase of duration D ends in a step of dt with probability dt / D and hands over
  to the next one (`phase_transition`); the prior is the share of the cycle each phase takes;
* its own head (the only one it reads, through its observation): a phase in which that head
  would show another state than the one seen is ruled out (log-likelihood -inf);
* social evidence (eq. 9-10, 12): every human driver it tracks that has a signal line ahead on
  its lane path (paths.LanePaths, sim/signal_rules.route_signal_lines) is modelled with the
  robot's own model of a human (theta_hat, beta_hat; the same `SocialLikelihood` scene and noise
  model as the hidden-agent belief) on each phase hypothesis: in phase p its head shows
  state_p, and it stops at its line if `must_stop(state_p, v, d)` (a stop-line constraint in
  its Q*, models/driver.RoadRules), else it drives on. The acceleration observed one step later
  is scored with `action_log_likelihood` (heavy-tailed kernel, clipped by max_log_likelihood_ratio);
  humans multiply (eq. 12).

A human the robot cannot expect to read its head (outside the view the robot assumes a human
has, BeliefConfig.human_range_m and human_half_fov_rad, behind the head's visor, or with another
tracked car on the line of sight: `human_sees_head`) acts on what it saw before, which the robot
does not know: its action is not scored.

So left-turners accelerating from their line into the turn are evidence for a phase that shows
them green (a protected left, in which the cross traffic has red); cross traffic braking
towards its line for one that shows it red; cross traffic holding its speed close to its line
for its green. The robot never reads the world's signal state: only its observation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from marl_social.models.candidates import PlanningEgo, Surroundings
from marl_social.models.driver import RoadRules, rule_abiding_totals
from marl_social.models.gap_evaluation import vehicle_gap_evaluation
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.belief.action_model import (
    action_log_likelihood,
    bounded_log_likelihood,
)
from marl_social.perception.belief.bayes import bayes_step
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.paths import LanePaths
from marl_social.perception.belief.social import SocialLikelihood
from marl_social.perception.tracking import TrackSet
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import DecodedObservation
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.signal_rules import must_stop, route_signal_lines
from marl_social.sim.signals import SignalPlan

# a human's action is scored once its track has been measured this many steps (fewer than
# BeliefConfig.min_track_steps: a left-turner starting from rest a few metres before its line
# crosses it within about a second, and waiting longer would lose most of what it tells)
PHASE_MIN_TRACK_STEPS = 3


def phase_transition(plan: SignalPlan, dt_s: float) -> np.ndarray:
    """(P, P) column-stochastic: phase j ends within dt_s with probability dt_s / D_j.

    Args:
        plan: the signal plan (phase durations D_j [s], in cycle order).
        dt_s: the step [s].
    """
    n = len(plan.phases)
    leave = np.minimum(dt_s / plan.durations_s, 1.0)
    mat = np.diag(1.0 - leave)
    mat[(np.arange(n) + 1) % n, np.arange(n)] += leave
    return mat


@dataclass
class _Human:
    """What the robot predicted for one tracked human last step.

    Attributes:
        v_mps: its along-path speed [m/s].
        q_values: (P, A) Q*_H of its first actions under each phase hypothesis; None when the
            next step cannot score its action (its track too young, or it cannot read its head).
        actions_mps2: (A,) the accelerations they execute as [m/s^2].
        n_seen: consecutive steps it has been tracked.
        sees_head: the robot expected it to read its head (`human_sees_head`).
    """

    v_mps: float
    q_values: np.ndarray | None
    actions_mps2: np.ndarray
    n_seen: int
    sees_head: bool = True


@dataclass(frozen=True)
class SignalledCar:
    """A tracked car with a signal line ahead on its lane path.

    Attributes:
        row: its row in the TrackSet.
        route: its lane path (paths.LanePaths).
        s_m: its arc length along it [m].
        v_mps: its along-path speed [m/s].
        line_s_m: the line's arc length [m].
        head: index into RoadMap.signal_heads of the head controlling the line.
        length_m: its length [m].
    """

    row: int
    route: Route
    s_m: float
    v_mps: float
    line_s_m: float
    head: int
    length_m: float

    @property
    def to_line_m(self) -> float:
        """From its front bumper to the line [m]."""
        return self.line_s_m - self.s_m - 0.5 * self.length_m


def signalled_cars(lane_paths: LanePaths, road_map: RoadMap, tracks: TrackSet
                   ) -> list[SignalledCar]:
    """The tracked, seen vehicles whose lane path has a signal line ahead of their front.

    Args:
        lane_paths: the map's lane paths.
        road_map: the static map (stop lines, signal heads).
        tracks: the robot's tracks.
    """
    out = []
    for k in range(len(tracks)):
        if tracks.is_pedestrian[k] or not tracks.seen[k]:
            continue
        route = lane_paths.route_of(tracks.xy[k], float(tracks.heading_rad[k]))
        if route is None:
            continue
        lines, heads = lane_paths.signal_lines(route, road_map)
        s0, _ = route.project_point(float(tracks.xy[k, 0]), float(tracks.xy[k, 1]))
        half = 0.5 * float(tracks.length_m[k])
        ahead = np.flatnonzero(lines > s0 + half)
        if not len(ahead):
            continue
        _, heading = route.point_at(s0)
        d = np.array([math.cos(float(heading)), math.sin(float(heading))])
        v = float(tracks.velocity[k] @ d)
        j = int(ahead[0])
        out.append(SignalledCar(k, route, s0, v, float(lines[j]), int(heads[j]),
                                float(tracks.length_m[k])))
    return out


def stops_per_phase(head_states: np.ndarray, car: SignalledCar) -> np.ndarray:
    """(P,) bool: whether the car must stop at its line in each phase (sim/signal_rules).

    Args:
        head_states: (P, H) the state of every head in every phase.
        car: the car.
    """
    return np.array([must_stop(int(s), max(car.v_mps, 0.0), car.to_line_m)
                     for s in head_states[:, car.head]])


def human_sees_head(car: SignalledCar, tracks: TrackSet, head, range_m: float,
                    half_fov_rad: float) -> bool:
    """Whether the robot expects a tracked human to read its head now.

    The head within range_m and half_fov_rad of the human's heading, the human within the
    head's visor, and no other track's bounding circle on the segment between them.

    Args:
        car: the human's car.
        tracks: the robot's tracks (car.row is the human).
        head: the SignalHead controlling its line.
        range_m: the range the robot assumes a human sees [m].
        half_fov_rad: the half-angle of the view it assumes [rad].
    """
    start = np.asarray(tracks.xy[car.row], dtype=np.float64)
    rel = head.position - start
    dist = float(np.hypot(*rel))
    bearing = math.atan2(rel[1], rel[0])
    wrap = lambda a: abs((a + math.pi) % (2.0 * math.pi) - math.pi)
    if (dist > range_m or wrap(bearing - float(tracks.heading_rad[car.row])) > half_fov_rad
            or wrap(bearing + math.pi - head.facing_rad) > head.view_half_angle_rad):
        return False
    others = np.arange(len(tracks)) != car.row
    centres = tracks.xy[others]
    radius = 0.5 * np.hypot(tracks.length_m[others], tracks.width_m[others])
    t = np.clip((centres - start) @ rel / max(dist * dist, 1e-12), 0.0, 1.0)
    gap = np.linalg.norm(start + t[:, None] * rel - centres, axis=1)
    return not bool(np.any(gap < radius))


class SignalPhaseBelief:
    """b(phase) over the map's signal plan (module docstring).

    Args:
        road_map: the static map the robot may know (signal plan and heads, lanes, its route).
        robot_name: the robot's agent name (its route: the heads it obeys).
        social: the hidden-agent belief's SocialLikelihood (the robot's model of a human, the
            scene it assumes a human reacts to, the noise of its acceleration estimates).
        config: BeliefConfig (floor, beta_hat, tail_dof, max_log_likelihood_ratio, the
            view it assumes a human has).
        use_social: fold in the humans' behaviour (else only its own head).

    Attributes:
        phase_names: the P phases, in cycle order.
        probabilities: (P,) the current belief.
        head_states: (P, H) what every head shows in every phase.
        own_heads: the heads controlling the robot's own signal lines.
        last_log_likelihoods: this step's (P,) log-likelihoods, "own" and "social".
    """

    def __init__(self, road_map: RoadMap, robot_name: str, social: SocialLikelihood,
                 config: BeliefConfig, use_social: bool = True):
        plan = road_map.signal_plan
        if plan is None:
            raise ValueError(f"robot {robot_name!r}: the map has no signal plan")
        self.road_map = road_map
        self.plan = plan
        self.phase_names = tuple(p.name for p in plan.phases)
        self.head_states = plan.head_states(road_map.signal_heads)
        self.transition = phase_transition(plan, DT_S)
        self.prior = plan.durations_s / plan.cycle_s
        route = road_map.routes.get(robot_name)
        self.own_heads = (tuple(int(h) for h in route_signal_lines(route, road_map)[1])
                          if route is not None else ())
        self.social = social
        self.config = config
        self.use_social = bool(use_social)
        self.lane_paths = social.lane_paths
        self._model = social.model
        self.reset()

    def reset(self) -> None:
        """Back to the prior; forget the tracked humans."""
        self.probabilities = self.prior.copy()
        self._humans: dict[int, _Human] = {}
        self.last_log_likelihoods: dict = {}

    def probability(self, name: str) -> float:
        """The belief in the phase called `name`."""
        return float(self.probabilities[self.plan.phase_index(name)])

    def set_phase(self, index: int) -> None:
        """Know the phase for certain (the oracle's privileged input)."""
        self.probabilities = np.eye(len(self.phase_names))[int(index)]

    def own_log_likelihood(self, decoded: DecodedObservation) -> np.ndarray:
        """(P,) 0 where the phase shows the robot's own heads as seen, -inf elsewhere."""
        ll = np.zeros(len(self.phase_names))
        for head, state in decoded.signal_states().items():
            if head in self.own_heads:
                ll[self.head_states[:, head] != state] = -np.inf
        return ll

    def update(self, decoded: DecodedObservation, tracks: TrackSet,
               v_desired_mps: float) -> np.ndarray:
        """Fold in one step: prediction, the robot's own head, the humans; returns (P,).

        Args:
            decoded: the robot's decoded observation.
            tracks: its current tracks.
            v_desired_mps: the speed it assumes a human wants [m/s] (its traffic belief).
        """
        ll_own = self.own_log_likelihood(decoded)
        sources = [ll_own]
        if self.use_social:
            sources += self._social_log_likelihoods(decoded, tracks, v_desired_mps)
        self.probabilities = bayes_step(self.probabilities, np.array(sources), self.transition,
                                        self.config.floor)
        social = np.sum(sources[1:], axis=0) if len(sources) > 1 else np.zeros_like(ll_own)
        self.last_log_likelihoods = {"own": ll_own, "social": social}
        return self.probabilities.copy()

    def _social_log_likelihoods(self, decoded: DecodedObservation, tracks: TrackSet,
                                v_desired_mps: float) -> list[np.ndarray]:
        """(P,) log P(a_obs | phase) of every human seen this step and the last (eq. 10)."""
        cfg = self.config
        out, current = [], {}
        model = replace(self._model, v_desired_mps=float(v_desired_mps))
        for car in signalled_cars(self.lane_paths, self.road_map, tracks):
            oid = int(tracks.ids[car.row])
            prev = self._humans.get(oid)
            a_est, n_seen = 0.0, 1
            sees = human_sees_head(car, tracks, self.road_map.signal_heads[car.head],
                                   cfg.human_range_m, cfg.human_half_fov_rad)
            if prev is not None:
                a_est, n_seen = (car.v_mps - prev.v_mps) / DT_S, prev.n_seen + 1
                if n_seen > PHASE_MIN_TRACK_STEPS and prev.sees_head and sees:
                    _, heading = car.route.point_at(car.s_m)
                    sigma = self.social.scoring.observation_sigma_mps2(tracks, car.row,
                                                                       float(heading))
                    ll = action_log_likelihood(prev.q_values, cfg.beta_hat, a_est,
                                               prev.actions_mps2, sigma, cfg.tail_dof)
                    out.append(bounded_log_likelihood(ll, cfg.max_log_likelihood_ratio))
            q = None  # the next step scores it only if it reads its head now and then, and
            if n_seen >= PHASE_MIN_TRACK_STEPS and sees:  # from PHASE_MIN_TRACK_STEPS + 1 on
                q = self._q_values(model, car, a_est, decoded, tracks)
            current[oid] = _Human(car.v_mps, q, self._executed(max(car.v_mps, 0.0)), n_seen,
                                  sees)
        self._humans = current
        return out

    def _q_values(self, model, car: SignalledCar, prev_accel: float,
                  decoded: DecodedObservation, tracks: TrackSet) -> np.ndarray:
        """(P, A) Q*_H of the car's first actions under each phase: stop at its line or not."""
        xy, heading = car.route.point_at(car.s_m)
        others = self.social.prediction.scenes.others_scene(np.asarray(xy), float(heading),
                                          int(tracks.ids[car.row]), decoded, tracks)
        scene = others if others is not None else self._empty_scene()
        v0 = max(car.v_mps, 0.0)
        curve = self.social.prediction.curve_speed(car.route)
        ev = vehicle_gap_evaluation(
            PlanningEgo(model.candidates, model.theta.as_array(), model.v_desired_mps,
                        model.vehicle, car.route, car.s_m, v0, prev_accel),
            Surroundings(scene, self.road_map.crosswalks, curve_speed=curve))
        q_go = rule_abiding_totals(ev, model, car.s_m, RoadRules(None, (), curve))[0]
        q_stop = rule_abiding_totals(ev, model, car.s_m, RoadRules(car.line_s_m, (), curve))[0]
        stops = stops_per_phase(self.head_states, car)
        return np.where(stops[:, None], q_stop.min(axis=-1)[None], q_go.min(axis=-1)[None])

    def _empty_scene(self) -> ScenePrediction:
        """A one-hypothesis scene without objects."""
        n_t = len(self._model.plan_times_s)
        return ScenePrediction(np.zeros((1, 0, n_t, 2)), np.zeros((1, 0, n_t)), np.zeros((1, 0)),
                               np.zeros((1, 0)), np.zeros((1, 0)), np.zeros((1, 0), bool),
                               np.zeros((1, 0), bool))

    def _executed(self, v0: float) -> np.ndarray:
        """(A,) accelerations the candidate first actions execute as at speed v0 [m/s^2]."""
        veh = self._model.vehicle
        first = np.asarray(self._model.first_actions_mps2, dtype=np.float64)
        a = np.clip(first, -veh.brake_max_mps2, veh.accel_max_mps2)
        return np.maximum(a, -v0 / DT_S)

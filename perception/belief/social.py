"""Social information: a human driver's observed action as evidence (eq. 9-12).

`SocialLikelihood` follows every tracked human driver step to step and puts three jobs
together, each in a module of its own: predicting its Q-values under every hypothesis
(human_prediction.HumanPrediction, eq. 11), scoring the action it was then seen to take
(action_scoring.ActionScoring, eq. 9-10) and the belief over its rationality
(rationality.RationalityBelief).

Each human driver the robot tracks is a sensor. The robot predicts the human's action
distribution under every (hidden-agent hypothesis l, traffic speed v) with its model of the human
(theta_hat, beta_hat; eq. 8 and 11) and, one step later, weighs the acceleration it observed:

    P(a_obs | x_l, v) = sum_u softmax(-beta_hat Q*_H(x_l, v, .))[u] t_nu(a_obs - u; sigma)

(`action_log_likelihood`; the normal kernel, nu = inf, is the paper's eq. 10); humans multiply
(eq. 12). Robust, so that one noisy sample cannot flip the belief:

* sigma^2 = accel_noise_mps2^2 (the human's own execution noise) + the variance of the robot's
  own estimate of the human's acceleration, from its Kalman filter
  (`TrackSet.velocity_change_cov` / dt^2; `ActionScoring.observation_sigma_mps2`): a robot
  with a noisier sensor trusts each sample less;
* the kernel t_nu is heavy-tailed (BeliefConfig.tail_dof): what the model does not predict
  (an emergency stop, a glitch) still points, by a bounded factor, at the hypotheses whose
  actions lie nearest to it;
* each observation's log-likelihood is clipped to max_log_likelihood_ratio below its maximum
  (`bounded_log_likelihood`): one observation moves the log-odds between any two sets of
  hypotheses by at most BeliefConfig.max_log_likelihood_ratio nats (4 by default: a factor
  55).

The traffic speed v_traffic is one unknown of the episode (BeliefConfig.traffic_hazard_per_s,
0 by default), and each human's speed when its track first counts is evidence about it
(N(v_i; v_traffic, cruise_speed_std_mps^2), `cruise_log_likelihood`): a human who brakes hard
is then not explained by a flow that has just slowed down or by one far below the speed it was
seen driving at.

Modelling choices of `SocialLikelihood`:

* The human sees the hypothesised pedestrian, a hypothesised vehicle (kind "vehicle": a car's
  footprint driving along its lane, so the human's Q* keeps it out of collision) if it lies in
  an assumed forward field of view of the human (`BeliefConfig.human_range_m`,
  `human_half_fov_rad`), and, besides it, the objects the robot tracks, and the robot
  itself, that lie in that view, predicted at constant velocity. A human who waits at a
  conflict for a hypothesised vehicle it can see is then evidence for that vehicle.
* The human's desired speed is v_traffic (marginalized with the traffic-speed belief).
* a_obs is estimated from the robot's own Kalman track (along-route speed difference over one
  step); candidate accelerations are compared with a_obs after the vehicle's limits (no
  reversing: an action u at speed v executes as max(u, -v/dt)).
* The robot knows the human's speed only as well as its track does: the model is averaged
  over that estimate, Q*_H from three speeds (Gauss-Hermite nodes of the track's velocity std
  along the route, `ActionScoring.speed_std_mps`; BeliefConfig.marginalize_speed) with the
  scene and its hypotheses built once (models/gap_evaluation.vehicle_gap_evaluations), the
  action probabilities averaged (action_model.speed_averaged_log_likelihood). A human's best
  action can change across ~0.1 m/s (whether it can still make its curve speed, or stop
  before a crosswalk): evaluated at the estimate alone, a left-turner braking for its curve
  read one step as the full bound's evidence for a hidden car.
* Q*_H is computed once per human and step for all L hypotheses with one batched candidate
  evaluation (`models.candidates.evaluate_candidates`, the function `driver_q_values` wraps)
  without the speed feature; the speed feature theta_speed (v - v_ref)^2 (per planner step, in
  simulator-step units) is then added for each v_traffic. That gives exactly
  `driver_q_values(DriverModel(v_desired_mps=v))` for every (l, v) from a single rollout
  (tests/perception/belief/test_social.py checks the equality).
* The human keeps the right of way like the simulated drivers (models/driver.RoadRules): in a
  conflict zone its route yields at, a car on one of the zone's priority lanes -- tracked, or
  the hypothesised one -- that claims the zone adds the conflict cost
  (`HumanPrediction.yield_zones`). A left-turner waiting before the lane it crosses is then
  explained by a hypothesised car coming along that lane. It also keeps to the curve speed of
  its path's bends (human_prediction.HUMAN_CURVE_LAT_ACCEL_MPS2; `rule_abiding_totals`), so slowing for a turn
  is not read as giving way. Stop lines are left out: the robot cannot know whether a human
  has already stopped at one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from marl_social.perception.belief.action_scoring import ActionScoring
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.human_prediction import HumanPrediction
from marl_social.perception.belief.hypotheses import Hypothesis
from marl_social.perception.belief.paths import LanePaths, route_pose
from marl_social.perception.belief.rationality import RationalityBelief
from marl_social.perception.tracking import TrackSet
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import DecodedObservation
from marl_social.sim.road_map import RoadMap


@dataclass
class _HumanState:
    """What the robot remembers of one tracked human until the next step.

    Attributes:
        v_mps: its along-route speed [m/s].
        q_values: (L, V, A) Q*_H of its candidate actions, or (3, L, V, A) from the speeds
            about the robot's estimate of its speed (`speed_std_mps`, action_model.
            speed_nodes_mps); None while its track is too young
            for the next step to score its action (n_seen < BeliefConfig.min_track_steps).
        actions_mps2: (A,) accelerations they execute as [m/s^2].
        n_seen: consecutive steps its track has been measured.
        beta_belief: (B,) belief over its rationality on BeliefConfig.beta_grid_hat (empty
            when beta is fixed).
    """

    v_mps: float
    q_values: np.ndarray | None
    actions_mps2: np.ndarray
    n_seen: int = 1
    beta_belief: np.ndarray = field(default_factory=lambda: np.zeros(0))


class SocialLikelihood:
    """The likelihood of the tracked human drivers' observed actions (module docstring).

    Every tracked vehicle driving in one of the map's lanes is a human driver, modelled along
    that lane (paths.LanePaths: inferred from its track, never from a name or another agent's
    route).

    Args:
        road_map: the static map (crosswalks and lanes).
        agent_names: names of object ids for the debugging outputs (object id k is
            agent_names[k - 1] if given; else "object_<k>"); never used to find humans.
        hypotheses: the L hidden-agent hypotheses (pedestrians and vehicles).
        traffic_grid_mps: (V,) traffic speeds of the traffic-speed belief [m/s].
        config: BeliefConfig (theta_hat, beta_hat, beta_grid_hat, accel_noise_mps2, ...).

    Attributes:
        prediction: the humans' Q-values per hypothesis (HumanPrediction; its `model` is
            DriverModel(theta_hat, beta_hat), the robot's model of a human, eq. 8, 11).
        scoring: the likelihood of an observed action (ActionScoring).
        rationality: the rationality grid and its update (RationalityBelief).
        lane_paths: the map's lane paths (a tracked car's lane, from its track).
    """

    def __init__(self, road_map: RoadMap, agent_names: list[str], hypotheses: list[Hypothesis],
                 traffic_grid_mps: np.ndarray, config: BeliefConfig):
        self.agent_names = list(agent_names)
        self.hypotheses = hypotheses
        self.traffic_grid_mps = np.ascontiguousarray(traffic_grid_mps, dtype=np.float64)
        self.config = config
        self.lane_paths = LanePaths(road_map)
        self.prediction = HumanPrediction(road_map, hypotheses, self.traffic_grid_mps, config)
        self.scoring = ActionScoring(config)
        self.rationality = RationalityBelief(config)
        self._vehicle = np.array([h.kind == "vehicle" for h in hypotheses])
        self.reset()

    @property
    def model(self):
        """The robot's model of a human (DriverModel(theta_hat, beta_hat), eq. 8, 11)."""
        return self.prediction.model

    def reset(self) -> None:
        """Forget every tracked human (call at every episode start)."""
        self._humans: dict[int, _HumanState] = {}

    def beta_beliefs(self) -> dict:
        """{human name: (B,) belief over its rationality on config.beta_grid_hat}.

        For the humans tracked now (social+beta only; empty otherwise).
        """
        if not self.rationality.inferred:
            return {}
        return {self.object_name(oid): h.beta_belief.copy() for oid, h in self._humans.items()}

    def object_name(self, object_id: int) -> str:
        """Name of an object id in the debugging outputs: its agent name if known."""
        if 1 <= object_id <= len(self.agent_names):
            return self.agent_names[object_id - 1]
        return f"object_{object_id}"

    def log_likelihoods(self, decoded: DecodedObservation, tracks: TrackSet,
                        predicted: np.ndarray):
        """Eq. 9-10 and 12 for every tracked human seen this step and the last.

        The action distribution predicted at the previous step is scored with the acceleration
        observed since; then each human's Q-values are predicted for the next step.

        Args:
            decoded: the robot's decoded observation.
            tracks: the robot's current tracks.
            predicted: (L, V) predicted joint belief b(l, v) (updates the rationality beliefs).

        Returns:
            (S, L, V) log-likelihoods of S independent sources -- log P(a_obs,i | x_l, v) of each
            human whose action was scored, and the cruising-speed evidence of each human whose
            track counts for the first time (`cruise_log_likelihood`, the same for every l) --
            and {human name: a_obs [m/s^2]}.
        """
        cfg = self.config
        out, a_obs_all = [], {}
        current = {}
        negligible = None
        if self.prediction.has_vehicles:
            # hidden vehicles the belief all but rules out are left out of the humans' scenes
            # (their belief stays negligible whatever the humans do; the likelihood is that of
            # "none")
            negligible = self._vehicle & (predicted.sum(axis=1) < cfg.vehicle_negligible_mass)
        cars = np.flatnonzero(tracks.seen & ~tracks.is_pedestrian).tolist()
        ids, xy_all, heading_all = tracks.ids.tolist(), tracks.xy.tolist(), tracks.heading_rad
        velocity = tracks.velocity.tolist()
        for k in cars:
            oid = ids[k]
            x, y = xy_all[k]
            route = self.lane_paths.route_of(xy_all[k], float(heading_all[k]))
            if route is None:
                continue
            s0, _ = route.project_point(x, y)
            route_x, route_y, heading = route_pose(route, s0)
            vx, vy = velocity[k]
            v = vx * math.cos(heading) + vy * math.sin(heading)
            prev = self._humans.get(oid)
            a_est, n_seen = 0.0, 1
            beta_belief = self.rationality.prior
            if prev is not None:
                a_est, n_seen = (v - prev.v_mps) / DT_S, prev.n_seen + 1
                a_obs_all[self.object_name(oid)] = a_est
                beta_belief = prev.beta_belief
                if n_seen > cfg.min_track_steps:
                    sigma = self.scoring.observation_sigma_mps2(tracks, k, heading)
                    score = partial(self._score, prev, a_est=a_est, sigma_mps2=sigma)
                    ll, beta_belief = self.rationality.log_likelihood(score, prev.beta_belief,
                                                                      predicted)
                    out.append(ll)
            if n_seen == cfg.min_track_steps:  # once per human: its cruising speed
                out.append(np.broadcast_to(self.cruise_log_likelihood(v),
                                           (len(self.hypotheses), len(self.traffic_grid_mps))))
            v0 = max(v, 0.0)
            q = None  # the next step scores this prediction only from min_track_steps + 1 on
            if n_seen >= cfg.min_track_steps:
                prediction = self.prediction
                others = prediction.scenes.others_scene(np.array([x, y]), heading, oid,
                                                        decoded, tracks)
                viewer = ((np.array([route_x, route_y]), heading) if prediction.has_vehicles
                          else None)
                q = prediction.q_values(route, s0, v0, a_est, others, negligible, viewer,
                                        self.scoring.speed_std_mps(tracks, k, heading))
            current[oid] = _HumanState(v, q, self.prediction.executed(v0), n_seen, beta_belief)
        self._humans = current  # a human not seen this step starts afresh when seen again
        n, n_v = len(self.hypotheses), len(self.traffic_grid_mps)
        return np.array(out).reshape(-1, n, n_v), a_obs_all

    def cruise_log_likelihood(self, v_mps: float) -> np.ndarray:
        """(V,) log N(v_mps; v_traffic, cruise_speed_std_mps^2) up to a constant, per grid speed.

        A human's speed [m/s] when its track first counts, as evidence about the flow speed.
        """
        z = (float(v_mps) - self.traffic_grid_mps) / self.config.cruise_speed_std_mps
        return -0.5 * z * z

    def _score(self, prev: _HumanState, beta: float, a_est: float,
               sigma_mps2: float) -> np.ndarray:
        """(L, V) log P(a_est | x_l, v) of the Q-values predicted one step ago, at beta."""
        return self.scoring.log_likelihood(prev.q_values, prev.actions_mps2, beta, a_est,
                                           sigma_mps2)

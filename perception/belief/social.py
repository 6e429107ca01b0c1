"""Social information: a human driver's observed action as evidence (eq. 9-12).

Each human driver the robot tracks is a sensor. The robot predicts the human's action
distribution under every (hidden-agent hypothesis l, traffic speed v) with its model of the human
(theta_hat, beta_hat; eq. 8 and 11) and, one step later, weighs the acceleration it observed:

    P(a_obs | x_l, v) = (1 - rho) sum_u softmax(-beta_hat Q*_H(x_l, v, .))[u] N(a_obs; u, sigma^2)
                        + rho U(a_obs)

(`action_log_likelihood`; rho = 0 is the paper's eq. 10); humans multiply (eq. 12). Robust, so
that one noisy sample cannot flip the belief:

* sigma^2 = accel_noise_mps2^2 (the human's own execution noise) + the variance of the robot's
  own estimate of the human's acceleration, from its Kalman filter
  (`TrackSet.velocity_change_cov` / dt^2; `SocialLikelihood.observation_sigma_mps2`): a robot
  with a noisier sensor trusts each sample less;
* the outlier term rho U (BeliefConfig.outlier_prob) explains what the model cannot;
* each observation's log-likelihood is clipped to max_log_likelihood_ratio below its maximum
  (`bounded_log_likelihood`): one observation moves the log-odds between any two sets of
  hypotheses by at most BeliefConfig.max_log_likelihood_ratio nats (2.5 by default: a factor
  12; a 0.995 belief falls to at most 0.94 from one contrary sample, and two consistent
  samples take a 0.5 belief above 0.99).

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
* The robot knows the human's speed only as well as its track does: on a route with a bend the
  model is averaged over that estimate, Q*_H from three speeds (Gauss-Hermite nodes of the
  track's velocity std along the route, `speed_std_mps`; BeliefConfig.marginalize_speed) with
  the scene and its hypotheses built once (models/gap_evaluation.vehicle_gap_evaluations), the
  action probabilities averaged (action_model.speed_averaged_log_likelihood). A human's best
  action can change across ~0.1 m/s (whether it can still make its curve speed): evaluated at
  the estimate alone, a left-turner braking for its curve read one step as the full bound's
  evidence for a hidden car. On straight routes it did not pay for its cost (`speed_std_mps`).
* Q*_H is computed once per human and step for all L hypotheses with one batched candidate
  evaluation (`models.candidates.evaluate_candidates`, the function `driver_q_values` wraps)
  without the speed feature; the speed feature theta_speed (v - v_ref)^2 (per planner step, in
  simulator-step units) is then added for each v_traffic. That gives exactly
  `driver_q_values(DriverModel(v_desired_mps=v))` for every (l, v) from a single rollout
  (tests/perception/belief/test_social.py checks the equality).
* The human keeps the right of way like the simulated drivers (models/driver.RoadRules): in a
  conflict zone its route yields at, a car on one of the zone's priority lanes -- tracked, or
  the hypothesised one -- that claims the zone adds the conflict cost
  (`SocialLikelihood.yield_zones`). A left-turner waiting before the lane it crosses is then
  explained by a hypothesised car coming along that lane. It also keeps to the curve speed of
  its path's bends (HUMAN_CURVE_LAT_ACCEL_MPS2; `rule_abiding_totals`), so slowing for a turn
  is not read as giving way. Stop lines are left out: the robot cannot know whether a human
  has already stopped at one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from marl_social.models.candidates import CandidateEvaluation, ScenePrediction
from marl_social.models.driver import DriverModel, RoadRules, rule_abiding_totals
from marl_social.models.gap_evaluation import vehicle_gap_evaluations
from marl_social.models.yield_expectation import YieldExpectation
from marl_social.perception.belief import compiled
from marl_social.perception.belief.action_model import (
    action_log_likelihood,
    bounded_log_likelihood,
    logsumexp,
    speed_averaged_log_likelihood,
    speed_nodes_mps,
)
from marl_social.perception.belief.bayes import bayes_update, normalize
from marl_social.perception.belief.compiled import PAIRWISE_MAX
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.human_scene import HumanScenes
from marl_social.perception.belief.hypotheses import Hypothesis
from marl_social.perception.belief.paths import LanePaths, route_pose
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import DecodedObservation
from marl_social.sim.road_map import RoadMap, Route
from marl_social.sim.route_rules import CurveSpeed, priority_mask, route_conflicts

# the lateral acceleration the robot assumes a human accepts in a bend (a generic driver's;
# a human slowing for its turn is then not read as giving way to a hidden car) [m/s^2]
HUMAN_CURVE_LAT_ACCEL_MPS2 = 2.5
KEPT_ROWS_MAX = 256  # the kept-hypothesis rows remembered per set of present hypotheses


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
    """The robot's model of the human drivers and the likelihood of their observed actions.

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
        model: DriverModel(theta_hat, beta_hat), the robot's model of a human (eq. 8, 11).
    """

    def __init__(self, road_map: RoadMap, agent_names: list[str], hypotheses: list[Hypothesis],
                 traffic_grid_mps: np.ndarray, config: BeliefConfig):
        """Build the human model and the hypotheses' pedestrian predictions."""
        self.road_map = road_map
        self.agent_names = list(agent_names)
        self.hypotheses = hypotheses
        self.traffic_grid_mps = np.ascontiguousarray(traffic_grid_mps, dtype=np.float64)
        self.config = config
        self._present = np.array([h.present for h in hypotheses])
        self.lane_paths = LanePaths(road_map)
        # the robot's model of a human (eq. 8, 11); the speed feature is added per v_ref
        self.model = DriverModel(theta=config.theta_hat, beta=config.beta_hat,
                                 vehicle=VehicleParams())
        self._candidates = self.model.candidates
        self._theta_no_speed = replace(config.theta_hat, speed=0.0).as_array()
        self._times = self._candidates.plan_times_s
        self._first = np.asarray(self._candidates.first_actions_mps2, dtype=np.float64)
        veh = self.model.vehicle  # the first actions within the vehicle's limits (_executed)
        self._first_limited = np.clip(self._first, -veh.brake_max_mps2, veh.accel_max_mps2)
        self._vehicle = np.array([h.kind == "vehicle" for h in hypotheses])
        self._has_vehicles = bool(self._vehicle.any())
        self._kept_rows_memo: dict[bytes, tuple] = {}  # present (L,) -> (inverse, keep)
        # the speed feature theta_speed (v - v_ref)^2 per planner step, in simulator-step units
        self._speed_weight = config.theta_hat.speed * (self._candidates.plan_dt_s / DT_S)
        self._v_ref_column = self.traffic_grid_mps[:, None, None, None]  # (V, 1, 1, 1) [m/s]
        self.scenes = HumanScenes(
            hypotheses, self._times, config, self.model.vehicle,
            YieldExpectation(road_map) if config.human_expects_yield else None)
        self._beta_grid = np.asarray(config.beta_grid_hat, dtype=np.float64)
        self._beta_prior = np.full(len(self._beta_grid), 1.0 / max(len(self._beta_grid), 1))
        self._conflicts: dict[str, tuple] = {}  # route name -> its yield conflicts
        self._curves: dict[str, CurveSpeed | None] = {}  # route name -> its curve speed
        self.reset()

    def reset(self) -> None:
        """Forget every tracked human (call at every episode start)."""
        self._humans: dict[int, _HumanState] = {}

    # -- the scenes the human is modelled against (human_scene.HumanScenes) ---------------------
    def in_view(self, viewer_xy, viewer_heading_rad: float) -> np.ndarray:
        """(L,) bool: hypothesised agents inside a human's assumed view (HumanScenes.in_view)."""
        return self.scenes.in_view(viewer_xy, viewer_heading_rad)

    def others_scene(self, human_xy, human_heading, human_id, decoded: DecodedObservation,
                     tracks: TrackSet) -> ScenePrediction | None:
        """What the robot assumes the human reacts to besides the hypothesised agent.

        HumanScenes.others_scene (the same arguments).
        """
        return self.scenes.others_scene(human_xy, human_heading, human_id, decoded, tracks)

    def hypothesis_scene(self, others: ScenePrediction | None = None,
                         viewer: tuple | None = None) -> ScenePrediction:
        """The L scenes the human is modelled against (HumanScenes.hypothesis_scene)."""
        return self.scenes.hypothesis_scene(others, viewer)

    # -- the human's Q-values and the likelihood of its action ----------------------------------
    def human_q_values(self, route: Route, s0: float, v0: float, prev_accel: float,
                       others: ScenePrediction | None = None,
                       negligible: np.ndarray | None = None,
                       speed_std_mps: float | None = None) -> np.ndarray:
        """Q*_H(x_l, v, u) for every hidden-agent hypothesis l and traffic speed v, one rollout.

        Equal to driver_q_values(DriverModel(theta_hat, beta_hat, v_desired_mps=v), route, s0,
        v0, prev_accel, scene_l, crosswalks) with scene_l = `others` plus hypothesis l's hidden
        agent (eq. 11; a hypothesised vehicle only if the human at s0 can see it,
        `hypothesis_scene` with the human as viewer): the candidates are evaluated once for
        all L scenes without the speed feature, which is then added for each v.

        Args:
            route: the human's route.
            s0: its arc length along the route [m].
            v0: its along-route speed [m/s].
            prev_accel: its previous acceleration [m/s^2].
            others: one-hypothesis scene of the other objects the human reacts to (None:
                nothing but the hypothesised agent).
            negligible: (L,) bool, hypotheses whose hidden agent is left out of the human's
                scene (their belief is negligible: `log_likelihoods`); None: none is.
            speed_std_mps: the std of the robot's estimate v0 of the human's speed [m/s]: the
                Q-values from each of action_model.speed_nodes_mps(v0, speed_std_mps), the
                scene built once (`speed_averaged_log_likelihood` weighs them). None: from v0.

        Returns:
            (L, V, A) optimal cost-to-go of each first action; (3, L, V, A) with speed_std_mps.
        """
        viewer = None
        if self._has_vehicles:
            x, y, heading = route_pose(route, s0)
            viewer = (np.array([x, y]), heading)
        return self._q_values(route, s0, v0, prev_accel, others, negligible, viewer,
                              speed_std_mps)

    def _q_values(self, route: Route, s0: float, v0: float, prev_accel: float,
                  others: ScenePrediction | None, negligible: np.ndarray | None,
                  viewer: tuple | None, speed_std_mps: float | None = None) -> np.ndarray:
        """`human_q_values` with the human's view (xy (2,) [m], heading [rad]) already known.

        viewer None: every hypothesised agent is in its scene (no vehicle hypotheses).
        speed_std_mps: as human_q_values (None: (L, V, A) from v0; else (3, L, V, A)).
        """
        objects = self.scenes.objects_in_view(viewer)
        # every hypothesis whose hidden agent is not in the human's scene ("none", a car out of
        # its view) gives the scene of "none": the candidates are evaluated once for all of them
        present = objects[5]
        if negligible is not None:
            present = present & ~negligible
        inverse, keep = self._kept_rows(present)
        scene = self.scenes.kept_scene(others, objects, keep)  # hypothesis_scene(others, viewer)[keep]
        zones = self.yield_zones(route, s0, scene)
        curve = self._curve_speed(route)
        speeds = (np.array([v0]) if speed_std_mps is None
                  else speed_nodes_mps(v0, speed_std_mps))
        evaluations = vehicle_gap_evaluations(
            self._candidates, self._theta_no_speed, 0.0, self.model.vehicle, route, s0, speeds,
            prev_accel, scene, self.road_map.crosswalks, yield_zones=zones,
            yield_margin_s=self.model.yield_margin_s, curve_speed=curve)
        q = [self._evaluated(ev, s0, zones, curve, inverse) for ev in evaluations]
        return q[0] if speed_std_mps is None else np.stack(q)

    def _evaluated(self, ev: CandidateEvaluation, s0: float, zones: tuple,
                   curve: CurveSpeed | None, inverse: np.ndarray) -> np.ndarray:
        """(L, V, A) Q*_H of one speed's evaluation of the kept scenes (`_q_values`)."""
        # (L, A, C): predicted collisions and plans too fast for its bends excluded
        base = rule_abiding_totals(ev, self.model, s0, RoadRules(None, zones, curve))
        if ev.v.shape[-1] > PAIRWISE_MAX or not base.shape[-1]:
            speed = self._speed_weight * np.square(ev.v - self._v_ref_column).sum(axis=-1)
            return (base[:, None] + speed[None]).min(axis=-1)[inverse]  # (V, A, C) speed
        # the same arithmetic compiled: the speed feature, its minimum over the continuations
        return compiled.kernels().speed_q_values(
            np.ascontiguousarray(base), np.ascontiguousarray(ev.v), self.traffic_grid_mps,
            self._speed_weight, inverse)

    def _kept_rows(self, present: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(L,) row of each hypothesis in the kept scenes and the (K,) kept hypotheses.

        Row 0 is the first hypothesis without its hidden agent in the scene ("none"), then
        the present ones in order; once per `present` (L,) bool (read-only arrays).
        """
        key = present.tobytes()
        rows = self._kept_rows_memo.get(key)
        if rows is None:
            inverse = np.zeros(len(present), dtype=np.intp)
            inverse[present] = np.arange(1, int(present.sum()) + 1)
            keep = np.concatenate([np.flatnonzero(~present)[:1], np.flatnonzero(present)])
            inverse.setflags(write=False)
            keep.setflags(write=False)
            if len(self._kept_rows_memo) >= KEPT_ROWS_MAX:
                self._kept_rows_memo.clear()
            rows = self._kept_rows_memo[key] = (inverse, keep)
        return rows

    def _curve_speed(self, route: Route) -> CurveSpeed | None:
        """The curve speed the robot assumes a human keeps on `route` (None: straight)."""
        if route.name not in self._curves:
            curve = CurveSpeed(route, HUMAN_CURVE_LAT_ACCEL_MPS2,
                               0.5 * self.model.vehicle.length_m)
            self._curves[route.name] = None if curve.is_straight else curve
        return self._curves[route.name]

    def yield_conflicts(self, route: Route) -> tuple:
        """The conflict zones `route` passes where it yields (sim/route_rules.route_conflicts).

        Computed once per route name (a human's path, paths.LanePaths).
        """
        conflicts = self._conflicts.get(route.name)
        if conflicts is None:
            conflicts = tuple(c for c in route_conflicts(route, self.road_map) if c.yields)
            self._conflicts[route.name] = conflicts
        return conflicts

    def yield_zones(self, route: Route, s0: float, scene: ScenePrediction) -> tuple:
        """The right of way the robot assumes a human on `route` at s0 [m] keeps (RoadRules).

        The conflict zones its route passes where it yields (sim/route_rules.route_conflicts)
        and that it has not yet left, each (polygon (V, 2) [m], priority (L, M) bool): the
        scene's cars travelling along one of the zone's priority lanes at the first predicted
        step (`priority_mask`) -- a hypothesised car on such a lane only in its hypothesis.
        The human's Q* then holds the conflict cost of entering the zone while one of them
        claims it (models/driver.RoadRules, `evaluate_candidates`' yield_zones): a human
        waiting at the zone for a car the robot cannot see is evidence for that car.

        Args:
            route: the human's route (its lane and onward, paths.LanePaths).
            s0: its arc length along the route [m].
            scene: the L scenes the human is modelled against (`hypothesis_scene`).
        """
        conflicts = self.yield_conflicts(route)
        if not conflicts or not scene.mask.any():
            return ()
        half = 0.5 * self.model.vehicle.length_m
        cars = scene.mask & ~scene.is_pedestrian  # (L, M)
        xy, heading = scene.xy[:, :, 0].reshape(-1, 2), scene.heading[:, :, 0].reshape(-1)
        zones = []
        for conflict in conflicts:
            if s0 - half > conflict.s_exit_m:  # already through it
                continue
            has_way = priority_mask(conflict.zone, self.road_map, xy, heading)
            has_way = has_way.reshape(cars.shape) & cars
            if has_way.any():
                zones.append((conflict.zone.polygon, has_way))
        return tuple(zones)

    def _executed(self, v0: float) -> np.ndarray:
        """(A,) accelerations the candidate first actions execute as at speed v0 [m/s^2]."""
        return np.maximum(self._first_limited, -max(v0, 0.0) / DT_S)

    def _human_log_likelihood(self, prev: _HumanState, a_est: float, sigma_mps2: float,
                              predicted: np.ndarray):
        """(L, V) log P(a_est | x_l, v) of one human, and its updated rationality belief (B,).

        With a fixed beta_hat this is eq. 10 with the outlier term; with a beta grid the
        likelihood is marginalized over the human's beta belief, which is then updated with the
        predicted joint `predicted` (L, V) b(l, v). Either way the result is clipped to
        max_log_likelihood_ratio below its maximum (`bounded_log_likelihood`).

        Args:
            prev: what the robot predicted for this human one step ago.
            a_est: the acceleration read off its track [m/s^2].
            sigma_mps2: std of a_est about the executed action: the human's own execution
                noise and the track's error, in quadrature [m/s^2].
            predicted: (L, V) predicted joint belief b(l, v).
        """
        cfg = self.config
        if not len(self._beta_grid):
            ll = self._action_log_likelihood(prev, cfg.beta_hat, a_est, sigma_mps2)
            return bounded_log_likelihood(ll, cfg.max_log_likelihood_ratio), prev.beta_belief
        ll = np.stack([self._action_log_likelihood(prev, beta, a_est, sigma_mps2)
                       for beta in self._beta_grid])  # (B, L, V)
        if not np.all(np.isfinite(ll)):
            return np.zeros(ll.shape[1:]), prev.beta_belief
        log_b = np.log(prev.beta_belief)[:, None, None]
        marginal = logsumexp((ll + log_b).reshape(len(ll), -1), axis=0).reshape(ll.shape[1:])
        marginal = bounded_log_likelihood(marginal, cfg.max_log_likelihood_ratio)
        top = ll.max()
        evidence = (np.exp(ll - top) * predicted[None]).sum(axis=(1, 2))  # (B,) up to a constant
        beta_belief = bayes_update(evidence, prev.beta_belief)
        beta_belief = normalize(np.maximum(beta_belief, cfg.floor))
        return marginal, beta_belief

    def _action_log_likelihood(self, prev: _HumanState, beta: float, a_est: float,
                               sigma_mps2: float) -> np.ndarray:
        """(L, V) log P(a_est | x_l, v) of prev.q_values: one speed's, or averaged over three."""
        cfg = self.config
        score = (action_log_likelihood if prev.q_values.ndim == 3
                 else speed_averaged_log_likelihood)
        return score(prev.q_values, beta, a_est, prev.actions_mps2, sigma_mps2,
                     cfg.outlier_prob)

    def observation_sigma_mps2(self, tracks: TrackSet, k: int, heading_rad: float) -> float:
        """Std of a human's acceleration read off the robot's track about its action [m/s^2].

        sqrt(accel_noise_mps2^2 + var_track), var_track the along-route variance of the
        track's velocity change over the last step (TrackSet.velocity_change_cov) / dt^2: the
        robot's own estimation error, which grows with its sensor noise.

        Args:
            tracks: the robot's current tracks.
            k: the human's row in tracks.
            heading_rad: its route heading [rad].
        """
        base = self.config.accel_noise_mps2
        if tracks.velocity_change_cov is None:
            return base
        var_track = _variance_along(tracks.velocity_change_cov[k], heading_rad) / DT_S ** 2
        return math.sqrt(base * base + max(var_track, 0.0))

    def speed_std_mps(self, tracks: TrackSet, k: int, heading_rad: float,
                      route: Route) -> float | None:
        """Std of the robot's estimate of a human's speed along its route [m/s], where it counts.

        From the track's velocity covariance (TrackSet.velocity_cov). None (the model at the
        estimate alone) without it, with BeliefConfig.marginalize_speed off, or on a route
        without a bend (no curve speed, `_curve_speed`): there the measured gain did not pay
        for three evaluations (BeliefConfig.marginalize_speed).

        Args:
            tracks: the robot's current tracks.
            k: the human's row in tracks.
            heading_rad: its route heading [rad].
            route: its route (paths.LanePaths).
        """
        if (not self.config.marginalize_speed or tracks.velocity_cov is None
                or self._curve_speed(route) is None):
            return None
        return math.sqrt(max(_variance_along(tracks.velocity_cov[k], heading_rad), 0.0))

    def beta_beliefs(self) -> dict:
        """{human name: (B,) belief over its rationality on config.beta_grid_hat}.

        For the humans tracked now (social+beta only; empty otherwise).
        """
        if not len(self._beta_grid):
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
            (H, L, V) log P(a_obs,i | x_l, v) and {human name: a_obs [m/s^2]}.
        """
        cfg = self.config
        out, a_obs_all = [], {}
        current = {}
        negligible = None
        if self._has_vehicles:
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
            beta_belief = self._beta_prior
            if prev is not None:
                a_est, n_seen = (v - prev.v_mps) / DT_S, prev.n_seen + 1
                a_obs_all[self.object_name(oid)] = a_est
                beta_belief = prev.beta_belief
                if n_seen > cfg.min_track_steps:
                    sigma = self.observation_sigma_mps2(tracks, k, heading)
                    ll, beta_belief = self._human_log_likelihood(prev, a_est, sigma, predicted)
                    out.append(ll)
            v0 = max(v, 0.0)
            q = None  # the next step scores this prediction only from min_track_steps + 1 on
            if n_seen >= cfg.min_track_steps:
                others = self.scenes.others_scene(np.array([x, y]), heading, oid, decoded,
                                                  tracks)
                viewer = (np.array([route_x, route_y]), heading) if self._has_vehicles else None
                q = self._q_values(route, s0, v0, a_est, others, negligible, viewer,
                                   self.speed_std_mps(tracks, k, heading, route))
            current[oid] = _HumanState(v, q, self._executed(v0), n_seen, beta_belief)
        self._humans = current  # a human not seen this step starts afresh when seen again
        n, n_v = len(self.hypotheses), len(self.traffic_grid_mps)
        return np.array(out).reshape(-1, n, n_v), a_obs_all


def _variance_along(cov: np.ndarray, heading_rad: float) -> float:
    """d^T cov d of a (2, 2) covariance along the unit vector d of heading_rad [rad]."""
    d = np.array([math.cos(heading_rad), math.sin(heading_rad)])
    return float(d @ cov @ d)

"""The robot's social perception (Sun et al. 2019, section III-B-2, eq. 9-12, Algorithm 1).

The robot keeps two discrete beliefs, built only from its own observation vector each step and
the static map (never the world):

* `PedestrianBelief`: hidden physical states x_u,l, l = 1..L, represented by motion patterns
  (`Hypothesis`): "none" (no pedestrian about to cross) and, for each curb end of each
  crosswalk, "a pedestrian steps off that curb now and walks across".
* `TrafficSpeedBelief`: the social information I = v_traffic over a small grid (eq. 12).

Each step (Algorithm 1, in log space; 0.1 s per step):

1. prediction: a Markov transition moves `hazard_per_s * dt` of the mass uniformly between the
   hypotheses (beliefs never lock; a new pedestrian may appear), and likewise between traffic
   speeds;
2. own sensors: a pedestrian the robot sees crossing (or stepping onto) a crosswalk is positive
   information for the matching hypotheses (p_detect against p_false_alarm); otherwise the part
   of each hypothesis' region that the robot's depth rays show empty is negative information,
   P(no detection | l) = (1 - p_false_alarm) (1 - p_detect * visible_fraction_l);
3. social information (eq. 9-10, 12): each human driver the robot tracks is a sensor. The robot
   predicts the human's action distribution under every (hypothesis l, traffic speed v) with its
   model of the human (theta_hat, beta_hat; agents/human.py, eq. 8 and 11) and, one step later,
   weighs the acceleration it observed,
   P(a_obs | x_l, v) = sum_u softmax(-beta_hat Q*_H(x_l, v, .))[u] N(a_obs; u, sigma^2);
   humans multiply (eq. 12);
4. normalization, with a floor (beliefs are never NaN or all-zero).

The update is done on the joint b(l, v) ∝ b(l) b(v) P(own | l) prod_i P(a_i | l, v) and stored
as its two marginals (Algorithm 1's "fuse" step), so that a human braking for a pedestrian is
not read as slow traffic, nor a slow human as a pedestrian. Modelling choices:

* The human sees the hypothesised pedestrian (it is closer to the crosswalk and unoccluded in
  the paper's scenario) and, besides it, the objects the robot tracks, and the robot itself, that
  lie in an assumed forward field of view of the human (`BeliefConfig.human_range_m`,
  `human_half_fov_rad`), predicted at constant velocity.
* The human's desired speed is v_traffic (marginalized with the traffic-speed belief).
* The human's executed acceleration a_obs is estimated from the robot's own Kalman track
  (along-route speed difference over one step); candidate accelerations are compared with a_obs
  after the vehicle's limits (no reversing: an action u at speed v executes as max(u, -v/dt)).
* beta_hat defaults to 0.3, not the humans' own 5: Q* is in simulator-step cost units with a
  crosswalk weight of 1000, and an error of ~0.1 m/s in the robot's estimate of the human's
  speed moves the human's best first action between -2 and -8 m/s^2 when it is stopping
  before a crosswalk; with beta_hat = 5 the model is then confidently wrong and the belief swings.
  beta_hat absorbs the robot's state-estimation error (measured in tests/test_belief.py and the
  report).
* Q*_H is computed once per human and step for all L hypotheses with one batched candidate
  evaluation (`agents.candidates.evaluate_candidates`, the function `driver_q_values` wraps)
  with the speed feature left out; the speed feature, theta_speed (v - v_ref)^2 (per planner
  step, in simulator-step units), is then added for each v_traffic. That gives exactly
  `driver_q_values(DriverModel(v_desired_mps=v))` for every (l, v) from a single rollout
  (tests/test_belief.py checks the equality).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from filterpy.discrete_bayes import normalize
from filterpy.discrete_bayes import update as bayes_update
from marl_social.perception.fov import depth_ray_angles
from marl_social.perception.tracking import Tracker, TrackSet

from marl_social.models.boltzmann import boltzmann
from marl_social.models.candidates import (
    ScenePrediction,
    collision_free_totals,
    evaluate_candidates,
)
from marl_social.models.driver import DriverModel
from marl_social.sim.agent_spec import VehicleParams
from marl_social.sim.costs import CostWeights
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import SLOT_FIELDS, ObservationLayout
from marl_social.sim.road_map import Crosswalk, RoadMap, Route

_F = {name: i for i, name in enumerate(SLOT_FIELDS)}
PEDESTRIAN_DIAMETER_M = 0.6  # footprint of a hypothesised pedestrian [m]
_REGION_ALONG_M = (-0.5, 1.0)  # region: from 0.5 m behind the entry to 1 m past the curb [m]
_REGION_EDGE_M = 0.5  # region points stay this far inside the crosswalk's side edges [m]
_NEAR_M = 1.0  # a detection within this margin of a hypothesis' corridor can match it [m]


# -- hypotheses ---------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Hypothesis:
    """A representative motion pattern of a possibly hidden pedestrian.

    Attributes:
        name: "none", "crossing_right", "crossing_left", ... (with several crosswalks
            "crossing<i>_<side>").
        present: False only for "none".
        start_xy: (2,) where it stands on the curb at the crosswalk entry [m].
        walk_dir: (2,) unit vector across the road.
        walk_speed_mps: walking speed [m/s].
        walk_length_m: distance from start_xy to the far entry, where it stops [m].
        curb_offset_m: distance from start_xy to the curb (the crosswalk's end) [m].
        half_width_m: half the crosswalk's extent along the road [m].
        crosswalk_index: index into RoadMap.crosswalks (-1 for "none").
    """

    name: str
    present: bool
    start_xy: np.ndarray | None = None
    walk_dir: np.ndarray | None = None
    walk_speed_mps: float = 0.0
    walk_length_m: float = 0.0
    curb_offset_m: float = 0.0
    half_width_m: float = 0.0
    crosswalk_index: int = -1

    def predict_xy(self, times_s) -> np.ndarray:
        """Positions (T, 2) [m] at future times (T,) [s]: at the curb entry now, walking across
        at walk_speed_mps, stopping at the far entry. Raises for the "none" hypothesis.
        """
        if not self.present:
            raise ValueError(f"hypothesis {self.name!r} has no pedestrian to predict")
        t = np.asarray(times_s, dtype=np.float64)
        dist = np.clip(self.walk_speed_mps * t, 0.0, self.walk_length_m)
        return self.start_xy + dist[:, None] * self.walk_dir

    def region(self) -> np.ndarray:
        """(K, 2) sample points [m] of where the pedestrian would be now or soon: the curb entry
        area and the first metre of road (5 along x 3 across). Empty (0, 2) for "none".
        """
        if not self.present:
            return np.zeros((0, 2))
        along = np.linspace(_REGION_ALONG_M[0], self.curb_offset_m + _REGION_ALONG_M[1], 5)
        half = max(self.half_width_m - _REGION_EDGE_M, 0.0)
        across = np.linspace(-half, half, 3)
        normal = np.array([-self.walk_dir[1], self.walk_dir[0]])
        pts = (self.start_xy + along[:, None, None] * self.walk_dir
               + across[None, :, None] * normal)
        return pts.reshape(-1, 2)

    def corridor_coords(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Coordinates of points (n, 2) [m] in this hypothesis' frame: `along` from start_xy in
        walk_dir and `across` (left of walk_dir) [m], each (n,).
        """
        rel = np.asarray(xy, dtype=np.float64) - self.start_xy
        along = rel @ self.walk_dir
        across = rel @ np.array([-self.walk_dir[1], self.walk_dir[0]])
        return along, across


def _side_name(road_map: RoadMap, crosswalk: Crosswalk, entry: np.ndarray) -> str:
    """"right" / "left" of the traffic direction of the lane nearest the crosswalk (or "a"/"b"
    by walking direction without lanes).
    """
    if not road_map.lanes:
        return ""
    best = None
    for lane in road_map.lanes:
        route = Route(lane.centerline)
        _, lateral, heading = route.project(crosswalk.center)
        if best is None or abs(float(lateral)) < best[0]:
            best = (abs(float(lateral)), float(heading))
    heading = best[1]
    rel = entry - crosswalk.center
    cross = math.cos(heading) * rel[1] - math.sin(heading) * rel[0]
    return "left" if cross > 0 else "right"


def crosswalk_hypotheses(road_map: RoadMap, walk_speed_mps: float = 1.3,
                         curb_offset_m: float = 1.0) -> list[Hypothesis]:
    """"none" plus one "crossing_<side>" per curb end of every crosswalk.

    The entry point is the crosswalk's end (curb) moved curb_offset_m onto the sidewalk; the
    pedestrian walks from there towards the other end (walk_speed_mps [m/s]) and stops at the
    far entry. <side> is "right"/"left" of the traffic direction of the nearest lane.
    """
    hyps = [Hypothesis("none", False)]
    many = len(road_map.crosswalks) > 1
    for i, cw in enumerate(road_map.crosswalks):
        d = np.array([math.cos(cw.walk_heading_rad), math.sin(cw.walk_heading_rad)])
        ends = [(cw.center - d * (0.5 * cw.length_m + curb_offset_m), d),
                (cw.center + d * (0.5 * cw.length_m + curb_offset_m), -d)]
        for k, (entry, walk_dir) in enumerate(ends):
            side = _side_name(road_map, cw, entry) or "ab"[k]
            name = f"crossing{i}_{side}" if many else f"crossing_{side}"
            hyps.append(Hypothesis(
                name, True, entry, walk_dir, float(walk_speed_mps),
                walk_length_m=cw.length_m + 2.0 * curb_offset_m, curb_offset_m=curb_offset_m,
                half_width_m=0.5 * cw.width_m, crosswalk_index=i,
            ))
    return hyps


# -- discrete Bayes -----------------------------------------------------------------------------
def markov_transition(n: int, p_move: float) -> np.ndarray:
    """(n, n) column-stochastic Markov matrix: each hypothesis keeps 1 - p_move of its mass and
    spreads p_move evenly over the others (identity for n = 1).
    """
    if n <= 1:
        return np.ones((max(n, 0), max(n, 0)))
    p = float(np.clip(p_move, 0.0, 1.0))
    mat = np.full((n, n), p / (n - 1))
    np.fill_diagonal(mat, 1.0 - p)
    return mat


def _sanitize_log_likelihood(log_lik: np.ndarray) -> np.ndarray:
    """Log-likelihoods (..., L) of one or more sources made safe and shifted so that each
    source's maximum is 0. A source with NaN or +inf anywhere, or -inf everywhere (nothing
    explains it), carries no usable information: zeros.
    """
    ll = np.asarray(log_lik, dtype=np.float64)
    top = ll.max(axis=-1, keepdims=True)  # NaN if any NaN, +inf if any +inf
    good = np.isfinite(top)
    return np.where(good, ll - np.where(good, top, 0.0), 0.0)


def bayes_step(prior, log_likelihoods, transition=None, floor: float = 1e-6) -> np.ndarray:
    """One discrete Bayes filter step (Algorithm 1, steps 2-3; eq. 9 and 12).

    Args:
        prior: (L,) belief after the previous step.
        log_likelihoods: (L,) or (S, L) log P(observation_s | hypothesis l) for S independent
            sources (own sensors, each human...), multiplied (summed in log space). A source
            with NaN or +inf anywhere, or -inf everywhere, is ignored.
        transition: (L, L) column-stochastic Markov matrix applied first (prediction), or None.
        floor: every belief is raised to at least this before the final normalization.

    Returns:
        (L,) posterior, finite, positive, summing to 1.
    """
    prior = np.asarray(prior, dtype=np.float64)
    total_prior = prior.sum()
    if not (math.isfinite(total_prior) and total_prior > 0.0 and prior.min() >= 0.0):
        prior, total_prior = np.ones_like(prior), float(len(prior))
    predicted = prior / total_prior
    if transition is not None:
        predicted = np.asarray(transition) @ predicted
    predicted = np.maximum(predicted, 0.0)
    ll = np.atleast_2d(np.asarray(log_likelihoods, dtype=np.float64))
    total = _sanitize_log_likelihood(_sanitize_log_likelihood(ll).sum(axis=0))
    posterior = bayes_update(np.exp(total), predicted)
    if not np.all(np.isfinite(posterior)):
        posterior = predicted / predicted.sum() if predicted.sum() > 0 else np.ones(len(prior))
    return normalize(np.maximum(posterior, floor))


def action_log_likelihood(q_values: np.ndarray, beta: float, a_obs: float,
                          actions_mps2: np.ndarray, sigma_mps2: float,
                          outlier_prob: float = 0.0) -> np.ndarray:
    """Log P(a_obs | x) of one observed acceleration under several hypotheses x (eq. 9-10):

        P(a_obs | x) = (1 - rho) sum_u softmax(-beta Q*(x, .))[u] N(a_obs; u, sigma^2)
                       + rho U(a_obs)

    rho = outlier_prob (0 gives eq. 10 exactly): a uniform density U over the actions' range
    widened by 3 sigma on each side, for observations no candidate explains (a tracking glitch,
    a model mismatch); it bounds what one step can do to the belief.

    Args:
        q_values: (..., A) Q*_H(x, u) of the A candidate actions (eq. 11) per hypothesis.
        beta: rationality of the model (inf = argmin).
        a_obs: observed acceleration [m/s^2]; non-finite values give zeros (uninformative).
        actions_mps2: (A,) accelerations the candidate actions execute as [m/s^2].
        sigma_mps2: std of the observation noise on a_obs [m/s^2].
        outlier_prob: rho in [0, 1).

    Returns:
        (...) log-likelihoods.
    """
    q = np.asarray(q_values, dtype=np.float64)
    if not math.isfinite(a_obs) or not np.all(np.isfinite(q)):
        return np.zeros(q.shape[:-1])
    sigma = max(float(sigma_mps2), 1e-3)
    if math.isinf(beta):
        with np.errstate(divide="ignore"):
            log_p = np.log(boltzmann(q, beta))
    else:
        z = -beta * (q - q.min(axis=-1, keepdims=True))
        log_p = z - np.log(np.exp(z).sum(axis=-1, keepdims=True))
    actions = np.asarray(actions_mps2, dtype=np.float64)
    with np.errstate(over="ignore"):  # an absurd a_obs gives -inf everywhere: uninformative
        log_gauss = (-0.5 * ((a_obs - actions) / sigma) ** 2
                     - math.log(sigma * math.sqrt(2 * math.pi)))
    log_model = _logsumexp(log_p + log_gauss, axis=-1)
    rho = float(np.clip(outlier_prob, 0.0, 1.0 - 1e-12))
    if rho == 0.0:
        return log_model
    width = actions.max() - actions.min() + 6.0 * sigma
    log_outlier = math.log(rho / width)
    return np.logaddexp(math.log1p(-rho) + log_model, log_outlier)


def _logsumexp(x: np.ndarray, axis: int) -> np.ndarray:
    """Log sum exp along axis, safe for -inf entries (all -inf gives -inf)."""
    top = np.max(x, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.exp(x - top).sum(axis=axis, keepdims=True)) + top
    return np.squeeze(out, axis=axis)


# -- traffic speed (eq. 12) ---------------------------------------------------------------------
class TrafficSpeedBelief:
    """Belief over the traffic speed v_traffic on a grid (social information, eq. 12):

        b(v | u_H) ∝ b(v) prod_i P(u_H,i | v)

    with a small Markov transition (hazard_per_step) before each update.

    Args:
        grid_mps: (V,) candidate traffic speeds [m/s].
        hazard_per_step: mass moving between grid values per step.
        floor: belief floor before normalization.
    """

    def __init__(self, grid_mps, hazard_per_step: float = 0.002, floor: float = 1e-6):
        self.grid_mps = np.asarray(grid_mps, dtype=np.float64)
        if self.grid_mps.ndim != 1 or len(self.grid_mps) == 0:
            raise ValueError("TrafficSpeedBelief: grid_mps must be a non-empty 1-D sequence")
        self.floor = float(floor)
        self.transition = markov_transition(len(self.grid_mps), hazard_per_step)
        self.reset()

    def reset(self) -> None:
        self.probabilities = np.full(len(self.grid_mps), 1.0 / len(self.grid_mps))

    def update(self, log_likelihoods) -> np.ndarray:
        """Fold in one step: log_likelihoods (H, V) log P(a_obs,i | v) for H humans (H may be 0:
        prediction only). Returns the (V,) posterior.
        """
        ll = np.asarray(log_likelihoods, dtype=np.float64).reshape(-1, len(self.grid_mps))
        if len(ll) == 0:
            ll = np.zeros((1, len(self.grid_mps)))
        self.probabilities = bayes_step(self.probabilities, ll, self.transition, self.floor)
        return self.probabilities

    @property
    def expected_mps(self) -> float:
        """E[v_traffic] under the belief [m/s]."""
        return float(self.probabilities @ self.grid_mps)


# -- the robot's belief over hidden pedestrians -------------------------------------------------
@dataclass(frozen=True)
class BeliefConfig:
    """Parameters of the robot's social perception (SI units).

    Attributes:
        walk_speed_mps: walking speed of the hypothesised pedestrians [m/s].
        curb_offset_m: how far from the curb a hypothesised pedestrian starts [m].
        p_detect: P(robot detects a pedestrian | it is in a visible part of the region).
        p_false_alarm: P(a crossing pedestrian is reported that is not there).
        accel_noise_mps2: sigma of N(a_obs; u, sigma^2), the noise of the robot's estimate of a
            human's acceleration [m/s^2].
        hazard_per_s: per-second probability mass moving between hypotheses [1/s].
        floor: beliefs never drop below this before normalization.
        epsilon: the paper's tail threshold (for the planner; see `PedestrianBelief.live`).
        beta_hat: the robot's model of the humans' rationality.
        beta_grid_hat: if non-empty, beta_hat is not fixed: each tracked human's rationality is
            inferred on this grid jointly with the hidden state (a per-human belief b_i(beta),
            uniform at first; P(a_i | l, v) = sum_beta b_i(beta) P(a_i | l, v, beta), and
            b_i(beta) ∝ b_i(beta) sum_{l,v} b(l, v) P(a_i | l, v, beta)). An erratic human is
            then explained by a low beta and moves the pedestrian belief less.
        theta_hat: the robot's model of the humans' cost weights.
        prior_present: prior mass spread evenly over the present hypotheses.
        v_traffic_grid_mps: grid of the traffic-speed belief [m/s].
        human_range_m, human_half_fov_rad: the field of view the robot assumes a human has for
            the objects it reacts to besides the hypothesised pedestrian [m, rad].
        walking_speed_min_mps: a seen pedestrian moving at least this fast along a hypothesis'
            walking direction is stepping onto the crosswalk [m/s].
        outlier_prob: weight rho of a uniform outlier component in P(a_obs | x)
            (`action_log_likelihood`; 0 = eq. 10 exactly).
        min_track_steps: a human's acceleration is used once its track has been measured this
            many consecutive steps (a new Kalman track's velocity is still settling).
        track_accel_noise_mps2: process noise of the robot's default Kalman tracker [m/s^2]
            (lower: smoother a_obs, more lag; 1.5 keeps the a_obs noise below sigma = 1).
    """

    walk_speed_mps: float = 1.3
    curb_offset_m: float = 1.0
    p_detect: float = 0.95
    p_false_alarm: float = 0.01
    accel_noise_mps2: float = 1.0
    hazard_per_s: float = 0.02
    floor: float = 1e-6
    epsilon: float = 0.02
    beta_hat: float = 0.3
    beta_grid_hat: tuple = ()
    theta_hat: CostWeights = field(default_factory=CostWeights)
    prior_present: float = 0.5
    v_traffic_grid_mps: tuple = (8.0, 10.0, 11.5, 13.0)
    human_range_m: float = 60.0
    human_half_fov_rad: float = math.radians(60.0)
    walking_speed_min_mps: float = 0.5
    outlier_prob: float = 0.0
    min_track_steps: int = 3
    track_accel_noise_mps2: float = 1.5

    def __post_init__(self):
        for name in ("p_detect", "p_false_alarm", "prior_present"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"BeliefConfig.{name} must be in [0, 1], got {value}")
        grid = np.asarray(self.beta_grid_hat, dtype=np.float64)
        if grid.ndim != 1 or not np.all(grid >= 0):  # also rejects NaN
            raise ValueError(f"BeliefConfig.beta_grid_hat must be a sequence of betas >= 0, "
                             f"got {self.beta_grid_hat!r}")
        if not (self.accel_noise_mps2 > 0 and self.hazard_per_s >= 0 and self.floor > 0):
            raise ValueError("BeliefConfig: need accel_noise_mps2 > 0, hazard_per_s >= 0, "
                             "floor > 0")


@dataclass
class _HumanState:
    """What the robot remembers of one tracked human until the next step: its along-route speed
    [m/s], Q*_H (L, V, A) of its candidate actions and the accelerations (A,) they execute as
    [m/s^2], and the belief (B,) over its rationality on BeliefConfig.beta_grid_hat (empty when
    beta is fixed).
    """

    v_mps: float
    q_values: np.ndarray
    actions_mps2: np.ndarray
    n_seen: int = 1
    beta_belief: np.ndarray = field(default_factory=lambda: np.zeros(0))


class PedestrianBelief:
    """The robot's belief over hidden crossing pedestrians (Algorithm 1), from its own
    observations and the static map only.

    Args:
        road_map: the static map (crosswalks, routes of the human drivers, speed limit).
        layout: the shared observation layout.
        robot_name: the robot's agent name.
        agent_names: env.possible_agents (public; slot object id k is agent_names[k - 1]); human
            drivers are the non-pedestrian objects whose name starts with "human" and that have a
            route in road_map.routes.
        config: BeliefConfig.
        use_social: fold in the humans' behaviour (eq. 9-10, and eq. 12 for v_traffic).
        use_own_sensors: fold in the robot's own detections and negative information.
        tracker: the robot's Kalman tracker of others (default: Tracker with the default sensor
            noise levels and config.track_accel_noise_mps2).

    Attributes:
        hypotheses: the L hypotheses, "none" first.
        probabilities: (L,) current belief.
        traffic: TrafficSpeedBelief (eq. 12).
        perceived: 1.0 if the robot currently sees a pedestrian crossing (or stepping onto) a
            crosswalk, else 0.0 (the paper's "perceived probability"). A pedestrian standing on
            the sidewalk is not a crossing pedestrian.
        last_likelihoods: this step's likelihoods (each scaled to max 1): "own" (L,), "social"
            (L,), "traffic" (V,), "visible_fraction" (L,), "detected" (L,) bool, "a_obs"
            {human name: observed acceleration [m/s^2]}.
    """

    def __init__(self, road_map: RoadMap, layout: ObservationLayout, robot_name: str,
                 agent_names: list[str], config: BeliefConfig | None = None,
                 use_social: bool = True, use_own_sensors: bool = True,
                 tracker: Tracker | None = None):
        self.config = config = config or BeliefConfig()
        self.road_map = road_map
        self.layout = layout
        self.robot_name = robot_name
        self.agent_names = list(agent_names)
        self.use_social = bool(use_social)
        self.use_own_sensors = bool(use_own_sensors)
        self.hypotheses = crosswalk_hypotheses(road_map, config.walk_speed_mps,
                                               config.curb_offset_m)
        n = len(self.hypotheses)
        self._present = np.array([h.present for h in self.hypotheses])
        self._present_idx = np.flatnonzero(self._present)
        regions = [h.region() for h in self.hypotheses if h.present]
        self._region = np.array(regions) if regions else np.zeros((0, 1, 2))  # (P, K, 2)
        self.transition = markov_transition(n, config.hazard_per_s * DT_S)
        self.tracker = tracker or Tracker(accel_noise_mps2=config.track_accel_noise_mps2)
        self.traffic = TrafficSpeedBelief(config.v_traffic_grid_mps, config.hazard_per_s * DT_S,
                                          config.floor)
        self._joint_transition = np.kron(self.transition, self.traffic.transition)
        self._human_routes = {
            i + 1: road_map.routes[name] for i, name in enumerate(self.agent_names)
            if name.startswith("human") and name in road_map.routes
        }
        # the robot's model of a human (eq. 8, 11); the speed feature is added per v_ref
        self.model = DriverModel(theta=config.theta_hat, beta=config.beta_hat,
                                 vehicle=VehicleParams())
        self._candidates = self.model.candidates
        self._theta_no_speed = replace(config.theta_hat, speed=0.0).as_array()
        self._times = self._candidates.plan_times_s
        self._first = np.asarray(self._candidates.first_actions_mps2, dtype=np.float64)
        self._hyp_scene = self._hypothesis_objects()
        self._beta_grid = np.asarray(config.beta_grid_hat, dtype=np.float64)
        self._beta_prior = np.full(len(self._beta_grid), 1.0 / max(len(self._beta_grid), 1))
        self._ray_cache: tuple | None = None
        self._empty_scene: ScenePrediction | None = None
        self.reset()

    # -- public API -------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to the prior (call at every episode start)."""
        n = len(self.hypotheses)
        prior = np.zeros(n)
        n_present = int(self._present.sum())
        if n_present:
            prior[self._present] = self.config.prior_present / n_present
            prior[~self._present] = 1.0 - self.config.prior_present
        else:
            prior[:] = 1.0
        self.probabilities = normalize(np.maximum(prior, self.config.floor))
        self.tracker.reset()
        self.traffic.reset()
        self._humans: dict[int, _HumanState] = {}
        self.perceived = 0.0
        self.last_likelihoods: dict = {}

    @property
    def p_pedestrian(self) -> float:
        """Belief that a crossing pedestrian is present: 1 when perceived, else 1 - P(none)."""
        if self.perceived > 0.5:
            return 1.0
        return float(1.0 - self.probabilities[~self._present].sum())

    def live(self, epsilon: float | None = None) -> np.ndarray:
        """(L,) bool: hypotheses with belief >= epsilon (default config.epsilon), the ones the
        planner keeps (the paper's tail threshold).
        """
        eps = self.config.epsilon if epsilon is None else float(epsilon)
        return self.probabilities >= eps

    def update(self, obs) -> np.ndarray:
        """Fold in one observation of the robot (Algorithm 1 order: prediction, own sensors,
        social information, normalization). Returns the (L,) posterior.

        The pedestrian hypotheses x_l and the traffic speed v are updated jointly,
        b(l, v) ∝ b(l) b(v) P(own | l) prod_i P(a_i | l, v)  (eq. 9 and 12), and stored as
        their marginals, so that a human braking for a pedestrian is not also read as slow
        traffic (and the other way round).
        """
        decoded = self.layout.decode(obs)
        n, n_v = len(self.hypotheses), len(self.traffic.grid_mps)
        tracks = self.tracker.update(decoded)
        ll_own = np.zeros(n)
        visible = np.zeros(n)
        detected = np.zeros(n, dtype=bool)
        if self.use_own_sensors:
            ll_own, visible, detected = self._own_sensor_log_likelihood(decoded, tracks)
        self.perceived = 1.0 if detected.any() else 0.0
        ll_social = np.zeros((0, n, n_v))
        a_obs = {}
        if self.use_social:
            ll_social, a_obs = self._social_log_likelihoods(decoded, tracks)
            if detected.any():
                # the robot sees a crossing pedestrian itself: the humans' behaviour is read
                # under the most probable detected hypothesis (informative about v_traffic
                # only), not as evidence about pedestrians it can see
                seen = np.flatnonzero(detected)
                best = seen[np.argmax(self.probabilities[seen])]
                ll_social = np.broadcast_to(ll_social[:, best:best + 1, :], ll_social.shape)
        sources = np.vstack([np.broadcast_to(ll_own[:, None], (n, n_v))[None], ll_social])
        pred_l = self.transition @ self.probabilities
        pred_v = self.traffic.transition @ self.traffic.probabilities
        prior = np.outer(self.probabilities, self.traffic.probabilities).ravel()
        joint = bayes_step(prior, sources.reshape(len(sources), -1), self._joint_transition,
                           self.config.floor).reshape(n, n_v)
        floor = self.config.floor
        self.probabilities = normalize(np.maximum(joint.sum(axis=1), floor))
        self.traffic.probabilities = normalize(np.maximum(joint.sum(axis=0), floor))
        # per-source summaries for debugging: social evidence about l (about v) marginalized
        # over v (over l) with the predicted beliefs
        social = np.exp(_sanitize_log_likelihood(ll_social.sum(axis=0).ravel())).reshape(n, n_v)
        by_l, by_v = social @ pred_v, pred_l @ social
        self.last_likelihoods = {
            "own": np.exp(_sanitize_log_likelihood(ll_own)), "social": by_l / by_l.max(),
            "traffic": by_v / by_v.max(), "visible_fraction": visible, "detected": detected,
            "a_obs": a_obs,
        }
        return self.probabilities.copy()

    # -- own sensors ------------------------------------------------------------------------
    def visible_fraction(self, decoded) -> np.ndarray:
        """(L,) fraction of each hypothesis' region the robot's depth rays show free (0 for
        "none"). A point is visible if within range and cone and the depth along its bearing
        (the shorter of the two neighbouring rays) reaches it, less a pedestrian's radius.
        """
        ego, depth = decoded.ego, np.asarray(decoded.depth_m, dtype=np.float64)
        out = np.zeros(len(self.hypotheses))
        if len(self._present_idx) == 0 or len(depth) == 0:
            return out
        x, y, c, s = (float(v) for v in ego[:4])
        rng, half = float(ego[5]), float(ego[6])
        angles = self._ray_angles(half, len(depth))
        rel = self._region - np.array([x, y])
        dist = np.hypot(rel[..., 0], rel[..., 1])
        bearing = np.arctan2(rel[..., 1], rel[..., 0]) - math.atan2(s, c)
        bearing = (bearing + np.pi) % (2.0 * np.pi) - np.pi
        n_rays = len(angles)
        if half >= np.pi:
            i1 = np.searchsorted(angles, bearing) % n_rays
            i0 = (i1 - 1) % n_rays
            in_cone = np.ones(bearing.shape, dtype=bool)
        else:
            i1 = np.clip(np.searchsorted(angles, bearing), 0, n_rays - 1)
            i0 = np.clip(i1 - 1, 0, n_rays - 1)
            in_cone = np.abs(bearing) <= half + 1e-9
        reach = np.minimum(depth[i0], depth[i1])
        seen = in_cone & (dist <= rng) & (reach >= dist - 0.5 * PEDESTRIAN_DIAMETER_M)
        out[self._present_idx] = seen.mean(axis=1)
        return out

    def _ray_angles(self, half: float, n_rays: int) -> np.ndarray:
        key = (half, n_rays)
        if self._ray_cache is None or self._ray_cache[0] != key:
            self._ray_cache = (key, depth_ray_angles(np.array([half]), n_rays)[0])
        return self._ray_cache[1]

    def match_pedestrians(self, xy, velocity) -> np.ndarray:
        """(L,) bool: present hypotheses consistent with seen pedestrians at xy (n, 2) [m] with
        velocity (n, 2) [m/s]: inside the hypothesis' corridor (the crosswalk from its entry to
        the far end, +-1 m) and either on the road not walking against its direction, or
        walking in its direction at >= walking_speed_min_mps. A pedestrian standing on the
        sidewalk matches nothing.
        """
        out = np.zeros(len(self.hypotheses), dtype=bool)
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        vel = np.asarray(velocity, dtype=np.float64).reshape(-1, 2)
        if len(xy) == 0:
            return out
        v_min = self.config.walking_speed_min_mps
        for i in self._present_idx:
            h = self.hypotheses[i]
            along, across = h.corridor_coords(xy)
            v_along = vel @ h.walk_dir
            corridor = ((np.abs(across) <= h.half_width_m + _NEAR_M)
                        & (along >= -_NEAR_M) & (along <= h.walk_length_m - h.curb_offset_m))
            on_road = (along >= h.curb_offset_m) & (along <= h.walk_length_m - h.curb_offset_m)
            crossing = (on_road & (v_along > -v_min)) | (v_along >= v_min)
            out[i] = bool(np.any(corridor & crossing))
        return out

    def _own_sensor_log_likelihood(self, decoded, tracks: TrackSet):
        """Positive and negative information from the robot's own sensors: (L,) log-likelihood,
        (L,) visible fraction, (L,) bool matched detections.
        """
        cfg = self.config
        seen_ped = tracks.is_pedestrian & tracks.seen
        detected = self.match_pedestrians(tracks.xy[seen_ped], tracks.velocity[seen_ped])
        visible = self.visible_fraction(decoded)
        miss = np.clip(1.0 - cfg.p_detect * visible, 1e-12, 1.0)
        p_fa = np.clip(cfg.p_false_alarm, 1e-12, 1.0 - 1e-12)
        if detected.any():
            # the detection is explained by a matching hypothesis, or is a false alarm (then
            # any other pedestrian's region was missed)
            lik = np.where(detected, cfg.p_detect, p_fa * np.where(self._present, miss, 1.0))
        else:
            lik = (1.0 - p_fa) * np.where(self._present, miss, 1.0)
        with np.errstate(divide="ignore"):
            return np.log(lik), visible, detected

    # -- social information -----------------------------------------------------------------
    def _hypothesis_objects(self):
        """Per-hypothesis pedestrian predictions at the planner times (fixed patterns)."""
        n, n_t = len(self.hypotheses), len(self._times)
        xy = np.zeros((n, n_t, 2))
        heading = np.zeros((n, n_t))
        for i, h in enumerate(self.hypotheses):
            if h.present:
                xy[i] = h.predict_xy(self._times)
                heading[i] = math.atan2(h.walk_dir[1], h.walk_dir[0])
        size = np.full(n, PEDESTRIAN_DIAMETER_M)
        return xy, heading, size, size, np.ones(n, dtype=bool), self._present.copy()

    def _others_scene(self, human_xy, human_heading, human_id, decoded, tracks: TrackSet
                      ) -> ScenePrediction | None:
        """One hypothesis (L = 1): what the robot assumes the human reacts to besides the
        hypothesised pedestrian: the vehicles it tracks (other than the human) and the robot
        itself inside the human's assumed field of view, at constant velocity; None if there
        is nothing. Seen pedestrians are left to the hypotheses (a crossing one is the detected
        hypothesis).
        """
        ego = decoded.ego
        xy = np.vstack([tracks.xy, ego[None, :2]])
        rel = xy - human_xy
        dist = np.hypot(rel[:, 0], rel[:, 1])
        bearing = np.arctan2(rel[:, 1], rel[:, 0]) - human_heading
        bearing = np.abs((bearing + np.pi) % (2.0 * np.pi) - np.pi)
        keep = np.append((tracks.ids != human_id) & ~tracks.is_pedestrian, True)
        keep &= (dist <= self.config.human_range_m) & (bearing <= self.config.human_half_fov_rad)
        if not keep.any():
            return None
        veh = self.model.vehicle
        vel = np.vstack([tracks.velocity, float(ego[4]) * ego[None, 2:4]])[keep]
        length = np.append(tracks.length_m, veh.length_m)[keep]
        width = np.append(tracks.width_m, veh.width_m)[keep]
        is_ped = np.append(tracks.is_pedestrian, False)[keep]
        m = len(vel)
        pred = xy[keep][:, None, :] + vel[:, None, :] * self._times[None, :, None]
        heading = np.append(tracks.heading_rad, math.atan2(ego[3], ego[2]))[keep]
        heading = np.broadcast_to(heading[:, None], (m, len(self._times)))
        return ScenePrediction(pred[None], heading[None], length[None], width[None],
                               0.5 * np.hypot(length, width)[None], is_ped[None],
                               np.ones((1, m), dtype=bool))

    def hypothesis_scene(self, others: ScenePrediction | None = None) -> ScenePrediction:
        """The L scenes the human is modelled against: `others` (one hypothesis, or None for
        nothing else) plus each hypothesis' pedestrian (masked out for "none").
        """
        if others is None:
            if self._empty_scene is None:
                n_t = len(self._times)
                empty = ScenePrediction(np.zeros((1, 0, n_t, 2)), np.zeros((1, 0, n_t)),
                                        np.zeros((1, 0)), np.zeros((1, 0)), np.zeros((1, 0)),
                                        np.zeros((1, 0), dtype=bool),
                                        np.zeros((1, 0), dtype=bool))
                self._empty_scene = empty.with_extra(*self._hyp_scene)
            return self._empty_scene
        return others.with_extra(*self._hyp_scene)

    def human_q_values(self, route: Route, s0: float, v0: float, prev_accel: float,
                       others: ScenePrediction | None = None) -> np.ndarray:
        """Q*_H(x_l, v, u) for every pedestrian hypothesis l and traffic speed v, one rollout.

        Equal to driver_q_values(DriverModel(theta_hat, beta_hat, v_desired_mps=v), route, s0,
        v0, prev_accel, scene_l, crosswalks) with scene_l = `others` plus hypothesis l's
        pedestrian (eq. 11): the candidates are evaluated once for all L scenes without the
        speed feature, which is then added for each v.

        Args:
            route, s0 [m], v0 [m/s], prev_accel [m/s^2]: the human on its route.
            others: one-hypothesis scene of the other objects the human reacts to (None:
                nothing but the hypothesised pedestrian).

        Returns:
            (L, V, A) optimal cost-to-go of each first action.
        """
        scene = self.hypothesis_scene(others)
        ev = evaluate_candidates(self._candidates, self._theta_no_speed, 0.0, self.model.vehicle,
                                 route, s0, v0, prev_accel, scene, self.road_map.crosswalks,
                                 geometry=True)
        base = collision_free_totals(ev)  # (L, A, C), predicted collisions excluded
        scale = self._candidates.plan_dt_s / DT_S
        v_ref = self.traffic.grid_mps
        speed = (self.config.theta_hat.speed * scale
                 * ((ev.v[None] - v_ref[:, None, None, None]) ** 2).sum(axis=-1))  # (V, A, C)
        return (base[:, None] + speed[None]).min(axis=-1)

    def _executed(self, v0: float) -> np.ndarray:
        """(A,) accelerations the candidate first actions execute as at speed v0 [m/s^2]."""
        veh = self.model.vehicle
        a = np.clip(self._first, -veh.brake_max_mps2, veh.accel_max_mps2)
        return np.maximum(a, -max(v0, 0.0) / DT_S)

    def _human_log_likelihood(self, prev: _HumanState, a_est: float):
        """(L, V) log P(a_est | x_l, v) of one human, and its updated rationality belief (B,).
        With a fixed beta_hat this is eq. 10; with a beta grid the likelihood is marginalized
        over the human's beta belief, which is then updated with the predicted joint b(l, v).
        """
        cfg = self.config
        if not len(self._beta_grid):
            return action_log_likelihood(prev.q_values, cfg.beta_hat, a_est, prev.actions_mps2,
                                         cfg.accel_noise_mps2, cfg.outlier_prob), prev.beta_belief
        ll = np.stack([action_log_likelihood(prev.q_values, beta, a_est, prev.actions_mps2,
                                             cfg.accel_noise_mps2, cfg.outlier_prob)
                       for beta in self._beta_grid])  # (B, L, V)
        if not np.all(np.isfinite(ll)):
            return np.zeros(ll.shape[1:]), prev.beta_belief
        log_b = np.log(prev.beta_belief)[:, None, None]
        marginal = _logsumexp((ll + log_b).reshape(len(ll), -1), axis=0).reshape(ll.shape[1:])
        joint = np.outer(self.transition @ self.probabilities,
                         self.traffic.transition @ self.traffic.probabilities)
        top = ll.max()
        evidence = (np.exp(ll - top) * joint[None]).sum(axis=(1, 2))  # (B,) up to a constant
        beta_belief = bayes_update(evidence, prev.beta_belief)
        beta_belief = normalize(np.maximum(beta_belief, cfg.floor))
        return marginal, beta_belief

    def beta_beliefs(self) -> dict:
        """{human name: (B,) belief over its rationality on config.beta_grid_hat} for the humans
        tracked now (social+beta only; empty otherwise).
        """
        if not len(self._beta_grid):
            return {}
        return {self.agent_names[oid - 1]: h.beta_belief.copy() for oid, h in self._humans.items()}

    def _social_log_likelihoods(self, decoded, tracks: TrackSet):
        """Eq. 9-10 and 12 for every tracked human seen this step and the last: (H, L, V)
        log P(a_obs,i | x_l, v) and {name: a_obs [m/s^2]}. The action distribution predicted
        at the previous step is scored with the acceleration observed since.
        """
        cfg = self.config
        out, a_obs_all = [], {}
        current = {}
        for k, oid in enumerate(tracks.ids.tolist()):
            route = self._human_routes.get(oid)
            if route is None or tracks.is_pedestrian[k] or not tracks.seen[k]:
                continue
            x, y = (float(v) for v in tracks.xy[k])
            s0, _ = route.project_point(x, y)
            _, heading = route.point_at(s0)
            heading = float(heading)
            vx, vy = (float(v) for v in tracks.velocity[k])
            v = vx * math.cos(heading) + vy * math.sin(heading)
            prev = self._humans.get(oid)
            a_est, n_seen = 0.0, 1
            beta_belief = self._beta_prior
            if prev is not None:
                a_est, n_seen = (v - prev.v_mps) / DT_S, prev.n_seen + 1
                a_obs_all[self.agent_names[oid - 1]] = a_est
                beta_belief = prev.beta_belief
                if n_seen > cfg.min_track_steps:
                    ll, beta_belief = self._human_log_likelihood(prev, a_est)
                    out.append(ll)
            others = self._others_scene(np.array([x, y]), heading, oid, decoded, tracks)
            v0 = max(v, 0.0)
            q = self.human_q_values(route, s0, v0, a_est, others)
            current[oid] = _HumanState(v, q, self._executed(v0), n_seen, beta_belief)
        self._humans = current  # a human not seen this step starts afresh when seen again
        n, n_v = len(self.hypotheses), len(self.traffic.grid_mps)
        return np.array(out).reshape(-1, n, n_v), a_obs_all

"""The robot's social perception (Sun et al. 2019, section III-B-2, eq. 9-12, Algorithm 1).

The robot keeps two discrete beliefs, built only from its own observation vector each step and
the static map (never the world):

* `HiddenAgentBelief` (`PedestrianBelief` is the same class): hidden physical states x_l,
  l = 1..L (`Hypothesis`, hypotheses.py): "none" (no hidden agent) and
  - for each curb end of each crosswalk, "a pedestrian is progress_m along this crossing and
    walks at speed_mps" for a few progress and speed bins: at the curb entry (the paper's
    "steps off the curb now") and already on the road;
  - for each lane that crosses or merges into the robot's route with the right of way there
    (conflicts.py: from the map the robot may know and its own route only), "a vehicle is
    progress_m along this lane and drives at speed_mps", in progress bins upstream of the
    point where it meets the route and speed bins around the speed limit (paper Fig. 1 b).
  The hypotheses are mutually exclusive: at most one hidden agent at a time.
* `TrafficSpeedBelief` (bayes.py): the social information I = v_traffic over a small grid
  (eq. 12).

Each step (Algorithm 1, in log space; 0.1 s per step):

1. prediction: the motion model (hypotheses.motion_transition): hypothesised agents move on
   along their path (mass moves to the next progress bin at their speed, and to "none" once
   they have crossed or passed the conflict), new ones arrive at the entry bins and
   hypothesised ones vanish at `hazard_per_s` (pedestrians) and `vehicle_hazard_per_s`
   (beliefs never lock); a small Markov transition between traffic speeds;
2. own sensors (own_sensors.py): positive information from a pedestrian the robot sees
   crossing or a vehicle it sees driving along a lane with the right of way, negative
   information from the part of each hypothesis' region its depth rays show empty;
3. social information (social.py, eq. 9-10, 12): each human driver the robot tracks is a
   sensor, its observed acceleration weighed under the robot's model of the human for every
   (hypothesis l, traffic speed v); humans multiply (eq. 12);
4. normalization, with a floor (beliefs are never NaN or all-zero).

The update is done on the joint b(l, v) ∝ b(l) b(v) P(own | l) prod_i P(a_i | l, v) and stored
as its two marginals (Algorithm 1's "fuse" step), so that a human braking for a pedestrian (or
waiting for a vehicle) is not read as slow traffic, nor a slow human as a pedestrian.

beta_hat defaults to 0.3, not the humans' own 5: Q* is in simulator-step cost units with a
crosswalk weight of 1000, and an error of ~0.1 m/s in the robot's estimate of the human's speed
moves the human's best first action between -2 and -8 m/s^2 when it is stopping before a
crosswalk; with beta_hat = 5 the model is then confidently wrong and the belief swings. beta_hat
absorbs the robot's state-estimation error (measured in tests/perception/belief and the report).

Everything the robot assumes about the humans is its own (BeliefConfig): theta_hat
(config.ROBOT_THETA_HAT), beta_hat, the humans' assumed view (a generic driver's 50 m, 70 deg),
the traffic-speed grid (fractions of the posted limit), and each human's path (the lane its
track drives in, paths.py) -- none is read from the scenario's truth or an agent's name.
"""

from __future__ import annotations

import numpy as np

from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.belief.bayes import (
    TrafficSpeedBelief,
    joint_bayes_update,
    normalize,
)
from marl_social.perception.belief.config import BeliefConfig
from marl_social.perception.belief.conflicts import vehicle_hypotheses
from marl_social.perception.belief.hypotheses import (
    KINDS,
    crosswalk_hypotheses,
    hypothesis_objects,
    motion_transition,
    stationary_distribution,
)
from marl_social.perception.belief.own_sensors import OwnSensors
from marl_social.perception.belief.social import SocialLikelihood
from marl_social.perception.tracking import Tracker
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import DecodedObservation, ObservationLayout
from marl_social.sim.road_map import RoadMap, Route


class HiddenAgentBelief:
    """The robot's belief over hidden agents: crossing pedestrians, vehicles (Algorithm 1).

    Built from the robot's own observations and the static map only.

    Args:
        road_map: the static map the robot may know (`RoadMap.for_agent(robot_name)`:
            crosswalks, lanes, conflict zones, speed limit and the robot's own route; other
            agents' routes are never read).
        layout: the shared observation layout.
        robot_name: the robot's agent name.
        agent_names: names of object ids in the debugging outputs only (object id k is
            agent_names[k - 1] when given, else "object_<k>"); human drivers are the tracked
            vehicles in one of the map's lanes, whatever their names.
        config: BeliefConfig.
        use_social: fold in the humans' behaviour (eq. 9-10, and eq. 12 for v_traffic).
        use_own_sensors: fold in the robot's own detections and negative information.
        tracker: the robot's Kalman tracker of others (default: Tracker with the robot's own
            sensor noise config.track_pos_noise_m, config.track_vel_noise_mps and process noise
            config.track_accel_noise_mps2).

    Attributes:
        hypotheses: the L hypotheses, "none" first.
        probabilities: (L,) current belief.
        traffic: TrafficSpeedBelief (eq. 12).
        own_sensors: OwnSensors, the likelihood of the robot's own detections.
        social: SocialLikelihood, the robot's model of the humans (eq. 9-11).
        model: the DriverModel the robot assumes for a human (social.model).
        perceived: 1.0 if the robot currently sees a pedestrian crossing (or stepping onto) a
            crosswalk, else 0.0 (the paper's "perceived probability"). A pedestrian standing on
            the sidewalk is not a crossing pedestrian.
        perceived_kinds: {kind: whether the robot currently sees an agent of that kind that
            matches one of its hypotheses} ("pedestrian", "vehicle").
        last_likelihoods: this step's likelihoods (each scaled to max 1): "own" (L,), "social"
            (L,), "traffic" (V,), "visible_fraction" (L,), "detected" (L,) bool, "a_obs"
            {human name: observed acceleration [m/s^2]}.
        tracks: the robot's tracks after the last update (tracker.tracks() then; the
            planner reads them rather than building them again).
    """

    def __init__(self, road_map: RoadMap, layout: ObservationLayout, robot_name: str,
                 agent_names: list[str], config: BeliefConfig | None = None,
                 use_social: bool = True, use_own_sensors: bool = True,
                 tracker: Tracker | None = None):
        """Build the hypotheses, the traffic-speed belief and the evidence models."""
        self.config = config = config or BeliefConfig()
        self.road_map = road_map
        self.layout = layout
        self.robot_name = robot_name
        self.agent_names = list(agent_names)
        self.use_social = bool(use_social)
        self.use_own_sensors = bool(use_own_sensors)
        self.hypotheses = crosswalk_hypotheses(road_map, config.walk_speeds_mps,
                                               config.curb_offset_m, config.progress_step_m)
        self.hypotheses += vehicle_hypotheses(
            road_map, road_map.routes.get(robot_name), config.vehicle_speed_fractions,
            config.vehicle_progress_step_m, config.vehicle_upstream_s)
        self._present = np.array([h.present for h in self.hypotheses])
        self._kinds = np.array([h.kind for h in self.hypotheses])
        self._kind_masks = [(kind, self._kinds == kind) for kind in KINDS]
        self._objects_at: tuple | None = None  # (time grid, hypotheses) -> hypothesis_objects
        self.transition = motion_transition(self.hypotheses, DT_S, config.hazards_per_s())
        self.prior = self._prior()
        self.tracker = tracker or Tracker(pos_noise_m=config.track_pos_noise_m,
                                          vel_noise_mps=config.track_vel_noise_mps,
                                          accel_noise_mps2=config.track_accel_noise_mps2)
        self.traffic = TrafficSpeedBelief(config.traffic_grid_mps(road_map.speed_limit_mps),
                                          config.traffic_hazard_per_s * DT_S,
                                          config.floor)
        self._joint_transition = np.kron(self.transition, self.traffic.transition)
        n_v = len(self.traffic.grid_mps)
        self._no_humans = np.zeros((0, len(self.hypotheses), n_v))  # (H = 0, L, V)
        self.own_sensors = OwnSensors(self.hypotheses, config)
        self.social = SocialLikelihood(road_map, self.agent_names, self.hypotheses,
                                       self.traffic.grid_mps, config)
        self.model = self.social.model
        self.reset()

    # -- public API -------------------------------------------------------------------------
    def _prior(self) -> np.ndarray:
        """(L,) the prior: the motion model's long-run distribution (BeliefConfig.prior_present)."""
        if not self._present.any():
            return np.ones(len(self.hypotheses))
        longrun = stationary_distribution(self.transition)
        if longrun[self._present].sum() <= 0.0:
            longrun[self._present] = 1.0
        present_mass = self.config.prior_present
        if present_mass is None:
            return normalize(np.maximum(longrun, self.config.floor))
        prior = np.where(self._present, longrun, 0.0)
        prior *= present_mass / prior.sum()
        prior[~self._present] = 1.0 - present_mass
        return normalize(np.maximum(prior, self.config.floor))

    def reset(self) -> None:
        """Back to the prior (call at every episode start)."""
        self.probabilities = self.prior.copy()
        self.tracker.reset()
        self.tracks = self.tracker.tracks()
        self.traffic.reset()
        self.social.reset()
        self.perceived = 0.0
        self.perceived_kinds = dict.fromkeys(KINDS, False)
        self.last_likelihoods: dict = {}

    def p_hidden(self, kind: str) -> float:
        """Belief that an agent of this kind is present where the robot cannot rule it out.

        1 when the robot sees one matching a hypothesis (perceived_kinds), 0 without
        hypotheses of that kind, else the mass of that kind's hypotheses, as 1 - the mass of
        all others ("none" included).

        Args:
            kind: "pedestrian" or "vehicle".
        """
        if kind not in KINDS:
            raise ValueError(f"p_hidden: kind must be one of {KINDS}, got {kind!r}")
        if self.perceived_kinds[kind]:
            return 1.0
        if not np.any(self._kinds == kind):
            return 0.0
        return max(float(1.0 - self.probabilities[self._kinds != kind].sum()), 0.0)

    @property
    def p_pedestrian(self) -> float:
        """Belief that a crossing pedestrian is present: 1 when perceived (`p_hidden`)."""
        return self.p_hidden("pedestrian")

    @property
    def p_vehicle(self) -> float:
        """Belief that a hidden vehicle is coming to the robot's route (`p_hidden`)."""
        return self.p_hidden("vehicle")

    def path_probabilities(self) -> dict:
        """{path name ("crossing_right", ...): belief that a hidden agent is on it} (sums bins)."""
        out: dict = {}
        for h, p in zip(self.hypotheses, self.probabilities):
            if h.present:
                out[h.path] = out.get(h.path, 0.0) + float(p)
        return out

    def live(self, epsilon: float | None = None) -> np.ndarray:
        """(L,) bool: hypotheses with belief >= epsilon, the ones the planner keeps.

        Args:
            epsilon: the paper's tail threshold (default config.epsilon).
        """
        eps = self.config.epsilon if epsilon is None else float(epsilon)
        return self.probabilities >= eps

    def update(self, obs) -> np.ndarray:
        """Fold in one observation of the robot and return the (L,) posterior.

        Algorithm 1 order: prediction, own sensors, social information, normalization. The
        pedestrian hypotheses x_l and the traffic speed v are updated jointly,
        b(l, v) ∝ b(l) b(v) P(own | l) prod_i P(a_i | l, v)  (eq. 9 and 12), and stored as
        their marginals, so that a human braking for a pedestrian is not also read as slow
        traffic (and the other way round).

        Args:
            obs: (layout.size,) the robot's observation vector.
        """
        decoded = self.layout.decode(obs)
        n = len(self.hypotheses)
        tracks = self.tracker.update(decoded)
        self.tracks = tracks
        if self.use_own_sensors:
            ll_own, visible, detected = self.own_sensors.log_likelihood(decoded, tracks)
            any_detected = bool(detected.any())
        else:
            ll_own, visible, detected = np.zeros(n), np.zeros(n), np.zeros(n, dtype=bool)
            any_detected = False
        self.perceived_kinds = ({k: bool(detected[mask].any()) for k, mask in self._kind_masks}
                                if any_detected else dict.fromkeys(KINDS, False))
        self.perceived = 1.0 if self.perceived_kinds["pedestrian"] else 0.0
        pred_l = self.transition @ self.probabilities
        pred_v = self.traffic.transition @ self.traffic.probabilities
        ll_social = self._no_humans
        a_obs = {}
        if self.use_social:
            ll_social, a_obs = self.social.log_likelihoods(decoded, tracks,
                                                           np.multiply.outer(pred_l, pred_v))
            if any_detected:
                # the robot sees the hidden agent itself: the humans' behaviour is read under
                # the most probable detected hypothesis (informative about v_traffic only),
                # not as evidence about agents it can see
                seen = np.flatnonzero(detected)
                best = seen[np.argmax(self.probabilities[seen])]
                ll_social = np.broadcast_to(ll_social[:, best:best + 1, :], ll_social.shape)
        _, self.probabilities, self.traffic.probabilities, social, own = joint_bayes_update(
            self.probabilities, self.traffic.probabilities, ll_own, ll_social,
            self._joint_transition, self.config.floor)
        # per-source summaries for debugging: social evidence about l (about v) marginalized
        # over v (over l) with the predicted beliefs
        by_l, by_v = social @ pred_v, pred_l @ social
        self.last_likelihoods = {
            "own": own, "social": by_l / by_l.max(),
            "traffic": by_v / by_v.max(), "visible_fraction": visible, "detected": detected,
            "a_obs": a_obs,
        }
        return self.probabilities.copy()

    # -- the parts, by their historical names -----------------------------------------------
    def visible_fraction(self, decoded: DecodedObservation) -> np.ndarray:
        """(L,) fraction of each hypothesis' region the robot sees free (OwnSensors).

        Args:
            decoded: the robot's decoded observation.
        """
        return self.own_sensors.visible_fraction(decoded)

    def match_vehicles(self, xy, velocity) -> np.ndarray:
        """(L,) bool: hypotheses matching the seen vehicles (OwnSensors).

        Args:
            xy: (n, 2) seen vehicles' positions [m].
            velocity: (n, 2) their velocities [m/s].
        """
        return self.own_sensors.match_vehicles(xy, velocity)

    def hypothesis_objects(self, times_s) -> tuple:
        """Each hypothesis' hidden agent at times_s (T,) [s], for the robot's own planner.

        The arguments of ScenePrediction.with_extra (hypotheses.hypothesis_objects): a planner's
        scenes are `ScenePrediction.from_tracks(tracks, times_s).with_extra(*this)`; a
        hypothesised vehicle has a car's footprint and heading along its lane and is not a
        pedestrian.
        """
        times = np.asarray(times_s, dtype=np.float64)
        key = (times.tobytes(), len(self.hypotheses))
        cached = self._objects_at
        if cached is None or cached[0] != key or cached[1] is not self.hypotheses:
            objects = hypothesis_objects(self.hypotheses, times)
            for array in objects:  # shared by every call at this time grid
                array.setflags(write=False)
            self._objects_at = cached = (key, self.hypotheses, objects)
        return cached[2]

    def match_pedestrians(self, xy, velocity) -> np.ndarray:
        """(L,) bool: hypotheses matching the seen pedestrians (OwnSensors).

        Args:
            xy: (n, 2) seen pedestrians' positions [m].
            velocity: (n, 2) their velocities [m/s].
        """
        return self.own_sensors.match_pedestrians(xy, velocity)

    def hypothesis_scene(self, others: ScenePrediction | None = None,
                         viewer: tuple | None = None) -> ScenePrediction:
        """The L scenes the human is modelled against (SocialLikelihood).

        Args:
            others: one-hypothesis scene of the other objects (None: nothing else).
            viewer: (xy (2,) [m], heading [rad]) of the human: hypothesised vehicles outside
                its assumed view are left out (None: all in).
        """
        return self.social.prediction.scenes.hypothesis_scene(others, viewer)

    def human_q_values(self, route: Route, s0: float, v0: float, prev_accel: float,
                       others: ScenePrediction | None = None,
                       negligible: np.ndarray | None = None,
                       speed_std_mps: float | None = None) -> np.ndarray:
        """(L, V, A) Q*_H(x_l, v, u) of a human, one rollout (SocialLikelihood).

        Args:
            route: the human's route.
            s0: its arc length along the route [m].
            v0: its along-route speed [m/s].
            prev_accel: its previous acceleration [m/s^2].
            others: one-hypothesis scene of the other objects the human reacts to.
            negligible: (L,) bool, hypotheses left out of the human's scene (None: none).
            speed_std_mps: the std of v0 [m/s]: (3, L, V, A) from the speeds about v0 that
                action_model.speed_averaged_log_likelihood weighs (None: (L, V, A) at v0).
        """
        return self.social.prediction.human_q_values(route, s0, v0, prev_accel, others, negligible,
                                          speed_std_mps)

    def beta_beliefs(self) -> dict:
        """{human name: (B,) rationality belief} of the humans tracked now (social+beta only)."""
        return self.social.beta_beliefs()


PedestrianBelief = HiddenAgentBelief  # the name from before vehicles were hypothesised

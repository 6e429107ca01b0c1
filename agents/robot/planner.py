"""The robot's planners: the same contingency MPC (agents/robot/mpc.py), different beliefs.

* ``social`` (the paper): beliefs over hidden pedestrians from the robot's own sensors
  (negative information) and from the humans' behaviour (eq. 9-10), perception/belief/.
* ``social+beta`` (beyond the paper): ``social`` that also infers each human's rationality
  beta on a grid (BeliefConfig.beta_grid_hat; confidence-aware prediction, Fridovich-Keil et
  al. 2019), so an erratic human's behaviour moves the belief less.
* ``aggressive``: what is not seen is absent (no hidden-pedestrian hypotheses).
* ``conservative``: every hidden-pedestrian hypothesis its own sensors have not ruled out is
  assumed true (no social inference).
* ``oracle``: perfect perception, an upper bound: it is the one planner given the true current
  state of every agent (``needs_truth``; through ``observe_truth``, called by `run_episode`
  and the autopilot), with no hidden hypotheses. It knows where everybody is, not what they
  will decide.

Every planner's scenes are its tracked objects (the oracle: the truth) in every branch plus,
per hypothesis, that hypothesis' hidden agent (a pedestrian, or a car on its lane; the belief's
`hypothesis_objects`). A tracked car in a lane is predicted along its lane path at its speed
along it, the rest at constant velocity (agents/robot/track_prediction.py). At conflict zones
where the robot yields, a car with the right of way predicted there claims the zone in its
branch (agents/robot/right_of_way.py): the robot waits or clears the zone well before the car
arrives. So the oracle gives way to the hidden car it knows of from the start, the
conservative planner to every hidden car it cannot rule out, the aggressive one only to a car
it sees, and the social one to those its belief holds. With the
planner parameter "sight_hold" (off by default) a belief-based planner pulling out of a stop
sign also holds short of the lane it cannot see while a human that will tell is still coming
(agents/robot/sight_hold.py).

All but the oracle act on the robot's own observation and the static map only. Each planner is
one `RobotVariant` (data, in `ROBOT_VARIANTS`); agents/registry.py registers them by name.

The robot's model of the humans and its tail threshold come from its own spec's planner
parameters (the robot's private knowledge; scenario knobs robot_theta_hat, robot_beta_hat,
robot_epsilon): "theta_hat" (cost weights, e.g. learned by agents/irl/), "beta_hat",
"epsilon" (agents/params.RobotModelParams).

At a signalized junction (a map with a signal plan) every planner obeys its own head as it reads
it (agents/robot/signal_stop.py: right turn on red after stopping) and keeps a belief over the
signal phase (perception/belief/phase.py; from its own head, and for ``social`` also from the
humans' behaviour). The MPC's branches then split by what the signalled traffic does
(agents/robot/phase_branches.py): ``social`` weighs "stops at its line" against "drives on" by
its phase belief, ``oracle`` by the true phase (``observe_truth``'s signal_phase),
``aggressive`` assumes the favourable phase (every signalled car stops at its line) and
``conservative`` that none does (it waits for the cross traffic to stop or pass).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from marl_social.agents.params import RobotModelParams, parse_planner_params
from marl_social.agents.robot.curb import CurbConfig, CurbPedestrians
from marl_social.agents.robot.mpc import ContingencyMpc
from marl_social.agents.robot.mpc_types import MpcConfig, MpcResult
from marl_social.agents.robot.phase_branches import PhaseBranches
from marl_social.agents.robot.right_of_way import RightOfWay, RightOfWayConfig
from marl_social.agents.robot.sight_hold import SightHold, SightHoldConfig
from marl_social.agents.robot.signal_stop import SignalStops
from marl_social.agents.robot.stop import StopSignConfig, StopSigns, pull_up_target
from marl_social.agents.robot.track_prediction import along_lane_paths
from marl_social.agents.robot.variants import ROBOT_VARIANTS, HypothesisWeighting, RobotVariant
from marl_social.models.candidates import ScenePrediction
from marl_social.models.steering import pure_pursuit
from marl_social.perception.belief import BeliefConfig, PedestrianBelief
from marl_social.perception.belief.phase import SignalPhaseBelief
from marl_social.perception.tracking import TrackSet
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.dynamics import DT_S
from marl_social.sim.observation import ObservationLayout
from marl_social.sim.road_map import RoadMap

BETA_GRID_HAT = (0.03, 0.1, 0.3, 1.0, 3.0)  # social+beta: rationality grid (log-spaced)
CONSERVATIVE_WALK_SPEED_MPS = 1.3  # conservative: its hypothesised pedestrians' speed [m/s]
TRACKED_REACH_M = 3.0  # a pedestrian tracked this close to a crosswalk is its pedestrian [m]
# the MPC's QP layouts of up to this many live branches are built with the planner, not at the
# first plan that meets them (ContingencyMpc.build_layouts; once per process): the three
# benchmark scenarios' episodes meet at most 9
PREBUILT_BRANCHES = 10


def _variant(planner: str | RobotVariant) -> RobotVariant:
    if isinstance(planner, RobotVariant):
        return planner
    if planner not in ROBOT_VARIANTS:
        raise ValueError(f"robot planner {planner!r}: must be one of {tuple(ROBOT_VARIANTS)}")
    return ROBOT_VARIANTS[planner]


def robot_configs(spec: AgentSpec, planner: str | RobotVariant = "social",
                  params: RobotModelParams | None = None) -> tuple[MpcConfig, BeliefConfig]:
    """The MPC and belief configuration of a robot from its spec (see module docstring).

    The belief's tracker gets the robot's own sensor noise (spec.sensor.pos_noise_m,
    vel_noise_mps); everything else the robot assumes about the humans is the robot's own
    (BeliefConfig's documented defaults unless spec.planner sets theta_hat / beta_hat).

    Args:
        spec: the robot's AgentSpec (its cost weights theta_R and planner parameters).
        planner: a name of ROBOT_VARIANTS or a RobotVariant.
        params: the robot's model of the humans (default: parsed from spec.planner).

    Raises:
        ValueError: an unknown planner, or a planner parameter unknown or out of range.
    """
    variant = _variant(planner)
    params = params or parse_planner_params(RobotModelParams, spec)
    belief = BeliefConfig()
    updates = {"epsilon": belief.epsilon if params.epsilon is None else params.epsilon,
               # the tracker filters with the robot's own sensor noise
               "track_pos_noise_m": spec.sensor.pos_noise_m,
               "track_vel_noise_mps": spec.sensor.vel_noise_mps}
    if params.theta_hat is not None:
        updates["theta_hat"] = params.theta_hat
    if params.beta_hat is not None:
        updates["beta_hat"] = params.beta_hat
    if params.human_expects_yield:
        updates["human_expects_yield"] = True
    if variant.infer_beta:
        updates["beta_grid_hat"] = BETA_GRID_HAT
    if variant.weighting is HypothesisWeighting.PRESENT_LIVE:
        # the conservative baseline assumes the worst at every curb it cannot see: a pedestrian
        # stepping off right now (the paper's single pattern per curb), not one that may have
        # walked on; split into progress and speed bins, each bin would fall below epsilon
        updates["progress_step_m"] = None
        updates["walk_speeds_mps"] = (CONSERVATIVE_WALK_SPEED_MPS,)
    return (MpcConfig(epsilon=updates["epsilon"]),
            replace(belief, **updates))


class RobotPlanner:
    """Contingency-MPC robot (see module docstring).

    Args:
        spec: the robot's AgentSpec.
        layout: the shared observation layout.
        road_map: the static map.
        agent_names: the env's possible_agents (public: maps object ids to names / routes).
        planner: a name of ROBOT_VARIANTS ("social", ..., "oracle") or a RobotVariant.
        mpc_config: overrides the MPC configuration from the spec.
        belief_config: overrides the belief configuration from the spec.
        params: the robot's model of the humans (default: parsed from spec.planner).
        curb_config: the robot's model of pedestrians waiting at a crosswalk (agents/robot/
            curb.py; default CurbConfig()).
        stop_config: when it counts as having stopped at a stop sign (agents/robot/stop.py;
            default StopSignConfig()).
        right_of_way_config: when a car with the right of way claims a conflict zone the
            robot yields at (agents/robot/right_of_way.py; default RightOfWayConfig()).
        sight_hold_config: where it holds short of a lane it cannot see, while a human that
            will tell it of a hidden car is still coming (agents/robot/sight_hold.py; default
            SightHoldConfig() with the MPC's comfort_decel_mps2).
    """

    def __init__(self, spec: AgentSpec, layout: ObservationLayout, road_map: RoadMap,
                 agent_names: list[str], planner: str | RobotVariant = "social",
                 mpc_config: MpcConfig | None = None, belief_config: BeliefConfig | None = None,
                 params: RobotModelParams | None = None, curb_config: CurbConfig | None = None,
                 stop_config: StopSignConfig | None = None,
                 right_of_way_config: RightOfWayConfig | None = None,
                 sight_hold_config: SightHoldConfig | None = None):
        self.variant = _variant(planner)
        params = params or parse_planner_params(RobotModelParams, spec)
        self.needs_truth = self.variant.needs_truth
        self.name = spec.name
        self.spec = spec
        self.layout = layout
        self.road_map = road_map
        self.route = road_map.routes[spec.name]
        default_mpc, default_belief = robot_configs(spec, self.variant, params)
        self.mpc = mpc_config or default_mpc
        self.v_desired = min(spec.v_desired_mps, road_map.speed_limit_mps)
        self.solver = ContingencyMpc(self.mpc, spec.vehicle)
        self.solver.build_layouts(PREBUILT_BRANCHES)
        # the belief keeps the robot's Kalman tracks of what it sees; the MPC reads the same ones
        self.belief = PedestrianBelief(
            road_map, layout, spec.name, list(agent_names), belief_config or default_belief,
            use_social=self.variant.use_social,
            use_own_sensors=self.variant.use_own_sensors,
        )
        self._times = self.mpc.plan_times_s
        # each hypothesis' hidden agent at the plan times: fixed, computed once
        self._hypothesis_objects = self.belief.hypothesis_objects(self._times)
        self._hypothesis_crosswalk = np.array(
            [h.crosswalk_index if h.kind == "pedestrian" else -1 for h in self.belief.hypotheses])
        # (L,) bool each, fixed with the hypotheses: the hidden agent present, a vehicle
        self._present = np.array([h.present for h in self.belief.hypotheses])
        self._vehicle = np.array([h.kind == "vehicle" for h in self.belief.hypotheses])
        for flags in (self._present, self._vehicle):
            flags.setflags(write=False)
        self._truth: TrackSet | None = None
        veh = spec.vehicle
        self.curb = CurbPedestrians(
            self.route, road_map.crosswalks, curb_config or CurbConfig(), veh.length_m,
            self.mpc.pedestrian_gap_m,
            0.5 * veh.width_m + self.mpc.pedestrian_clearance_m)
        self.stop_signs = StopSigns(self.route, road_map, veh.length_m, stop_config)
        self.right_of_way = RightOfWay(self.route, road_map, veh.length_m, right_of_way_config,
                                       veh.accel_max_mps2, self.mpc.lat_accel_max_mps2)
        # at a stop sign, with the belief's hypotheses (one of them "none") as the MPC's first
        # branches: not with a signal plan, whose phases multiply the branches
        hold = (params.sight_hold and bool(self.stop_signs.lines_m.size)
                and road_map.signal_plan is None and bool((~self._present).any()))
        self.sight_hold = SightHold(
            self.right_of_way, self.belief.social, hold, veh.length_m, self.mpc.plan_dt_s,
            self.mpc.epsilon, self.stop_signs.config,
            sight_hold_config or SightHoldConfig(comfort_decel_mps2=self.mpc.comfort_decel_mps2))
        self._hidden_vehicle = self._present & self._vehicle
        self._none_index = int(np.argmin(self._present))  # the "none" hypothesis
        self.signal_stops = SignalStops(self.route, road_map, veh.length_m, stop_config)
        self.phase_belief = None
        if road_map.signal_plan is not None:
            self.phase_belief = SignalPhaseBelief(road_map, spec.name, self.belief.social,
                                                  self.belief.config,
                                                  use_social=self.variant.use_social)
            self.phase_branches = PhaseBranches(road_map, self.belief.social.lane_paths,
                                                self.phase_belief.head_states,
                                                veh.brake_max_mps2, self.mpc.epsilon)
        self._true_phase: int | None = None
        self._static_boxes = np.array(
            [[*p.min(axis=0), *p.max(axis=0)] for p in road_map.static_polygons]).reshape(-1, 4)
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        """Start a new episode: fresh belief, QPs, stop-sign and curb state (`seed`: unused)."""
        self.belief.reset()
        self.solver.reset()
        self.curb.reset()
        self.stop_signs.reset()
        self.signal_stops.reset()
        if self.phase_belief is not None:
            self.phase_belief.reset()
        self.prev_accel = 0.0
        self.last_result: MpcResult | None = None
        self.weights = None

    def observe_truth(self, tracks: TrackSet, signal_phase: int | None = None) -> None:
        """Give the planner the true current state of every other agent (oracle only).

        Args:
            tracks: the true state of every other active agent (envs/policies.truth_tracks).
            signal_phase: the signal plan's running phase (envs/policies.truth_signal_phase;
                None: no signals).

        Raises:
            RuntimeError: the planner does not have `needs_truth`.
        """
        if not self.needs_truth:
            raise RuntimeError(f"robot {self.name}: only a planner with needs_truth (the oracle) "
                               "may read the true state")
        self._truth = tracks
        self._true_phase = signal_phase

    def hypothesis_weights(self) -> np.ndarray:
        """(L,) the weights the MPC plans with, by the variant's HypothesisWeighting.

        The belief for `social`, every live present hypothesis for `conservative` (a hidden
        car's: every one not ruled out by its sensors), only "none" for `aggressive` and
        `oracle`.
        """
        none = ~self._present
        weighting = self.variant.weighting
        if weighting is HypothesisWeighting.NONE_ONLY:
            return none.astype(np.float64)
        b = self.belief.probabilities
        if weighting is HypothesisWeighting.BELIEF:
            return b
        present_live = ~none & (b >= self.mpc.epsilon)
        # a hidden car is one of many small progress and speed bins, each below epsilon: the
        # conservative robot keeps every one its sensors have not ruled out (its belief, from
        # its own sensors only, still at least epsilon times its prior)
        present_live |= self._vehicle & (b >= self.mpc.epsilon * self.belief.prior)
        if not present_live.any():
            return none.astype(np.float64)
        return present_live / present_live.sum()

    def v_ref(self) -> float:
        """The speed the MPC tracks [m/s].

        A planner that reads the humans (use_social) tracks the traffic speed it believes in
        (eq. 12, the belief's mean, `belief.traffic.expected_mps`), capped at the speed limit;
        the others track the robot's own desired speed.
        """
        traffic = getattr(self.belief, "traffic", None)
        if self.variant.use_social and traffic is not None:
            return min(float(traffic.expected_mps), self.road_map.speed_limit_mps)
        return self.v_desired

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The (2,) [acceleration m/s^2, steering rad] for the robot's observation (obs_dim,)."""
        decoded = self.layout.decode(obs)
        x, y, c, s_, v = (float(a) for a in decoded.ego[:5])
        psi = math.atan2(s_, c)
        if self.needs_truth:
            if self._truth is None:
                raise RuntimeError("oracle planner: observe_truth() must be called every step")
            tracks = self._truth
        else:
            self.belief.update(obs)  # own tracks (+ negative / social information by variant)
            tracks = self.belief.tracks
        weights = self.hypothesis_weights()
        # contingencies (comfortable braking, a factor of the comfort weight per branch): a
        # hidden agent, a pedestrian stepping off the curb
        contingent = self._present
        # the tracked objects in every branch, each hypothesis' hidden agent in its own (a
        # hypothesised vehicle as a car on its lane)
        s0, _ = self.route.project_point(x, y)
        # a pedestrian walking up to the curb in front of a robot that can no longer stop
        # comfortably waits there (gap acceptance, agents/robot/curb.py)
        tracks = self.curb.walk_across(self.curb.hold_at_curb(tracks, s0, v))
        # the pedestrian hypotheses of a crosswalk at which the robot tracks a pedestrian are
        # about that pedestrian (the belief holds at most one hidden agent): the tracked one is
        # predicted, not a hypothesised copy (also while the robot does not see it, out of its
        # view as it drives past: the tracker keeps it where it was last seen)
        *hidden, present = self._hypothesis_objects
        present = present & ~self._tracked_crosswalks(tracks)
        # a tracked car in a lane along its lane path (track_prediction.py)
        scene = along_lane_paths(ScenePrediction.from_tracks(tracks, self._times), tracks,
                                 self.belief.social.lane_paths, self._times
                                 ).with_extra(*hidden, present)
        if self.phase_belief is not None:
            scene, weights, contingent = self._phase_branches(decoded, tracks, scene, weights,
                                                              contingent)
        # a pedestrian stepping off as a branch prepared for is met as that branch planned
        contingent = np.maximum(contingent, self.curb.prepared_comfort(tracks))
        step_xy, step_heading = self.curb.step_off(tracks, s0, v, DT_S, self._times)
        if len(step_xy):
            scene, weights = self._with_step_off(scene, weights, step_xy, step_heading)
            contingent = np.append(contingent, True)
        self.weights = weights
        stop_at = min(self.stop_signs.update(s0, v, DT_S),
                      self.signal_stops.update(s0, v, DT_S, decoded.signal_states()))
        claims = self.right_of_way.claims(scene, s0, v, self._times)
        # short of a lane it cannot see, it waits for a human that will tell, pulled up to
        # where it holds (sight_hold.py)
        hold_at = self.sight_hold.stop_at(claims, weights, self._hidden_vehicle,
                                          self._none_index, tracks, s0, v)
        pull_up = (self.sight_hold.pull_up_to(hold_at, s0, v) if hold_at < stop_at
                   else pull_up_target(stop_at, s0, v, self.stop_signs.config))
        stop_at = min(stop_at, hold_at)
        result = self.solver.plan(self.route, s0, v, self.prev_accel, self.v_ref(),
                                  self.road_map.speed_limit_mps, scene, weights,
                                  self._static_boxes, stop_at, contingent, claims, pull_up)
        self.last_result = result
        self.prev_accel = result.accel_mps2
        steer = pure_pursuit(self.route, x, y, psi, v, s0, self.spec.vehicle.wheelbase_m)
        return np.array([result.accel_mps2, steer], dtype=np.float32)

    def _tracked_crosswalks(self, tracks: TrackSet) -> np.ndarray:
        """(L,) bool: pedestrian hypotheses of a crosswalk with a tracked pedestrian near it.

        Near: within TRACKED_REACH_M of the crosswalk.

        Args:
            tracks: the robot's tracks.
        """
        ped_xy = tracks.xy[tracks.is_pedestrian]
        if not len(ped_xy):
            return np.zeros(len(self._hypothesis_crosswalk), dtype=bool)
        near = [i for i, cw in enumerate(self.road_map.crosswalks)
                if cw.contains(ped_xy, TRACKED_REACH_M).any()]
        # a few hypotheses and crosswalks: a comparison per crosswalk (np.isin sorts, ~0.1 ms)
        out = np.zeros(len(self._hypothesis_crosswalk), dtype=bool)
        for i in near:  # i >= 0: the vehicle hypotheses' -1 never matches
            out |= self._hypothesis_crosswalk == i
        return out

    def _phase_branches(self, decoded, tracks: TrackSet, scene: ScenePrediction,
                        weights: np.ndarray, contingent: np.ndarray) -> tuple:
        """Update the phase belief; the scene, weights and contingent flags per phase pattern.

        The phase weights by planner: the belief (social), the true phase (oracle), every
        signalled car stopping (aggressive), none (conservative: the tracks' prediction).
        """
        belief = self.phase_belief
        if self.needs_truth:
            if self._true_phase is not None:
                belief.set_phase(self._true_phase)
            phase_weights = belief.probabilities
        else:
            phase_weights = belief.update(decoded, tracks, self.v_ref())
        if self.variant.weighting is HypothesisWeighting.PRESENT_LIVE:
            phase_weights = np.zeros_like(phase_weights)  # no signalled car stops
        elif self.variant.weighting is HypothesisWeighting.NONE_ONLY and not self.needs_truth:
            phase_weights = None  # the favourable phase: every signalled car stops
        return self.phase_branches.expand(scene, weights, contingent, tracks, phase_weights,
                                          self._times)

    def _with_step_off(self, scene: ScenePrediction, weights: np.ndarray, xy: np.ndarray,
                       heading: np.ndarray) -> tuple[ScenePrediction, np.ndarray]:
        """The scene (L + 1 hypotheses) and weights (L + 1,) with the "steps off now" branch.

        The K pedestrians of xy (K, T, 2) and heading (K,) step off in the last hypothesis
        (the tracked objects, no hidden pedestrian), with probability CurbConfig.p_step_off;
        the L others, in which they keep waiting, share the rest.
        """
        n_hyp, n_k = scene.mask.shape[0], len(xy)
        for k in range(n_k):
            scene = scene.with_extra(np.broadcast_to(xy[k], (n_hyp,) + xy[k].shape),
                                     np.full((n_hyp, xy.shape[1]), heading[k]),
                                     np.full(n_hyp, 0.6), np.full(n_hyp, 0.6),
                                     np.ones(n_hyp, bool), np.zeros(n_hyp, bool))
        mask = scene.mask[:1].copy()
        mask[0, -n_k - 1] = False  # no hidden pedestrian
        mask[0, -n_k:] = True
        fields = [np.concatenate([a, a[:1]]) for a in
                  (scene.xy, scene.heading, scene.length_m, scene.width_m, scene.radius_m,
                   scene.is_pedestrian)]
        scene = ScenePrediction(*fields, np.concatenate([scene.mask, mask]))
        p = self.curb.config.p_step_off
        return scene, np.concatenate([(1.0 - p) * weights, [p]])

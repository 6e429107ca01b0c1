"""The stages of the robot's pipeline (agents/robot/pipeline.py), in the order they run.

| stage | runs where the route has | refines |
|---|---|---|
| `BeliefUpdate` | always | tracks, branch weights by the variant, v_ref |
| `CurbGapAcceptance` | a crosswalk | tracks: pedestrians waiting for it, walking across |
| `HypothesisBranches` | always | the scene of every hypothesis (tracks + its hidden agent) |
| `SignalBranches` | signal heads (a signal plan) | branches per signal pattern |
| `CrosswalkStepOff` | a crosswalk | the "steps off now" branch, its comfort |
| `StopLines` | a stop-sign or signal line | the stop target and the pull-up |
| `RightOfWayClaims` | a conflict zone it yields at | the zone claims per branch |
| `SightHoldStage` | a stop line before an occluded priority lane | a hold point |

The contingency MPC (agents/robot/mpc.py) then plans over the record. `build_stages` picks the
stages from the elements of the map along the robot's route, never from a scene's name.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from marl_social.agents.robot.curb import CurbPedestrians
from marl_social.agents.robot.mpc_types import MpcConfig
from marl_social.agents.robot.phase_branches import PhaseBranches
from marl_social.agents.robot.pipeline import PlanningRecord, Stage
from marl_social.agents.robot.right_of_way import RightOfWay
from marl_social.agents.robot.settings import RobotSettings
from marl_social.agents.robot.sight_hold import SightHold
from marl_social.agents.robot.signal_stop import SignalStops
from marl_social.agents.robot.stop import StopSigns, pull_up_target
from marl_social.agents.robot.track_prediction import along_lane_paths
from marl_social.agents.robot.variants import HypothesisWeighting, RobotVariant
from marl_social.models.scene_prediction import ScenePrediction
from marl_social.perception.belief import PedestrianBelief
from marl_social.perception.belief.phase import SignalPhaseBelief
from marl_social.sim.agent_spec import AgentSpec
from marl_social.sim.dynamics import DT_S
from marl_social.sim.road_map import RoadMap, Route

TRACKED_REACH_M = 3.0  # a pedestrian tracked this close to a crosswalk is its pedestrian [m]
STEP_OFF_SIZE_M = 0.6  # a pedestrian stepping off: its footprint's length and width [m]


@dataclass(frozen=True)
class RobotContext:
    """What the stages of one robot are built from.

    Attributes:
        spec: the robot's AgentSpec (its name, vehicle and desired speed).
        route: the robot's route.
        road_map: the static map.
        mpc: the MPC's configuration (plan times, epsilon, comfort, margins).
        belief: the robot's belief over hidden agents (its tracks, hypotheses, model of the
            humans).
        settings: the robot's settings (variant, model of the humans, stage configurations),
            every part resolved (settings.resolve_settings).
    """

    spec: AgentSpec
    route: Route
    road_map: RoadMap
    mpc: MpcConfig
    belief: PedestrianBelief
    settings: RobotSettings


class BeliefUpdate:
    """The belief update (eq. 9-12) and the branch weights by the planner variant.

    The oracle reads the truth instead (`PlanningRecord.truth`). The weights: the belief for
    `social`, every live present hypothesis for `conservative` (a hidden car's: every one not
    ruled out by its sensors), only "none" for `aggressive` and `oracle`.

    Args:
        belief: the robot's belief.
        variant: the planner variant.
        epsilon: the tail threshold (the MPC's).
        v_desired_mps: the robot's own desired speed, capped at the speed limit [m/s].
        speed_limit_mps: the map's speed limit [m/s].
    """

    def __init__(self, belief: PedestrianBelief, variant: RobotVariant, epsilon: float,
                 v_desired_mps: float, speed_limit_mps: float):
        self.belief, self.variant, self.epsilon = belief, variant, epsilon
        self.v_desired_mps, self.speed_limit_mps = v_desired_mps, speed_limit_mps
        # (L,) bool each, fixed with the hypotheses: the hidden agent present, a vehicle
        self.present = np.array([h.present for h in belief.hypotheses])
        self.vehicle = np.array([h.kind == "vehicle" for h in belief.hypotheses])
        for flags in (self.present, self.vehicle):
            flags.setflags(write=False)

    def reset(self) -> None:
        self.belief.reset()

    def weights(self) -> np.ndarray:
        """(L,) the weights the MPC plans with, by the variant's HypothesisWeighting."""
        none = ~self.present
        weighting = self.variant.weighting
        if weighting is HypothesisWeighting.NONE_ONLY:
            return none.astype(np.float64)
        b = self.belief.probabilities
        if weighting is HypothesisWeighting.BELIEF:
            return b
        present_live = ~none & (b >= self.epsilon)
        # a hidden car is one of many small progress and speed bins, each below epsilon: the
        # conservative robot keeps every one its sensors have not ruled out (its belief, from
        # its own sensors only, still at least epsilon times its prior)
        present_live |= self.vehicle & (b >= self.epsilon * self.belief.prior)
        if not present_live.any():
            return none.astype(np.float64)
        return present_live / present_live.sum()

    def v_ref(self) -> float:
        """The speed the MPC tracks [m/s].

        A planner that reads the humans (use_social) tracks the traffic speed it believes in
        (eq. 12, the belief's mean), capped at the speed limit; the others track the robot's
        own desired speed.
        """
        traffic = getattr(self.belief, "traffic", None)
        if self.variant.use_social and traffic is not None:
            return min(float(traffic.expected_mps), self.speed_limit_mps)
        return self.v_desired_mps

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        if self.variant.needs_truth:
            if record.truth is None:
                raise RuntimeError("oracle planner: observe_truth() must be called every step")
            tracks = record.truth.tracks
        else:
            self.belief.update(record.observation)  # own tracks, negative / social information
            tracks = self.belief.tracks
        # contingencies (comfortable braking, a factor of the comfort weight per branch): a
        # hidden agent
        return record.refined(tracks=tracks, weights=self.weights(), contingent=self.present,
                       v_ref_mps=self.v_ref())


class CurbGapAcceptance:
    """Pedestrians at the curb of a crosswalk on the route, as the robot predicts them.

    One walking up to the curb in front of a robot that can no longer stop comfortably waits
    there; one on the crosswalk walks across it (agents/robot/curb.py).
    """

    def __init__(self, curb: CurbPedestrians):
        self.curb = curb

    def reset(self) -> None:
        self.curb.reset()

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        held = self.curb.hold_at_curb(record.tracks, record.s_m, record.v_mps)
        return record.refined(tracks=self.curb.walk_across(held))


class HypothesisBranches:
    """One branch per hypothesis: the tracked objects in every one, its hidden agent in its own.

    A tracked car in a lane is predicted along its lane path (track_prediction.py), the rest at
    constant velocity; a hypothesised vehicle as a car on its lane. The pedestrian hypotheses of
    a crosswalk at which the robot tracks a pedestrian are about that pedestrian (the belief
    holds at most one hidden agent): the tracked one is predicted, not a hypothesised copy
    (also while the robot does not see it: the tracker keeps it where it was last seen).

    Args:
        belief: the robot's belief (its hypotheses and the map's lane paths).
        road_map: the static map (its crosswalks).
        times_s: (N,) the plan times [s].
    """

    def __init__(self, belief: PedestrianBelief, road_map: RoadMap, times_s: np.ndarray):
        self.lane_paths = belief.social.lane_paths
        self.crosswalks = road_map.crosswalks
        self.times_s = times_s
        # each hypothesis' hidden agent at the plan times: fixed, computed once
        self.hypothesis_objects = belief.hypothesis_objects(times_s)
        self.hypothesis_crosswalk = np.array(
            [h.crosswalk_index if h.kind == "pedestrian" else -1 for h in belief.hypotheses])

    def reset(self) -> None:
        pass

    def tracked_crosswalks(self, tracks) -> np.ndarray:
        """(L,) bool: pedestrian hypotheses of a crosswalk with a tracked pedestrian near it.

        Near: within TRACKED_REACH_M of the crosswalk.
        """
        ped_xy = tracks.xy[tracks.is_pedestrian]
        out = np.zeros(len(self.hypothesis_crosswalk), dtype=bool)
        if not len(ped_xy):
            return out
        # a few hypotheses and crosswalks: a comparison per crosswalk (np.isin sorts)
        for i, cw in enumerate(self.crosswalks):
            if cw.contains(ped_xy, TRACKED_REACH_M).any():
                out |= self.hypothesis_crosswalk == i  # the vehicles' -1 never matches
        return out

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        tracks = record.tracks
        *hidden, present = self.hypothesis_objects
        present = present & ~self.tracked_crosswalks(tracks)
        scene = along_lane_paths(ScenePrediction.from_tracks(tracks, self.times_s), tracks,
                                 self.lane_paths, self.times_s).with_extra(*hidden, present)
        return record.refined(scene=scene)


class SignalBranches:
    """The signalled traffic's futures per signal phase as branches (phase_branches.py).

    The phase belief updates from the robot's own heads (and the humans, for `social`); the
    phase weights by planner: the belief (social), the true phase (oracle), every signalled
    car stopping (aggressive), none (conservative: the tracks' prediction).

    Args:
        phase_belief: the robot's belief over the signal phase.
        branches: the phase-pattern expansion.
        variant: the planner variant.
        times_s: (N,) the plan times [s].
    """

    def __init__(self, phase_belief: SignalPhaseBelief, branches: PhaseBranches,
                 variant: RobotVariant, times_s: np.ndarray):
        self.phase_belief, self.branches = phase_belief, branches
        self.variant, self.times_s = variant, times_s

    def reset(self) -> None:
        self.phase_belief.reset()

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        belief = self.phase_belief
        if self.variant.needs_truth:
            if record.truth is not None and record.truth.signal_phase is not None:
                belief.set_phase(record.truth.signal_phase)
            phase_weights = belief.probabilities
        else:
            phase_weights = belief.update(record.decoded, record.tracks, record.v_ref_mps)
        if self.variant.weighting is HypothesisWeighting.PRESENT_LIVE:
            phase_weights = np.zeros_like(phase_weights)  # no signalled car stops
        elif self.variant.weighting is HypothesisWeighting.NONE_ONLY and not \
                self.variant.needs_truth:
            phase_weights = None  # the favourable phase: every signalled car stops
        scene, weights, contingent = self.branches.expand(
            record.scene, record.weights, record.contingent, record.tracks, phase_weights,
            self.times_s)
        return record.refined(scene=scene, weights=weights, contingent=contingent)


class CrosswalkStepOff:
    """A pedestrian waiting at the curb may step off now: one more branch (curb.py).

    The K pedestrians that may step off in front of the robot step off in the last branch (the
    tracked objects, no hidden pedestrian), with probability CurbConfig.p_step_off; the
    others, in which they keep waiting, share the rest. One that stepped off as a branch
    prepared for is met as that branch planned (its comfort factor).

    Args:
        curb: the robot's model of waiting pedestrians (shared with CurbGapAcceptance).
        times_s: (N,) the plan times [s].
    """

    def __init__(self, curb: CurbPedestrians, times_s: np.ndarray):
        self.curb, self.times_s = curb, times_s

    def reset(self) -> None:
        self.curb.reset()  # shared with CurbGapAcceptance: resetting twice is harmless

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        tracks = record.tracks
        contingent = np.maximum(record.contingent, self.curb.prepared_comfort(tracks))
        xy, heading = self.curb.step_off(tracks, record.s_m, record.v_mps, DT_S, self.times_s)
        if not len(xy):
            return record.refined(contingent=contingent)
        scene, weights = self._with_step_off(record.scene, record.weights, xy, heading)
        return record.refined(scene=scene, weights=weights,
                       contingent=np.append(contingent, True))

    def _with_step_off(self, scene: ScenePrediction, weights: np.ndarray, xy: np.ndarray,
                       heading: np.ndarray) -> tuple[ScenePrediction, np.ndarray]:
        """The scene (L + 1 branches) and weights (L + 1,) with the "steps off now" branch.

        Args:
            scene: L branches.
            weights: (L,) their weights.
            xy: (K, T, 2) the stepping-off pedestrians' predicted positions [m].
            heading: (K,) their headings [rad].
        """
        n_hyp, n_k = scene.mask.shape[0], len(xy)
        for k in range(n_k):
            scene = scene.with_extra(np.broadcast_to(xy[k], (n_hyp,) + xy[k].shape),
                                     np.full((n_hyp, xy.shape[1]), heading[k]),
                                     np.full(n_hyp, STEP_OFF_SIZE_M),
                                     np.full(n_hyp, STEP_OFF_SIZE_M),
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


class StopLines:
    """The stop-sign and signal lines on the route: the arc length to stay behind (stop.py).

    The robot stops at a stop sign until it has stood there long enough, and obeys its own
    signal head as it reads it (signal_stop.py: right turn on red after stopping); a slow robot
    short of the line pulls up to it.

    Args:
        stop_signs: the stop-sign lines on the route.
        signal_stops: the signal lines on the route.
    """

    def __init__(self, stop_signs: StopSigns, signal_stops: SignalStops):
        self.stop_signs, self.signal_stops = stop_signs, signal_stops

    def reset(self) -> None:
        self.stop_signs.reset()
        self.signal_stops.reset()

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        s0, v0 = record.s_m, record.v_mps
        stop_at = min(self.stop_signs.update(s0, v0, DT_S),
                      self.signal_stops.update(s0, v0, DT_S, record.decoded.signal_states()))
        return record.refined(stop_at_m=min(record.stop_at_m, stop_at),
                       pull_up_to_m=pull_up_target(stop_at, s0, v0, self.stop_signs.config))


class RightOfWayClaims:
    """A car with the right of way predicted at a zone the robot yields at claims it.

    In its branch (right_of_way.py): the robot waits, or clears the zone well before the car
    arrives.
    """

    def __init__(self, right_of_way: RightOfWay, times_s: np.ndarray):
        self.right_of_way, self.times_s = right_of_way, times_s

    def reset(self) -> None:
        pass

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        claims = self.right_of_way.claims(record.scene, record.s_m, record.v_mps, self.times_s)
        return record.refined(claims=claims)


class SightHoldStage:
    """Short of a lane it cannot see, the robot waits for a human that will tell (sight_hold.py).

    Pulled up to where it holds.

    Args:
        hold: the sight hold.
        hidden_vehicle: (L,) bool, the hypotheses of a present hidden vehicle.
        none_index: the hypothesis of no hidden agent.
    """

    def __init__(self, hold: SightHold, hidden_vehicle: np.ndarray, none_index: int):
        self.hold, self.hidden_vehicle, self.none_index = hold, hidden_vehicle, none_index

    def reset(self) -> None:
        pass

    def __call__(self, record: PlanningRecord) -> PlanningRecord:
        s0, v0 = record.s_m, record.v_mps
        hold_at = self.hold.stop_at(record.claims, record.weights, self.hidden_vehicle,
                                    self.none_index, record.tracks, s0, v0)
        if not hold_at < record.stop_at_m:
            return record
        return record.refined(stop_at_m=hold_at,
                       pull_up_to_m=self.hold.pull_up_to(hold_at, s0, v0))


def build_stages(context: RobotContext) -> tuple[Stage, ...]:
    """The stages of a robot, in order, chosen from the map's elements along its route.

    A crosswalk on the route brings the curb stages, a stop-sign or signal line the stop-line
    stage, a signal plan the signal branches, a conflict zone it yields at the right-of-way
    claims, and (with the sight_hold setting) a stop sign before such a zone with a hidden-car
    hypothesis the sight hold.

    Args:
        context: the robot's route, map, vehicle, MPC configuration, belief and settings.
    """
    c = context
    variant, model, vehicle = c.settings.variant, c.settings.model, c.spec.vehicle
    times = c.mpc.plan_times_s
    belief_update = BeliefUpdate(c.belief, variant, c.mpc.epsilon,
                                 min(c.spec.v_desired_mps, c.road_map.speed_limit_mps),
                                 c.road_map.speed_limit_mps)
    stages: list[Stage] = [belief_update]
    curb = CurbPedestrians(c.route, c.road_map.crosswalks, c.settings.curb, vehicle.length_m,
                           c.mpc.pedestrian_gap_m,
                           0.5 * vehicle.width_m + c.mpc.pedestrian_clearance_m)
    if curb.crosses_crosswalk:
        stages.append(CurbGapAcceptance(curb))
    stages.append(HypothesisBranches(c.belief, c.road_map, times))
    if c.road_map.signal_plan is not None:
        phase_belief = SignalPhaseBelief(c.road_map, c.spec.name, c.belief.social,
                                         c.belief.config, use_social=variant.use_social)
        stages.append(SignalBranches(
            phase_belief, PhaseBranches(c.road_map, c.belief.social.lane_paths,
                                        phase_belief.head_states, vehicle.brake_max_mps2,
                                        c.mpc.epsilon), variant, times))
    if curb.crosses_crosswalk:
        stages.append(CrosswalkStepOff(curb, times))
    stop_signs = StopSigns(c.route, c.road_map, vehicle.length_m, c.settings.stop)
    signal_stops = SignalStops(c.route, c.road_map, vehicle.length_m, c.settings.stop)
    if len(stop_signs.lines_m) or len(signal_stops.lines_m):
        stages.append(StopLines(stop_signs, signal_stops))
    right_of_way = RightOfWay(c.route, c.road_map, vehicle.length_m, c.settings.right_of_way,
                              vehicle.accel_max_mps2, c.mpc.lat_accel_max_mps2)
    if right_of_way.conflicts:
        stages.append(RightOfWayClaims(right_of_way, times))
    present = belief_update.present
    # at a stop sign, with the belief's hypotheses (one of them "none") as the MPC's first
    # branches: not with a signal plan, whose phases multiply the branches
    hold = (model.sight_hold and bool(stop_signs.lines_m.size)
            and c.road_map.signal_plan is None and bool((~present).any()))
    sight_hold = SightHold(
        right_of_way, c.belief.social, hold, vehicle.length_m, c.mpc.plan_dt_s,
        c.mpc.epsilon, c.settings.stop, c.settings.sight_hold)
    if sight_hold.active:
        stages.append(SightHoldStage(sight_hold, present & belief_update.vehicle,
                                     int(np.argmin(present))))
    return tuple(stages)
